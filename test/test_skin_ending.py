"""The vocabulary's end of a gesture: GestureEnd, the segmenter's wait, and joining rendered pieces."""

from __future__ import annotations

import numpy as np
import pytest
from skin_testing import command_node_parameters
from test_skin_multistroke import RATE, SYMBOLS, codebook, feed, polyline

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.ending import GestureEnd
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.segmentation import GestureSegmenter
from touch_lab.skin.ending_eval import FRAME_PERIOD_S, join_pieces, merge_pieces

GAP, WAIT = 0.5, 3.0
CIRCLE = [[(23.5 + 14 * np.cos(a), 23.5 + 14 * np.sin(a)) for a in np.linspace(0, 2 * np.pi, 24)]]


@pytest.fixture(scope='module')
def ending():
    """A rule over a codebook of a 2-stroke X, a 3-stroke H and a 1-stroke circle (synthetic)."""
    SYMBOLS['circle'] = CIRCLE      # for the codebook only: the other modules' tests iterate over SYMBOLS
    try:
        gestures, labels = codebook(np.random.default_rng(0), names=('X', 'H', 'circle'), per_class=10)
    finally:
        del SYMBOLS['circle']
    return GestureEnd(CloudRecogniser().fit(gestures, labels))


def lift(seg, seconds, t):
    return feed(seg, [None] * round(seconds * RATE), t, contact=False)


def test_the_first_bar_of_an_x_waits_for_the_second(ending):
    rng = np.random.default_rng(3)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=ending)
    out, t = feed(seg, polyline(SYMBOLS['X'][0], 60, rng), 0.0)
    out += lift(seg, 2.0, t)[0]                               # far longer than the short gap
    assert out == [] and seg.active and seg.stats.waited == 1
    out, t = feed(seg, polyline(SYMBOLS['X'][1], 60, rng), t + 2.0)
    assert out == []
    (x,), _ = lift(seg, GAP + 0.05, t)                        # the X is whole: the short gap ends it
    assert x.strokes == 2 and seg.stats.waited_continued == 1 and seg.stats.ended_at_bound == 0


def test_a_whole_one_stroke_gesture_ends_at_the_short_gap(ending):
    rng = np.random.default_rng(4)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=ending)
    _, t = feed(seg, polyline(CIRCLE[0], 90, rng), 0.0)
    early, t = lift(seg, GAP - 0.05, t)
    assert early == []
    (circle,), _ = lift(seg, 0.1, t)
    assert circle.strokes == 1 and seg.stats.waited == 0


def test_the_bound_ends_a_gesture_that_never_completes(ending):
    rng = np.random.default_rng(5)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=ending)
    _, t = feed(seg, polyline(SYMBOLS['H'][0], 60, rng), 0.0)
    _, t = lift(seg, 0.3, t)
    _, t = feed(seg, polyline(SYMBOLS['H'][1], 60, rng), t)         # two bars of an H: one to go
    waiting, t = lift(seg, WAIT - 0.1, t)
    assert waiting == [] and seg.active
    (h,), _ = lift(seg, 0.2, t)
    assert h.strokes == 2 and seg.stats.ended_at_bound == 1


def test_without_a_rule_the_short_gap_ends_everything_and_the_bound_is_checked():
    rng = np.random.default_rng(6)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT)
    _, t = feed(seg, polyline(SYMBOLS['X'][0], 60, rng), 0.0)
    (g,), _ = lift(seg, GAP + 0.05, t)
    assert g.strokes == 1
    with pytest.raises(ValueError, match='wait_s'):
        GestureSegmenter(gap_s=GAP, wait_s=GAP / 2)
    with pytest.raises(ValueError, match='wait_s'):
        GestureSegmenter(gap_s=GAP, wait_s=float('nan'))


def test_an_unusable_gesture_is_complete_and_the_rule_needs_ordered_points(ending):
    empty = TouchGesture.from_trajectory(np.zeros((0, 2)))
    assert ending.complete(empty)
    from touch_gestures.skin.registry import make_recogniser
    gestures, labels = codebook(np.random.default_rng(0), names=('X', 'H'), per_class=4)
    with pytest.raises(ValueError, match='ordered points'):
        GestureEnd(make_recogniser('centroid').fit(gestures, labels))
    with pytest.raises(ValueError, match='margin'):
        GestureEnd(CloudRecogniser().fit(gestures, labels), margin=-1)


def pieces_of(strokes_pts, starts):
    """One piece per stroke (as rendered at a short gap), each from its start time at 150 Hz."""
    out = []
    for pts, t0 in zip(strokes_pts, starts, strict=True):
        g = TouchGesture.from_trajectory(pts)
        g.times = t0 + np.arange(len(pts)) / RATE
        g.start_s, g.duration_s, g.frames = t0, (len(pts) - 1) / RATE, len(pts)
        out.append(g)
    return out


def test_joined_pieces_are_what_the_segmenter_cuts(ending):
    rng = np.random.default_rng(7)
    bars = [polyline(SYMBOLS['H'][k], 50, rng) for k in range(3)]
    pauses = [1.2, 0.3]                                     # a slow pen-up, then a quick one
    starts, t = [], 0.0
    for pts, pause in zip(bars, [*pauses, 0.0], strict=True):
        starts.append(t)
        t += (len(pts) - 1) / RATE + pause + FRAME_PERIOD_S
    pieces = pieces_of(bars, starts)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=ending)
    out, t = [], 0.0
    for pts, pause in zip(bars[:2], pauses, strict=True):
        o, t = feed(seg, pts, t)
        out += o
        o, t = lift(seg, pause, t)
        out += o
    o, t = feed(seg, bars[2], t)
    out += o + lift(seg, GAP + 0.05, t)[0]
    joined, latency = join_pieces(pieces, GAP, WAIT, ending)
    assert [g.strokes for g in joined] == [g.strokes for g in out] == [3]
    assert latency == [GAP]
    np.testing.assert_allclose(joined[0].trajectory, out[0].trajectory, atol=1e-6)
    assert joined[0].stroke.tolist() == out[0].stroke.tolist()
    # A fixed gap shorter than the slow pen-up splits the H; the pieces cannot show a gap below theirs.
    assert len(join_pieces(pieces, GAP)[0]) == 2
    with pytest.raises(ValueError, match='shorter'):
        join_pieces(pieces, 0.05)
    assert merge_pieces(pieces[:1]) is pieces[0]


def test_the_node_waits_in_a_multistroke_vocabulary_unless_told_not_to(tmp_path):
    from touch_gestures.skin.node import HapticCommandsNode
    from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S
    from touch_graph.runtime import Context, Parameter

    gestures, labels = codebook(np.random.default_rng(0), names=('X', 'H'), per_class=4)
    model = CloudRecogniser().fit(gestures, labels)
    given = command_node_parameters(tmp_path, model, {'X': 'stop'}, vocabulary='symbols')
    ctx = Context('sim')
    ctx.init()
    try:
        node = HapticCommandsNode(context=ctx, parameter_overrides=given)
        seg = node.stream.segmenter
        assert (seg.gap_s, seg.wait_s) == (ENDING_GAP_S, ENDING_WAIT_S) and isinstance(seg.is_complete, GestureEnd)
        assert seg.is_complete.class_min_strokes.tolist() == [3, 2]    # the file keeps each template's strokes
        node.destroy_node()
        node = HapticCommandsNode(context=ctx, parameter_overrides=[*given, Parameter('wait_s', value=0.0)])
        assert node.stream.segmenter.is_complete is None and node.stream.segmenter.gap_s == 1.5
        node.destroy_node()
    finally:
        ctx.shutdown()


def test_strokes_that_keep_coming_are_cut_at_the_limit_once():
    rng = np.random.default_rng(8)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=lambda g: False, max_duration_s=4.0)
    out, t = [], 0.0
    for _ in range(6):                                        # a stroke every 1.4 s, never a whole gesture
        o, t = feed(seg, polyline(SYMBOLS['X'][0], 60, rng), t)
        out += o
        o, t = lift(seg, 1.0, t)
        out += o
    assert [g.truncated for g in out] == [True] and seg.stats.truncated == 1
