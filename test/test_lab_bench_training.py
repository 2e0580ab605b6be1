"""``social-touch bench training`` runs the whole training path on an hour of sessions (no timings asserted)."""

from __future__ import annotations

import pytest

from touch_lab.bench.training import bench_training
from touch_sim.virtual_port import forget_devices


@pytest.fixture(autouse=True)
def fresh_devices():
    forget_devices()
    yield
    forget_devices()


def test_the_bear_with_symbolic_gestures_trains_through_train_bear_on_an_hour():
    out = bench_training(1, ('bear+symbolic',))
    result = out['bear+symbolic']
    assert out['synthetic'] is True
    assert result['minutes_of_frames'] >= 60 and result['bags'] % 2 == 0 and result['runs'] == 1
    assert result['train_s'] > 0 and result['cpu_s'] > 0
