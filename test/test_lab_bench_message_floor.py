"""``social-touch bench message-floor``: SkinFrames at 150 Hz to a subscriber, in a process of its own.

The figures are the bench's business; these tests hold what makes them meaningful: each run is a
fresh process on the client it names, it publishes at the skin's rate and its subscriber takes what
was published, and without a ROS 2 Python the output says rclpy was not measured.
"""

import sys

import pytest
from ros2_testing import require_ros2

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
    out = bench_message_floor(repeats=1, seconds=0.5)
    assert out['ours']['runs'] and out['ours']['received'][0] > 0
    assert out['rclpy'].startswith('not measured')


@pytest.mark.parametrize('kwargs', [{'repeats': 0}, {'seconds': 0.0}, {'pairs': 0}])
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
    out = bench_message_floor(repeats=1, seconds=1.0, ros2_python=sys.executable)
    for client in ('ours', 'rclpy'):
        _delivered({key: out[client][key][0] for key in ('received', 'published', 'expected')}
                   | {'percent_of_core': out[client]['percent_of_core']}, pairs=1)
