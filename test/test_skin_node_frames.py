"""SkinFrameStream and screen_gesture on hard input: garbage frames, stamps in any order, odd trajectories."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_gestures.skin.frames import SkinFrameStream
from touch_gestures.skin.gesture import TouchGesture, ideal_frame
from touch_gestures.skin.screening import MIN_EXTENT_MM, SCREEN_REASONS, gesture_extent_mm, screen_gesture
from touch_gestures.skin.segmentation import GestureSegmenter
from touch_graph.messages import get_message

SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
NS = 1_000_000_000


def frame(stamp_ns, point=None, pressure=None):
    sec, nanosec = divmod(stamp_ns, NS)
    msg = SkinFrame(header=Header(stamp=Time(sec=sec, nanosec=nanosec)), contact=point is not None,
                    pressure=ideal_frame(point).ravel() if point is not None else np.zeros(144, np.float32),
                    contact_x=float(point[0]) if point is not None else float('nan'),
                    contact_y=float(point[1]) if point is not None else float('nan'))
    if pressure is not None:
        msg._f_pressure = pressure  # past the checking property: a malformed frame made in process
    return msg


frames = st.lists(st.tuples(
    st.integers(0, 5 * NS),                                             # stamp, any order
    st.one_of(st.none(), st.tuples(st.floats(-10, 60), st.floats(-10, 60))),   # finger position or none
    st.sampled_from(['ok', 'nan', 'short', 'inf'])), max_size=120)


@settings(max_examples=60, deadline=None)
@given(frames)
def test_any_frame_stream_is_counted_and_never_raises(items):
    stream = SkinFrameStream(GestureSegmenter(max_duration_s=0.5), max_gap_s=0.1)
    gestures = []
    for stamp, point, kind in items:
        pressure = {'ok': None, 'nan': np.full(144, np.nan, np.float32), 'short': np.zeros(7, np.float32),
                    'inf': np.full(144, np.inf, np.float32)}[kind]
        gestures += stream.update(frame(1_700_000_000 * NS + stamp, point, pressure))
    gestures += stream.flush()
    bad = sum(kind != 'ok' for _, _, kind in items)
    assert stream.frames + stream.skipped['wrong_size'] + stream.skipped['non_finite'] == len(items)
    assert stream.skipped['wrong_size'] + stream.skipped['non_finite'] == bad
    for g in gestures:
        assert g.frames >= 1 and np.isfinite(g.trajectory).all() and g.duration_s >= 0
        assert screen_gesture(g) in (None, *SCREEN_REASONS)


def test_stamps_map_back_to_header_time():
    stream = SkinFrameStream(GestureSegmenter(gap_s=0.05, min_frames=2))
    with pytest.raises(ValueError, match='no frame has been fed yet'):
        stream.stamp_ns(0.0)
    t0 = 1_700_000_123 * NS + 456
    out = []
    for i in range(40):
        out += stream.update(frame(t0 + i * 10_000_000, np.array([5.0 + i, 20.0]) if i < 20 else None))
    (g,) = out
    assert stream.t0_ns == t0 and stream.end_stamp_ns(g) == t0 + 19 * 10_000_000
    assert stream.stamp_ns(g.start_s) == t0


@settings(max_examples=80, deadline=None)
@given(st.lists(st.tuples(st.floats(0, 47), st.floats(0, 47)), min_size=0, max_size=30),
       st.floats(0, 20), st.booleans(), st.booleans())
def test_screening_gives_one_reason_in_a_fixed_order(points, min_extent, multi, truncated):
    g = TouchGesture.from_trajectory(np.array(points, dtype=np.float64).reshape(-1, 2))
    g.multi_contact, g.truncated = multi, truncated
    reason = screen_gesture(g, min_extent)
    extent = gesture_extent_mm(g)
    expected = ('multi_contact' if multi else 'truncated' if truncated else 'too_few_points' if len(points) < 2
                else 'too_small' if extent < min_extent else None)
    assert reason == expected
    assert extent >= 0 and (len(points) > 0 or extent == 0)


def test_screening_rejects_bad_limits_and_its_default_is_two_taxels():
    g = TouchGesture.from_trajectory(np.array([[0.0, 0.0], [10.0, 0.0]]))
    assert pytest.approx(2 * 47 / 12) == MIN_EXTENT_MM
    with pytest.raises(ValueError):
        screen_gesture(g, float('nan'))
    with pytest.raises(ValueError):
        screen_gesture(g, 1.0, min_points=0)
