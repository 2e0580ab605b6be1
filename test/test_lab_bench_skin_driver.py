"""The skin benchmark runs and reports what the bench CLI expects (no timing is asserted)."""

from __future__ import annotations

import json

import pytest

from touch_graph.cli.main import main as social_touch
from touch_lab.bench.skin_driver import bench_decode_calibrate


def test_bench_reports_the_shared_keys():
    result = bench_decode_calibrate(repeats=1, frames=20)
    assert {'sensor', 'synthetic_data', 'us_per_frame', 'decode_us', 'calibrate_us', 'frame_period_us', 'ratio',
            'goal_ratio', 'meets_goal', 'repeats', 'frames'} <= set(result)
    assert result['sensor'] == 'skin' and result['synthetic_data'] is True and result['frames'] == 20
    assert result['frame_period_us'] == pytest.approx(1e6 / 150)
    assert result['ratio'] == pytest.approx(result['us_per_frame'] / result['frame_period_us'])
    with pytest.raises(ValueError, match='repeats'):
        bench_decode_calibrate(repeats=0)


def test_bench_cli_prints_json(capsys):
    assert social_touch(['bench', 'drivers', '--json', '--repeats', '1']) == 0
    assert json.loads(capsys.readouterr().out)['skin']['frames'] == 600
