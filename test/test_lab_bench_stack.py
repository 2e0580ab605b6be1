"""The runtime benchmarks on recorded bytes: they run, read every frame and report what the CLI prints.

No timing is asserted (machines are shared); the figures come from ``social-touch bench drivers|stack``.
"""

from __future__ import annotations

import json
import os

import pytest

from touch_driver.bear.protocol import BearDecoder
from touch_lab.bench.drivers import bench_driver
from touch_lab.bench.replay import PtyPort, record_scene
from touch_lab.bench.stack import bench_stack
from touch_lab.cli.main import main as social_touch


def test_a_recording_holds_one_whole_frame_per_period():
    rec = record_scene('bear', 5.0)
    assert rec.period == pytest.approx(1 / 3.4) and len(rec.chunks) == 17
    decoder = BearDecoder()
    assert [len(decoder.update(chunk)) for chunk in rec.chunks] == [1] * 17
    assert decoder.stats.checksum_errors == 0 and decoder.stats.sequence_gaps == 0


def test_a_pty_write_is_readable_on_the_terminal_side_when_it_returns():
    port = PtyPort()
    try:
        fd = os.open(port.path, os.O_RDWR | os.O_NOCTTY)
        port.write(b'\x00\xa5\x5a\r\n' * 100)
        assert port.readable() == 500
        assert os.read(fd, 1000) == b'\x00\xa5\x5a\r\n' * 100   # raw: no byte changed on the way
        os.close(fd)
    finally:
        port.close()


def test_driver_bench_times_the_node_and_its_parts():
    result = bench_driver(record_scene('skin', 2.0), repeats=1)
    assert result['frames'] == 300 and result['frame_period_us'] == pytest.approx(1e6 / 150)
    assert result['us_per_frame'] > 0 and result['decode_us'] > 0 and result['handle_us'] > 0
    assert result['io_us'] == pytest.approx(result['us_per_frame'] - result['decode_us'] - result['handle_us'])
    assert result['ratio'] == pytest.approx(result['us_per_frame'] / result['frame_period_us'])


def test_stack_bench_runs_every_node_on_every_sensor(capsys):
    result = bench_stack(repeats=1, duration_s=20.0)
    assert set(result['per_sensor']) == {'bear', 'patch', 'skin'}
    assert result['total']['rates_hz'] == {'bear': 3.4, 'patch': 100.0, 'skin': 150.0}
    assert result['total']['callback_errors'] == 0
    assert result['total']['outputs']['skin'] > 0 and result['total']['outputs']['bear'] > 0  # the recognisers ran
    assert 0 < result['total']['cpu_s_per_s'] < 1 and result['goal_percent'] == 3.0
    with pytest.raises(ValueError, match='repeats'):
        bench_stack(repeats=0)


def test_bench_cli_prints_json(capsys):
    assert social_touch(['bench', 'runtime', '--json', '--repeats', '1']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['target'] == 'runtime' and out['msgs_per_s'] > 0
