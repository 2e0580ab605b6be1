"""Sensor level (knight2009 V.A, V.C): the ring buffer of all 64 channels and the named active set."""

from __future__ import annotations

from collections import deque

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.sensor_level import LevelBuffer, active_sensors

BODY = BodyMap.default()


def test_defaults_are_the_papers() -> None:
    buf = LevelBuffer()
    assert buf.buffer_len == 20 and buf.threshold == 0.3 and buf.n_channels == 64


def test_window_is_chronological_and_bounded() -> None:
    buf = LevelBuffer(buffer_len=4)
    assert buf.window().shape == (0, 64)
    for i in range(10):
        buf.update(np.full(64, i / 10, dtype=np.float32))
        assert buf.window().shape == (min(i + 1, 4), 64)
    np.testing.assert_allclose(buf.window()[:, 5], [0.6, 0.7, 0.8, 0.9], rtol=1e-6)
    assert buf.window().dtype == np.float32
    assert buf.count == 10 and buf.filled == 4


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 25),
       rows=st.lists(st.one_of(st.floats(-2, 2, width=32), st.sampled_from([np.nan, np.inf, -np.inf])),
                     min_size=1, max_size=60))
def test_window_matches_a_reference_deque(n: int, rows: list[float]) -> None:
    buf = LevelBuffer(buffer_len=n)
    ref: deque = deque(maxlen=n)
    for value in rows:
        buf.update(np.full(64, value, dtype=np.float32))
        clean = 0.0 if not np.isfinite(value) else min(max(value, 0.0), 1.0)
        ref.append(clean)
    np.testing.assert_allclose(buf.window()[:, 0], np.array(ref, dtype=np.float32))
    assert np.all((buf.window() >= 0) & (buf.window() <= 1))


def test_nan_and_inf_are_counted_and_read_as_no_touch() -> None:
    buf = LevelBuffer(buffer_len=3)
    levels = np.zeros(64, dtype=np.float32)
    levels[[2, 7]] = [np.nan, np.inf]
    levels[9] = 0.8
    buf.update(levels)
    assert buf.invalid_counts[2] == 1 and buf.invalid_counts[7] == 1 and buf.invalid_counts.sum() == 2
    assert buf.latest()[2] == 0.0 and buf.latest()[7] == 0.0
    assert np.flatnonzero(buf.active()).tolist() == [9]


def test_faulty_channels_read_as_untouched() -> None:
    """A sensor stuck at full scale, flagged by the calibrator, must not look like an endless hold."""
    buf = LevelBuffer(buffer_len=3)
    faulty = np.zeros(64, dtype=bool)
    faulty[24] = True
    for _ in range(5):
        buf.update(np.ones(64, dtype=np.float32), faulty)
    assert not buf.active()[24] and buf.window()[:, 24].max() == 0.0
    assert buf.active()[25]


def test_bad_arguments_raise_value_error() -> None:
    with pytest.raises(ValueError, match='buffer_len'):
        LevelBuffer(buffer_len=0)
    with pytest.raises(ValueError, match='threshold'):
        LevelBuffer(threshold=0.0)
    with pytest.raises(ValueError, match=r'shape \(64,\)'):
        LevelBuffer().update(np.zeros(63))


def test_active_sensors_are_named_through_the_body_map() -> None:
    levels = np.zeros(64, dtype=np.float32)
    head2, sole = BODY.by_name('head2').channel, BODY.by_name('foot_left_sole').channel
    levels[[head2, sole]] = [0.9, 0.31]
    levels[13] = 1.0            # unfitted channel: never reported
    levels[0] = 0.29            # below the 30 % threshold
    out = active_sensors(levels, BODY)
    assert [(s.name, s.region, s.location) for s in out] == [('head2', 'head', 'crown'),
                                                               ('foot_left_sole', 'left_foot', 'left foot sole')]
    assert out[0].channel == head2 and out[0].level == pytest.approx(0.9)
    assert active_sensors(np.full(64, np.nan, dtype=np.float32), BODY) == []
