"""GestureSegmenter: hysteresis, multi-stroke, a touch that never ends, two fingers, bad frames."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_gestures.skin.gesture import PITCH_MM, ideal_frame
from touch_gestures.skin.segmentation import GestureSegmenter

RATE = 150.0
EMPTY = np.zeros((12, 12), np.float32)


def feed_path(seg, points, t0=0.0, contact=True):
    """Feed one frame per point at 150 Hz; returns (gestures, next time)."""
    out, t = [], t0
    for p in points:
        frame = ideal_frame(p) if contact else EMPTY
        out += seg.update(frame, contact, p if contact else None, t)
        t += 1 / RATE
    return out, t


def lift(seg, seconds, t0):
    return feed_path(seg, [None] * round(seconds * RATE), t0, contact=False)


def line(n, y=20.0):
    return [np.array([5.0 + 35.0 * k / max(n - 1, 1), y]) for k in range(n)]


def test_one_touch_is_one_gesture_after_the_hysteresis():
    seg = GestureSegmenter(gap_s=0.1)
    got, t = feed_path(seg, line(60))
    assert got == [] and seg.active
    early, t = lift(seg, 0.05, t)
    assert early == []  # still within the hysteresis
    late, t = lift(seg, 0.1, t)
    (g,) = late
    assert g.frames == 60 and len(g.trajectory) == 60 and g.strokes == 1
    assert g.trajectory.dtype == np.float32 and g.times.dtype == np.float64
    assert g.duration_s == pytest.approx(59 / RATE)
    assert g.binary_map[5, 1:11].all() and not g.binary_map[0].any()  # a row traced across
    assert not g.multi_contact and not g.truncated and not seg.active


def test_strokes_closer_than_the_hysteresis_join_longer_gaps_split():
    seg = GestureSegmenter(gap_s=0.15)
    a, t = feed_path(seg, line(30, y=10.0))
    b, t = lift(seg, 0.08, t)
    c, t = feed_path(seg, line(30, y=30.0), t)
    d, t = lift(seg, 0.3, t)
    assert a == b == c == []
    (joined,) = d
    assert joined.strokes == 2 and joined.stroke.tolist() == [0] * 30 + [1] * 30
    seg2 = GestureSegmenter(gap_s=0.15)
    first, t = feed_path(seg2, line(30))
    first += lift(seg2, 0.3, t)[0]
    second, t = feed_path(seg2, line(30), t + 0.3)
    second += seg2.flush()
    assert len(first) == 1 and len(second) == 1


def test_a_touch_that_never_ends_is_cut_once_and_state_stays_bounded():
    seg = GestureSegmenter(max_duration_s=1.0, max_frames=500)
    resting = [np.array([20.0, 20.0])] * int(5 * RATE)  # a hand resting for 5 s
    got, t = feed_path(seg, resting)
    assert len(got) == 1 and got[0].truncated and got[0].duration_s == pytest.approx(1.0, abs=0.01)
    assert seg.stats.truncated == 1
    after, t = lift(seg, 0.5, t)
    assert after == []  # the release after the cut does not emit a second gesture
    again, t = feed_path(seg, line(20), t)
    again += lift(seg, 0.5, t)[0]
    assert len(again) == 1 and not again[0].truncated
    small = GestureSegmenter(max_duration_s=100.0, max_frames=50)
    cut, _ = feed_path(small, resting[:200])
    assert len(cut) == 1 and cut[0].truncated and len(cut[0].trajectory) == 50


def _two_blob_frame(dx_taxels):
    f = np.zeros((12, 12), np.float32)
    f[5:7, 2:4] = 0.5
    f[5:7, 2 + dx_taxels:4 + dx_taxels] = 0.5
    return f


def test_two_fingers_are_flagged_one_finger_with_holes_is_not():
    for gap, expected in ((5, True), (2, False)):  # 3 empty taxels apart / 0: one blob
        seg = GestureSegmenter(min_frames=1)
        for k in range(30):
            seg.update(_two_blob_frame(gap), True, np.array([20.0, 22.0]), k / RATE)
        (g,) = seg.flush()
        assert g.multi_contact is expected, gap
    holey = np.zeros((12, 12), np.float32)
    holey[4, 4] = holey[4, 6] = holey[6, 5] = 0.3  # a pad seen through tilted domes: gaps of one taxel
    seg = GestureSegmenter()
    for k in range(30):
        seg.update(holey, True, np.array([5.5 * PITCH_MM, 5 * PITCH_MM]), k / RATE)
    assert not seg.flush()[0].multi_contact


def test_two_fingers_through_the_virtual_skin():
    from touch_driver.skin.calibration import calibrate_frames
    from touch_sim.skin.device import render_frames
    from touch_sim.skin.stimuli import StaticPress, Timeline

    scene = Timeline([StaticPress(12.0, 23.0, 1.5, at_s=0.4, for_s=0.6),
                      StaticPress(35.0, 23.0, 1.5, at_s=0.4, for_s=0.6)])
    cal = calibrate_frames(render_frames(scene, duration_s=1.3, seed=3))
    seg = GestureSegmenter()
    out = []
    for i in range(len(cal.contact)):
        if cal.tared[i]:
            out += seg.update(cal.pressure[i], bool(cal.contact[i]), cal.contact_xy_mm[i], i / RATE)
    out += seg.flush()
    assert len(out) == 1 and out[0].multi_contact
    # The contact point of two equal fingers lies between them, which is why the flag matters.
    assert 18 < np.median(out[0].trajectory[:, 0]) < 29


def test_bad_frames_are_counted_not_raised():
    seg = GestureSegmenter(min_frames=1)
    nan = np.full((12, 12), np.nan, np.float32)
    nan[3, 3] = 0.8
    seg.update(nan, True, np.array([13.0, 13.0]), 0.0)
    seg.update(ideal_frame(np.array([14.0, 13.0])), True, np.array([np.nan, np.nan]), 0.01)
    seg.update(EMPTY, False, None, 0.005)          # time went backwards: skipped
    seg.update(EMPTY, False, None, float('nan'))   # no time at all: skipped
    (g,) = seg.flush()
    assert seg.stats.nan_frames == 1 and seg.stats.missing_points == 1 and seg.stats.time_reversals == 2
    assert g.frames == 2 and len(g.trajectory) == 1 and np.isfinite(g.peak_map).all()
    with pytest.raises(ValueError, match='pressure must be'):
        seg.update(np.zeros(10), True, None, 1.0)


def test_taps_shorter_than_min_frames_are_dropped():
    seg = GestureSegmenter(min_frames=5)
    got, t = feed_path(seg, line(3))
    got += lift(seg, 0.5, t)[0]
    assert got == [] and seg.stats.too_short == 1


@pytest.mark.parametrize('kwargs', [{'gap_s': -1}, {'max_duration_s': 0}, {'min_frames': 0},
                                    {'map_threshold': float('nan')}, {'map_relative': 1.0},
                                    {'multi_fraction': 2.0}])
def test_bad_parameters_are_refused(kwargs):
    with pytest.raises(ValueError):
        GestureSegmenter(**kwargs)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.booleans(), st.floats(0, 47), st.floats(0, 47), st.sampled_from([0.0, 0.3, np.nan])),
                min_size=1, max_size=300))
def test_any_frame_stream_gives_consistent_gestures(frames):
    seg = GestureSegmenter(gap_s=0.05, max_duration_s=0.5, min_frames=2, max_frames=40)
    out = []
    for k, (contact, x, y, level) in enumerate(frames):
        pressure = ideal_frame(np.array([x, y])) * (1.0 if np.isnan(level) else level + 0.1)
        if np.isnan(level):
            pressure[0, 0] = np.nan
        out += seg.update(pressure if contact else EMPTY, contact, np.array([x, y]) if contact else None, k / RATE)
    out += seg.flush()
    starts = sum(1 for i, f in enumerate(frames) if f[0] and (i == 0 or not frames[i - 1][0]))
    assert len(out) <= starts + len(frames) // 40 + 1
    for g in out:
        assert len(g.trajectory) <= g.frames <= 40 and g.duration_s <= 0.5 + 1e-9
        assert np.all(np.diff(g.times) > 0) and np.isfinite(g.trajectory).all() and np.isfinite(g.peak_map).all()
        assert g.frames >= 2 or g.truncated


@settings(max_examples=200, deadline=None)
@given(base_ns=st.integers(0, 2 * 10**18), gap_frames=st.integers(1, 400))
def test_a_lift_of_exactly_gap_s_ends_the_gesture_on_that_frame(base_ns, gap_frames):
    # Stamps as the node makes them: integer ns from the header, made float seconds (sec + nanosec / 1e9).
    # At 100 Hz a gap of k frames is exactly k * 10 ms; float rounding must not make it one frame late.
    period_ns = 10_000_000
    seg = GestureSegmenter(gap_s=gap_frames * period_ns / 1e9, min_frames=2)
    touch = np.zeros((12, 12), np.float32)
    touch[3, 4] = 1.0

    def t(k):
        ns = base_ns + k * period_ns
        return ns // 10**9 + (ns % 10**9) / 1e9

    for k in range(5):
        assert seg.update(touch, True, np.array([17.0, 13.7]), t(k)) == []
    last = 4
    for k in range(last + 1, last + gap_frames):
        assert seg.update(np.zeros((12, 12), np.float32), False, None, t(k)) == [], k - last
    assert len(seg.update(np.zeros((12, 12), np.float32), False, None, t(last + gap_frames))) == 1
