"""``social-touch bench message-floor``: SkinFrames at 150 Hz to a subscriber, in a process of its own.

The figures are the bench's business; these tests hold what makes them meaningful: each run is a
fresh process on the client it names, it publishes at the skin's rate and its subscriber takes what
was published, and without a ROS 2 Python the output says rclpy was not measured.
"""

import sys

import pytest
from ros2_testing import require_ros2

from touch_lab.bench import message_floor
from touch_lab.bench.message_floor import DEPTH, RATE_HZ, bench_message_floor, measure


def _delivered(run: dict, pairs: int) -> None:
    # Timers skip missed periods (rclpy's rule): at most one more publication per pair than the nominal
    # rate gives in the window. Frames queued before the window opened are received in it: at most a
    # queue's depth per pair.
    assert 0 < run['published'] <= run['expected'] + pairs
    assert 0 < run['received'] <= run['published'] + DEPTH * pairs
    assert run['percent_of_core'] > 0


def test_one_run_on_our_runtime_publishes_at_the_skin_rate_and_receives_it():
    run = measure(sys.executable, shim=True, seconds=1.0, pairs=2)
    assert run['client'] == 'ours'
    assert run['expected'] == pytest.approx(2 * RATE_HZ, abs=2)
    _delivered(run, pairs=2)


def test_without_a_ros2_python_only_ours_is_measured_and_the_output_says_so(monkeypatch):
    monkeypatch.delenv('SOCIAL_TOUCH_ROS2_PYTHON', raising=False)
    out = bench_message_floor(repeats=1, seconds=0.5, pairs=(1,))
    assert out['ours'][1]['runs'] and out['ours'][1]['received'][0] > 0
    assert 'per_extra_pair' not in out['ours']          # one count: no slope
    assert out['rclpy'].startswith('not measured')


def test_the_cost_per_extra_pair_is_the_slope_between_the_first_and_last_count(monkeypatch):
    costs = {1: 3.0, 2: 4.5, 4: 7.5}
    monkeypatch.setattr(message_floor, 'measure', lambda python, shim, seconds, pairs: {
        'client': 'ours', 'percent_of_core': costs[pairs], 'received': 1, 'published': 1, 'expected': 1,
        'load_average_1min': 0.0})
    monkeypatch.delenv('SOCIAL_TOUCH_ROS2_PYTHON', raising=False)
    out = bench_message_floor(repeats=1, seconds=0.5, pairs=(4, 1, 2, 1))
    assert [n for n in out['ours'] if n != 'per_extra_pair'] == [1, 2, 4]
    assert out['ours']['per_extra_pair'] == 1.5


@pytest.mark.parametrize('kwargs', [{'repeats': 0}, {'seconds': 0.0}, {'pairs': ()}, {'pairs': (0, 1)}])
def test_nonsense_arguments_are_refused(kwargs):
    with pytest.raises(ValueError):
        bench_message_floor(**kwargs)


def test_a_python_without_the_client_is_a_clear_error(tmp_path):
    broken = tmp_path / 'python'
    broken.write_text('#!/bin/sh\nexit 3\n')
    broken.chmod(0o755)
    with pytest.raises(RuntimeError, match='failed with 3'):
        measure(str(broken), shim=False, seconds=0.5, pairs=1)


@pytest.mark.ros2
def test_real_rclpy_and_ours_each_carry_the_frames():
    require_ros2()
    out = bench_message_floor(repeats=1, seconds=1.0, pairs=(1,), ros2_python=sys.executable)
    for client in ('ours', 'rclpy'):
        row = out[client][1]
        _delivered({key: row[key][0] for key in ('received', 'published', 'expected')}
                   | {'percent_of_core': row['percent_of_core']}, pairs=1)
