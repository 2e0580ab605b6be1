"""Multi-stroke gestures: the gap, the point-cloud recogniser, the per-vocabulary rule, the pause table."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_gestures.skin.clouds import CloudRecogniser, cloud_features
from touch_gestures.skin.gesture import TouchGesture, ideal_frame
from touch_gestures.skin.segmentation import MULTISTROKE_GAP_S, GestureSegmenter, default_gap_s
from touch_lab.skin.gaps import gap_table, pause_percentiles_s
from touch_lab.skin.recognisers import make_recogniser
from touch_lab.skin.recognisers.auto import AutoRecogniser, codebook_accuracy
from touch_sim.skin.traces import TraceSample

RATE = 150.0
EMPTY = np.zeros((12, 12), np.float32)

#: Symbols as strokes of (x, y) corners in mm on the skin: people trace them in any order and direction.
SYMBOLS = {
    'X': [[(10, 10), (37, 37)], [(37, 10), (10, 37)]],
    'plus': [[(23.5, 8), (23.5, 39)], [(8, 23.5), (39, 23.5)]],
    'H': [[(10, 8), (10, 39)], [(37, 8), (37, 39)], [(10, 23.5), (37, 23.5)]],
    'T': [[(8, 10), (39, 10)], [(23.5, 10), (23.5, 39)]],
    'Z': [[(10, 10), (37, 10), (10, 37), (37, 37)]],
}


def polyline(corners, n, rng, jitter=0.6):
    """(n, 2) points along the corners, with a little hand tremor."""
    c = np.asarray(corners, dtype=np.float64)
    seg = np.hypot(*np.diff(c, axis=0).T)
    cum = np.r_[0, np.cumsum(seg)]
    s = np.linspace(0, cum[-1], n)
    pts = np.column_stack([np.interp(s, cum, c[:, 0]), np.interp(s, cum, c[:, 1])])
    return pts + rng.normal(0, jitter, pts.shape)


def symbol(name, rng, shuffle=True, points=40):
    """A TouchGesture of ``name`` with its strokes in a random order and direction (when ``shuffle``)."""
    strokes = [list(s) for s in SYMBOLS[name]]
    if shuffle:
        strokes = [s[::-1] if rng.random() < 0.5 else s for s in strokes]
        strokes = [strokes[i] for i in rng.permutation(len(strokes))]
    pts, ids = [], []
    for k, s in enumerate(strokes):
        p = polyline(s, int(points * rng.uniform(0.7, 1.4)), rng)
        pts.append(p)
        ids.append(np.full(len(p), k))
    g = TouchGesture.from_trajectory(np.concatenate(pts))
    g.stroke = np.concatenate(ids).astype(np.int16)
    g.strokes = len(strokes)
    return g


def codebook(rng, names=tuple(SYMBOLS), per_class=8, shuffle=True):
    gestures, labels = [], []
    for name in names:
        for _ in range(per_class):
            gestures.append(symbol(name, rng, shuffle))
            labels.append(name)
    return gestures, labels


# ----------------------------------------------------------------------------- segmentation
def feed(seg, points, t, contact=True):
    out = []
    for p in points:
        out += seg.update(ideal_frame(p) if contact else EMPTY, contact, p if contact else None, t)
        t += 1 / RATE
    return out, t


def test_default_gap_follows_the_vocabulary():
    assert default_gap_s(1) < 0.5 < default_gap_s(2) == MULTISTROKE_GAP_S


def test_an_x_with_a_slow_pen_up_is_one_gesture_with_the_multistroke_gap():
    rng = np.random.default_rng(1)
    seg = GestureSegmenter(gap_s=MULTISTROKE_GAP_S)
    a, t = feed(seg, polyline(SYMBOLS['X'][0], 60, rng), 0.0)
    b, t = feed(seg, [None] * int(0.8 * RATE), t, contact=False)   # 0.8 s: the 90th percentile pause
    c, t = feed(seg, polyline(SYMBOLS['X'][1], 60, rng), t)
    assert a == b == c == []
    early, t = feed(seg, [None] * int((MULTISTROKE_GAP_S - 0.1) * RATE), t, contact=False)
    assert early == [] and seg.active          # the gap has not passed: no command yet
    (x,), t = feed(seg, [None] * int(0.2 * RATE), t, contact=False)
    assert x.strokes == 2 and sorted(set(x.stroke.tolist())) == [0, 1]
    # The same lift with the single-stroke gap: two gestures.
    seg = GestureSegmenter(gap_s=default_gap_s(1))
    out, t = feed(seg, polyline(SYMBOLS['X'][0], 60, rng), 0.0)
    out += feed(seg, [None] * int(0.8 * RATE), t, contact=False)[0]
    out += feed(seg, polyline(SYMBOLS['X'][1], 60, rng), t + 0.8)[0] + seg.flush()
    assert len(out) == 2


# ----------------------------------------------------------------------------- features
@settings(max_examples=40, deadline=None)
@given(gap=st.floats(5.0, 40.0), n=st.integers(8, 64))
def test_cloud_points_lie_on_the_ink_never_in_the_air(gap, n):
    """Two horizontal strokes ``gap`` mm apart: every resampled point is on one of them."""
    pts = np.array([[0.0, 0.0], [10.0, 0.0], [0.0, gap], [10.0, gap]])
    f = cloud_features(pts, np.array([0, 0, 1, 1]), n).reshape(n, 2)
    ys = np.unique(np.round(f[:, 1], 5))
    assert len(ys) == 2                       # two rows of points, none in between
    assert np.isfinite(f).all() and np.abs(f).max() <= 1.0 + 1e-6


def test_one_point_and_a_dab_are_usable_and_finite():
    f = cloud_features(np.array([[3.0, 4.0]]), np.array([0]), 16)
    assert f.shape == (32,) and np.all(f == 0)
    g = TouchGesture.from_trajectory(np.zeros((0, 2)))
    rec = CloudRecogniser().fit(*codebook(np.random.default_rng(0), per_class=3))
    assert rec.predict(g).rejected == 'unusable'
    dab = rec.predict(TouchGesture.from_trajectory(np.full((5, 2), 20.0)))
    assert np.isfinite(dab.distance)


# ----------------------------------------------------------------------------- recogniser
@pytest.mark.parametrize('exact', [0, 4, 1000])
def test_cloud_reads_symbols_whatever_the_stroke_order_and_direction(exact):
    rng = np.random.default_rng(2)
    rec = CloudRecogniser(exact=exact).fit(*codebook(rng, shuffle=False))  # templates in one order only
    tests = [(name, symbol(name, rng)) for name in SYMBOLS for _ in range(6)]
    hits = sum(rec.predict(g).nearest == name for name, g in tests)
    assert hits == len(tests)


def test_exact_matching_is_a_true_distance_never_beaten_by_a_bound():
    """With exact matching on the closest few, the reported distance of the winner is its matching cost."""
    rng = np.random.default_rng(3)
    gestures, labels = codebook(rng)
    full = CloudRecogniser(exact=10_000).fit(gestures, labels)
    few = CloudRecogniser(exact=4).fit(gestures, labels)
    for name in SYMBOLS:
        g = symbol(name, rng)
        a, b = full.predict(g), few.predict(g)
        assert a.nearest == b.nearest == name
        assert b.distance == pytest.approx(a.distance, rel=1e-9)


def test_a_trace_ten_times_longer_than_the_templates_and_one_template_per_class():
    rng = np.random.default_rng(4)
    gestures, labels = codebook(rng, per_class=1)
    rec = CloudRecogniser().fit(gestures, labels)
    assert np.isfinite(rec.class_thresholds_).all()
    long_x = symbol('X', rng, points=400)      # 10x the points of the templates
    assert rec.predict(long_x).nearest == 'X'


# ----------------------------------------------------------------------------- the rule
def lines(rng, n):
    out, labels = [], []
    for _ in range(n):
        y = rng.uniform(15, 32)
        pts = polyline([(8, y), (39, y)], int(rng.integers(30, 60)), rng)
        for name, p in (('line_right', pts), ('line_left', pts[::-1])):
            g = TouchGesture.from_trajectory(p, np.arange(len(p)) / RATE)
            out.append(g)
            labels.append(name)
    return out, labels


def test_the_rule_keeps_direction_where_the_vocabulary_needs_it():
    rng = np.random.default_rng(5)
    gestures, labels = lines(rng, 10)
    auto = AutoRecogniser().fit(gestures, labels)
    assert auto.choice_ == 'trace' and auto.direction_aware and auto.reason_.startswith('direction')
    cloud, trace = auto.evidence_['fused'], auto.evidence_['trace']
    assert max(cloud.values()) < 0.75 < min(trace.values())   # one cloud for two directions
    g, _ = lines(rng, 1)
    assert auto.predict(g[0]).label == 'line_right' and auto.predict(g[1]).label == 'line_left'


def test_the_rule_takes_the_cloud_where_people_vary_the_stroke_order():
    rng = np.random.default_rng(6)
    auto = AutoRecogniser().fit(*codebook(rng, per_class=10))
    assert auto.choice_ == 'fused' and auto.reason_ == 'multi-stroke vocabulary', auto.evidence_
    assert auto.predict(symbol('H', rng)).label == 'H'
    # One template per class: nothing to measure on, the vocabulary still has multi-stroke gestures.
    assert make_recogniser('auto').fit(*codebook(rng, per_class=1)).choice_ == 'fused'


def test_codebook_accuracy_of_a_class_with_one_template_is_nan():
    rng = np.random.default_rng(7)
    gestures, labels = codebook(rng, names=('X', 'H'), per_class=3)
    acc = codebook_accuracy(CloudRecogniser().fit([*gestures, symbol('T', rng)], [*labels, 'T']))
    assert np.isnan(acc[list(sorted({*labels, 'T'})).index('T')]) and np.nanmin(acc) == 1.0


# ----------------------------------------------------------------------------- pauses
def sample(pauses_ms):
    t, xs, ids = [], [], []
    now = 0.0
    for k, pause in enumerate([0.0, *pauses_ms]):
        now += pause
        t += [now, now + 100]
        xs += [0.0, 1.0]
        ids += [k, k]
        now += 100
    return TraceSample('1', 'v', 'g', '0', np.array(xs), np.zeros(len(xs)), np.array(t), np.array(ids))


def test_gap_table_and_pause_percentiles():
    samples = [sample([]), sample([300]), sample([300, 1200]), sample([5000])]
    table = {r['gap_s']: r['whole'] for r in gap_table(samples, [0.2, 0.5, 1.5, 6.0])}
    assert table == {0.2: 0.25, 0.5: 0.5, 1.5: 0.75, 6.0: 1.0}
    assert pause_percentiles_s(samples, [50])['p50'] == pytest.approx(0.75)
    assert pause_percentiles_s([sample([])]) == {}
    with pytest.raises(ValueError):
        gap_table([])
