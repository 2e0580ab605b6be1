"""The vocabulary's end of a gesture: GestureEnd, the segmenter's wait, and joining rendered pieces."""

from __future__ import annotations

import numpy as np
import pytest
from skin_testing import command_node_parameters
from test_skin_multistroke import RATE, SYMBOLS, codebook, feed, polyline, symbol

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.ending import GestureEnd
from touch_gestures.skin.fused import FusedRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.segmentation import GestureSegmenter, Verdict
from touch_lab.skin import ending_eval
from touch_lab.skin.ending_eval import FRAME_PERIOD_S, cut_pieces, join_pieces, merge_pieces
from touch_sim.skin.render import RenderedSample

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


def test_the_bound_ends_a_prefix_that_never_completes(ending):
    rng = np.random.default_rng(5)
    prefix_rule = GestureEnd(ending.recogniser, unfinished=False)   # fewer strokes than H's: a prefix
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=prefix_rule)
    _, t = feed(seg, polyline(SYMBOLS['H'][0], 60, rng), 0.0)
    _, t = lift(seg, 0.3, t)
    _, t = feed(seg, polyline(SYMBOLS['H'][1], 60, rng), t)         # two bars of an H: one to go
    waiting, t = lift(seg, WAIT - 0.1, t)
    assert waiting == [] and seg.active
    (h,), _ = lift(seg, 0.2, t)
    assert h.strokes == 2 and seg.stats.ended_at_bound == 1 and seg.stats.ended_unfinished == 0


def test_strokes_that_can_be_no_whole_gesture_wait_until_the_limit(ending):
    """Two bars of an H, whose codebook has 3-stroke H's only: unfinished, so a pause past the bound
    still joins the third bar; with no third bar the gesture ends max_duration_s after its start."""
    rng = np.random.default_rng(9)
    bars = [polyline(SYMBOLS['H'][k], 60, rng) for k in range(3)]
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=ending, max_duration_s=8.0)
    _, t = feed(seg, bars[0], 0.0)
    _, t = lift(seg, 0.3, t)
    _, t = feed(seg, bars[1], t)
    assert ending(seg.partial()) is Verdict.UNFINISHED and not ending.complete(seg.partial())
    waiting, t = lift(seg, WAIT + 2.0, t)                             # past the bound: still waiting
    assert waiting == [] and seg.active
    _, t = feed(seg, bars[2], t)
    (h,), t = lift(seg, GAP + 0.05, t)                                # the H is whole now
    assert h.strokes == 3 and seg.stats.waited_continued == 1 and seg.stats.ended_at_bound == 0
    _, t = feed(seg, bars[0], t)
    _, t = lift(seg, 0.3, t)
    start, (_, t) = t - 0.3 - len(bars[0]) / RATE, feed(seg, bars[1], t)
    out, t = lift(seg, 8.0 - (t - start) - 0.1, t)                   # just before the limit
    assert out == [] and seg.active
    (two,), _ = lift(seg, 0.2, t)
    assert two.strokes == 2 and not two.truncated and seg.stats.ended_unfinished == seg.stats.ended_at_bound == 1


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
    from touch_lab.skin.recognisers import make_recogniser
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


def test_joined_pieces_wait_for_unfinished_strokes_as_the_segmenter_does(ending):
    rng = np.random.default_rng(10)
    bars = [polyline(SYMBOLS['H'][k], 50, rng) for k in range(3)]

    def pieces_with(pauses):
        starts, t = [], 0.0
        for pts, pause in zip(bars, [*pauses, 0.0], strict=True):
            starts.append(t)
            t += (len(pts) - 1) / RATE + pause + FRAME_PERIOD_S
        return pieces_of(bars, starts)

    slow = pieces_with([0.3, 5.0])                          # a 5 s pause after two bars: past the bound
    joined, latency = join_pieces(slow, GAP, WAIT, ending)
    assert [g.strokes for g in joined] == [3] and latency == [GAP]
    prefix_rule = GestureEnd(ending.recogniser, unfinished=False)
    cuts = list(cut_pieces(slow, GAP, WAIT, prefix_rule))
    assert [(c.gesture.strokes, c.reason, c.verdict) for c in cuts] == [(2, 'bound', Verdict.PREFIX),
                                                                        (1, 'end', Verdict.PREFIX)]
    # Past the limit (10 s from the start): the two bars end there, the wait being the time left.
    cuts = list(cut_pieces(pieces_with([0.3, 11.0]), GAP, WAIT, ending))
    two = cuts[0].gesture
    assert [(c.gesture.strokes, c.reason) for c in cuts] == [(2, 'limit'), (1, 'end')]
    assert cuts[0].latency_s == pytest.approx(10.0 - two.duration_s)
    # A next stroke starting after the limit while the gesture waits: the segmenter truncates there.
    cuts = list(cut_pieces(pieces_with([0.3, 9.5]), GAP, 12.0, prefix_rule))
    assert [(c.gesture.strokes, c.reason, c.gesture.truncated) for c in cuts] == [(2, 'truncated', True)]


def rendered_h(subject, sample, pauses, rng):
    """An H traced with ``pauses`` (s) between its bars, as pieces rendered at a short gap."""
    bars = [polyline(SYMBOLS['H'][k], 50, rng) for k in range(3)]
    starts, t = [], 0.0
    for pts, pause in zip(bars, [*pauses, 0.0], strict=True):
        starts.append(t)
        t += (len(pts) - 1) / RATE + pause + FRAME_PERIOD_S
    return RenderedSample(subject, 'v', 'H', sample, pieces_of(bars, starts))


def test_the_causes_and_the_table_count_what_cut_each_sample():
    rng = np.random.default_rng(11)
    samples = [rendered_h(s, f'{s}{k}', [0.3, 0.4], rng) for s in 'ab' for k in range(4)]
    samples += [rendered_h('a', 'slow', [0.3, 5.0], rng),          # whole only if unfinished strokes wait
                rendered_h('b', 'slower', [12.0, 0.3], rng)]       # a pause after a bar alone: a prefix
    circles = [pieces_of([polyline(CIRCLE[0], 60, rng)], [0.0]) for _ in range(8)]
    samples += [RenderedSample('ab'[k % 2], 'v', 'circle', f'c{k}', c) for k, c in enumerate(circles)]
    strokes = {(r.subject, r.variant, r.label, r.sample): sum(p.strokes for p in r.gestures) for r in samples}
    strokes[('a', 'v', 'circle', 'c0')] = 2                          # as if the skin had joined two strokes

    def causes(rule):
        return ending_eval.ending_causes(samples, CloudRecogniser, strokes, GAP, WAIT, rule)

    after, before = causes('strokes-unfinished'), causes('fractions')
    assert after['per_class']['H']['whole'] == 9 and after['per_class']['H']['pause over the bound'] == 1
    assert before['per_class']['H']['whole'] == 8 and before['per_class']['H']['pause over the bound'] == 2
    assert after['totals']['samples'] == len(samples) and after['per_class']['circle']['whole'] == 8
    assert after['rendering'] == {'circle': {'strokes joined': 1, 'stroke broken': 0}}
    assert sum(after['bound_pauses'].values()) == 1 and after['bound_pauses']['10-inf s'] == 1
    configs = [(GAP, WAIT, 'fractions'), (GAP, WAIT, 'strokes-unfinished'), (GAP, None, None)]
    rows = ending_eval.ending_table(samples, CloudRecogniser, configs)
    assert [round(r['whole'] * len(samples)) for r in rows] == [16, 17, 16]
    assert rows[2]['latency_median_s'] == GAP and rows[2]['waits_after'] == 0


def test_the_node_waits_in_a_multistroke_vocabulary_unless_told_not_to(tmp_path):
    from touch_gestures.skin.node import HapticCommandsNode
    from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S
    from touch_graph.runtime import Context, Parameter

    gestures, labels = codebook(np.random.default_rng(0), names=('X', 'H'), per_class=4)
    model = FusedRecogniser().fit(gestures, labels)   # the multi-stroke recogniser the robot runs
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


def test_stroke_prefixes_cut_templates_between_strokes_and_fall_back_to_fractions(ending):
    from touch_gestures.skin.early import template_prefixes

    assert ending.prefixes == 'strokes' and sorted(ending._stroke_prefixes) == [1, 2]
    # k = 1: the X's and H's (more than one stroke); k = 2: the H's only.
    assert [len(m.templates_) for m in ending._stroke_prefixes.values()] == [20, 10]
    assert list(ending._stroke_prefixes[2].classes_) == ['H']
    rng = np.random.default_rng(12)
    x = symbol('X', rng)
    first_bar = TouchGesture.from_trajectory(x.trajectory[x.stroke == 0])
    assert ending(x) is Verdict.WHOLE and ending(first_bar) is not Verdict.WHOLE
    # Per-template fractions cut each template as one fraction would.
    points = rng.normal(size=(3, 16, 2))
    both = template_prefixes(points, np.array([0.5, 0.25, 0.5]), 'cloud')
    np.testing.assert_allclose(both[1], template_prefixes(points[1:2], 0.25, 'cloud')[0], atol=1e-6)
    np.testing.assert_allclose(both[[0, 2]], template_prefixes(points[[0, 2]], 0.5, 'cloud'), atol=1e-6)
    # A codebook that does not know its templates' strokes (an older file): the fractions.
    old = CloudRecogniser().fit([x, first_bar], ['X', 'bar'])
    old.set_codebook(old.templates_, old.classes_[old.template_labels_])
    assert GestureEnd(old).prefixes == 'fractions' and GestureEnd(old).class_min_strokes is None
    with pytest.raises(ValueError, match='prefixes'):
        GestureEnd(old, prefixes='halves')
