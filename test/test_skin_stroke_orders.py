"""A gesture's strokes in another order (touch_gestures.skin.stroke_orders) and the fused trace's use of them."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_skin_multistroke import SYMBOLS, polyline

from touch_gestures.skin.fused import FusedRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.stroke_orders import every_order, reordered, split_strokes
from touch_lab.skin.recognisers import load_codebook, save_codebook


def stroke_spans(stroke):
    """The strokes as slices of the path (runs of one stroke id, as split_strokes cuts them)."""
    sizes = [len(part) for part in split_strokes(np.zeros(len(stroke)), stroke)] if len(stroke) else []
    ends = np.cumsum(sizes, dtype=int)
    return [slice(int(e - n), int(e)) for n, e in zip(sizes, ends, strict=True)]


def in_strokes(g):
    """The gesture's strokes and their clocks, as reordered takes them."""
    return split_strokes(g.trajectory, g.stroke), split_strokes(g.times, g.stroke)


def strokes_gesture(strokes, lifts, rate=150.0):
    """A gesture of the given (n_k, 2) strokes with the given lifts (s) between them."""
    points, times, ids, t = [], [], [], 0.0
    for k, s in enumerate(strokes):
        if k:
            t += lifts[k - 1]
        own = np.arange(len(s)) / rate
        points.append(s)
        times.append(t + own)
        ids.append(np.full(len(s), k, dtype=np.int16))
        t += own[-1]
    g = TouchGesture.from_trajectory(np.concatenate(points), np.concatenate(times))
    g.stroke = np.concatenate(ids)
    g.strokes = len(strokes)
    return g


@st.composite
def multi_stroke(draw):
    k = draw(st.integers(1, 4))
    sizes = draw(st.lists(st.integers(1, 6), min_size=k, max_size=k))
    lifts = draw(st.lists(st.floats(0.0, 20.0), min_size=k - 1, max_size=k - 1))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    return strokes_gesture([rng.uniform(0, 47, (n, 2)) for n in sizes], lifts)


@given(multi_stroke(), st.data())
def test_a_reordered_path_keeps_each_stroke_and_the_lifts_in_turn(g, data):
    spans = stroke_spans(g.stroke)
    order = tuple(data.draw(st.permutations(range(len(spans)))))
    points, times = reordered(*in_strokes(g), order)
    assert points.shape == g.trajectory.shape and times.dtype == np.float64
    new, start = [], 0
    for index in order:   # the new path's strokes: the old ones' lengths, in the new order
        size = spans[index].stop - spans[index].start
        new.append(slice(start, start + size))
        start += size
    # Times: float64 sums of at most 4 strokes' clocks and 3 lifts, each under 25 s: within a few ulps of 100 s.
    atol = 8 * np.spacing(100.0)
    for s, index in zip(new, order, strict=True):
        old = spans[index]
        np.testing.assert_array_equal(points[s], g.trajectory[old])   # points and direction kept
        np.testing.assert_allclose(times[s] - times[s.start], g.times[old] - g.times[old.start], rtol=0, atol=atol)
    lifts = [g.times[b.start] - g.times[a.stop - 1] for a, b in itertools.pairwise(spans)]
    new_lifts = [times[b.start] - times[a.stop - 1] for a, b in itertools.pairwise(new)]
    np.testing.assert_allclose(new_lifts, lifts, rtol=0, atol=atol)
    assert (np.diff(times) >= -atol).all() and times[0] == g.times[0]


@given(multi_stroke(), st.integers(1, 4))
def test_every_order_lists_k_factorial_paths_the_traced_order_first(g, max_strokes):
    k = len(stroke_spans(g.stroke))
    paths = every_order(g, max_strokes)
    assert len(paths) == (math.factorial(k) if 2 <= k <= max_strokes else 1)
    np.testing.assert_array_equal(paths[0][0], g.trajectory)
    np.testing.assert_array_equal(paths[0][1], g.times)
    for points, times in paths:   # the same points, in another order of whole strokes
        assert sorted(map(tuple, points.tolist())) == sorted(map(tuple, g.trajectory.tolist()))
        assert len(times) == len(g.times)
    # Each stroke comes first in (k - 1)! of them (the strokes' first points: uniform floats, distinct).
    starts = [tuple(g.trajectory[s.start]) for s in stroke_spans(g.stroke)]
    firsts = [starts.index(tuple(points[0])) for points, _ in paths]
    assert len(paths) == 1 or sorted(set(firsts)) == list(range(k))


def test_a_bad_order_and_an_empty_path():
    g = strokes_gesture([np.zeros((2, 2)), np.ones((2, 2))], [0.5])
    for bad in ((0,), (0, 0), (1, 2), (0, 1, 2)):
        with pytest.raises(ValueError, match='each of the 2 strokes once'):
            reordered(*in_strokes(g), bad)
    empty = TouchGesture.from_trajectory(np.zeros((0, 2)))
    assert stroke_spans(empty.stroke) == [] and len(every_order(empty, 3)) == 1
    points, times = reordered([], [], ())
    strokes, clocks = in_strokes(g)
    with pytest.raises(ValueError, match='one clock per stroke'):
        reordered(strokes, clocks[:1], (1, 0))
    with pytest.raises(ValueError, match='at least one point'):
        reordered([np.zeros((0, 2)), np.ones((1, 2))], [np.zeros(0), np.zeros(1)], (1, 0))
    assert points.shape == (0, 2) and times.shape == (0,)


def bars(first, second, rng, lift=0.4):
    """An X traced with the bar ``first`` (0: top-left to bottom-right, 1: top-right to bottom-left) first."""
    strokes = [polyline(SYMBOLS['X'][i], 30, rng) for i in (first, second)]
    return strokes_gesture(strokes, [lift])


def pitchfork(rng):
    """A U (left to right, through the bottom) then a stem down its middle: not an X."""
    u = polyline([(8, 8), (12, 33), (35, 33), (39, 8)], 40, rng)
    return strokes_gesture([u, polyline([(23.5, 5), (23.5, 42)], 30, rng)], [0.4])


def test_the_trace_reads_an_x_written_in_another_order_as_an_x():
    rng = np.random.default_rng(3)
    gestures = [bars(1, 0, rng) for _ in range(6)] + [pitchfork(rng) for _ in range(6)]
    labels = ['X'] * 6 + ['pitchfork'] * 6
    query = bars(0, 1, rng)   # nobody in the codebook starts with this bar
    as_traced = FusedRecogniser(stroke_orders=1).fit(gestures, labels)
    every = FusedRecogniser().fit(gestures, labels)
    # Two strokes: two orders per template (the rest of the 3! slots are copies, left out of the search).
    assert len(as_traced.trace_.templates_) == 12 and len(every.trace_.templates_) == 24
    x, fork = list(every.classes_).index('X'), list(every.classes_).index('pitchfork')
    far = as_traced.trace_.class_distances(query)
    assert far[x] > far[fork]   # in the order traced, the trace reads a pitchfork
    near = every.trace_.class_distances(query)
    assert near[x] < 0.5 * far[x] and near[x] < near[fork]   # the right bars, once the orders agree
    assert (near <= far).all()   # more readings of the same templates: never farther
    # The cloud's side is the same codebook.
    np.testing.assert_array_equal(every.cloud_.class_distances(query), as_traced.cloud_.class_distances(query))


def test_a_codebook_of_one_order_per_template_still_loads_and_a_wrong_width_is_refused(tmp_path):
    rng = np.random.default_rng(4)
    gestures = [bars(1, 0, rng) for _ in range(4)] + [pitchfork(rng) for _ in range(4)]
    labels = ['X'] * 4 + ['pitchfork'] * 4
    one = FusedRecogniser(stroke_orders=1).fit(gestures, labels)   # the layout of codebooks made before
    assert one.templates_.shape[1] == one.cloud_width + 64
    loaded = load_codebook(save_codebook(tmp_path / 'one.npz', one, vocabulary='symbols'))
    assert isinstance(loaded, FusedRecogniser) and len(loaded.trace_.templates_) == 8
    for g in gestures:
        assert loaded.predict(g) == one.predict(g)
    with pytest.raises(ValueError, match='a fused codebook holds the cloud'):
        FusedRecogniser().set_codebook(one.templates_[:, :-1], one.classes_[one.template_labels_])
    for bad in (0, 5, 2.0, True):
        with pytest.raises(ValueError, match='stroke_orders'):
            FusedRecogniser(stroke_orders=bad).fit(gestures, labels)
    dab = TouchGesture.from_trajectory(np.zeros((0, 2)))
    assert FusedRecogniser().features(dab) is None
