"""Rejection by the order of a one-stroke touch, and rare stroke counts (synthetic gestures)."""

from __future__ import annotations

import copy
import itertools

import numpy as np
import pytest
from test_skin_multistroke import codebook

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.evidence import CodebookEvidence
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.order_evidence import _ONE_THREAD_PRODUCT, _ONE_THREAD_VECTOR, OrderEvidence, one_stroke_path
from touch_gestures.skin.proposed import TraceRecogniser
from touch_lab.skin.recognisers import load_codebook, save_codebook

#: A five-point star's tips in the order one stroke visits them (unit circle, y down).
_ANGLES = np.deg2rad(-90 + 144 * np.arange(6))
STAR = np.column_stack([np.cos(_ANGLES), np.sin(_ANGLES)])


def dense(way: np.ndarray, per_segment: int = 30) -> np.ndarray:
    """(k, 2) waypoints -> points every 1/per_segment of each segment (last point kept)."""
    pts = [a + (b - a) * t for a, b in itertools.pairwise(way)
           for t in np.linspace(0, 1, per_segment, endpoint=False)]
    return np.vstack([pts, way[-1:]])


def traced(way: np.ndarray, rng: np.random.Generator, start: int = 0, reverse: bool = False,
           size_mm: float = 30.0) -> TouchGesture:
    """A closed one-stroke shape traced from waypoint ``start`` (either way) with a shaky finger, mm."""
    loop = way[:-1]
    loop = np.roll(loop[::-1] if reverse else loop, -start, axis=0)
    pts = dense(np.vstack([loop, loop[:1]])) * (size_mm / 2) + 23.5
    pts = pts + rng.normal(0, 0.3, pts.shape)
    return TouchGesture.from_trajectory(pts, np.linspace(0.0, 1.2, len(pts)))


def shuffled_star(rng: np.random.Generator) -> TouchGesture:
    """One stroke through a star's points in a random order: the star's cloud, no star's path."""
    pts = dense(STAR) * 15 + 23.5
    pts = pts[rng.permutation(len(pts))]
    return TouchGesture.from_trajectory(pts, np.linspace(0.0, 1.2, len(pts)))


@pytest.fixture(scope='module')
def fitted():
    """A cloud over the multi-stroke symbols plus a one-stroke star, traced from any tip either way; no
    margin rule and a distance limit too far to matter, so that what it turns away is the order evidence's
    doing."""
    rng = np.random.default_rng(4)
    gestures, labels = codebook(rng, names=('X', 'H', 'T'), per_class=20)
    for k in range(20):
        gestures.append(traced(STAR, rng, start=k % 5, reverse=k % 2 == 1))
        labels.append('star')
    return CloudRecogniser(max_distance=1e9, min_margin=0.0).fit(gestures, labels)


def test_a_star_from_any_tip_either_way_is_accepted_and_its_shuffled_cloud_is_not(fitted):
    rng = np.random.default_rng(11)
    for start in range(5):
        for reverse in (False, True):
            m = fitted.predict(traced(STAR, rng, start, reverse, size_mm=24.0))
            assert m.label == 'star', (start, reverse, m)
    order = fitted.order_evidence_
    star = list(fitted.classes_).index('star')
    assert np.isfinite(order.thresholds[star]) and np.isinf(np.delete(order.thresholds, star)).all()
    scribbles = [shuffled_star(rng) for _ in range(10)]
    rejected = list(map(fitted.predict, scribbles))
    assert all(m.nearest == 'star' and m.rejected == 'order' for m in rejected), rejected
    blind = copy.copy(fitted)
    blind.order_evidence_ = None   # the cloud alone takes every one for a star
    assert [blind.predict(g).label for g in scribbles] == ['star'] * len(scribbles)


def test_path_distance_reads_a_closed_stroke_from_any_start_and_an_open_one_from_its_ends():
    line = np.column_stack([np.linspace(-0.5, 0.5, 32), np.zeros(32)])
    star = one_stroke_path(TouchGesture.from_trajectory(dense(STAR, 40) * 10 + 20))
    ev = OrderEvidence(np.stack([line, line, star, star]), np.array([0, 0, 1, 1]), 2)
    assert ev.path_distance(line[::-1], np.array([0])) == pytest.approx(0.0, abs=1e-9)
    assert ev.path_distance(np.roll(line, 9, axis=0), np.array([0])) > 0.2    # a line read from its middle: no line
    for shift in (0, 7, 19):
        for path in (np.roll(star, shift, axis=0), np.roll(star[::-1], shift, axis=0)):
            assert ev.path_distance(path, np.array([2])) < 0.02    # one resampling step at most
    assert ev.path_distance(star, np.array([], dtype=np.intp)) == np.inf


def test_calibration_needs_two_one_stroke_templates_and_several_strokes_are_not_checked():
    rng = np.random.default_rng(2)
    path = rng.normal(0, 0.3, (32, 2))
    nan = np.full((32, 2), np.nan)
    ev = OrderEvidence(np.stack([path, path + 0.01, path, nan, nan]), np.array([0, 0, 1, 2, 2]), 3)
    assert np.isfinite(ev.thresholds[0]) and np.isinf(ev.thresholds[1:]).all()
    two = TouchGesture.from_trajectory(rng.uniform(5, 40, (40, 2)))
    two.stroke = np.repeat(np.array([0, 1], dtype=np.int16), 20)
    two.strokes = 2
    assert one_stroke_path(two) is None and ev.check(two, 0) is None
    far = TouchGesture.from_trajectory(rng.uniform(5, 40, (40, 2)))
    assert ev.check(far, 0) == 'order' and ev.check(far, 1) is None
    with pytest.raises(ValueError, match='paths must be'):
        OrderEvidence(np.zeros((3, 32)), np.array([0, 0, 1]), 2)
    with pytest.raises(ValueError, match='scale > 0'):
        OrderEvidence(np.zeros((2, 32, 2)), np.array([0, 1]), 2, scale=0.0)


def test_the_paths_travel_in_the_codebook_file_and_an_ordered_recogniser_has_none(fitted, tmp_path):
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', fitted, vocabulary='symbols'))
    np.testing.assert_allclose(loaded.order_evidence_.thresholds, fitted.order_evidence_.thresholds, rtol=1e-5)
    rng = np.random.default_rng(5)
    assert loaded.predict(shuffled_star(rng)).rejected == 'order'
    gestures, labels = codebook(rng, names=('X', 'T'), per_class=5)
    assert TraceRecogniser().fit(gestures, labels).order_evidence_ is None   # it reads the order already
    assert CloudRecogniser(max_distance=None).fit(gestures, labels).order_evidence_ is None   # no limits at all
    with pytest.raises(ValueError, match='template_paths'):
        CloudRecogniser().set_codebook(fitted.templates_, fitted.classes_[fitted.template_labels_],
                                       template_paths=np.zeros((3, 32, 2)))


def test_a_stroke_count_few_templates_of_a_big_class_show_is_not_allowed():
    labels = np.r_[np.zeros(200, int), np.ones(50, int)]
    strokes = np.r_[np.full(199, 2), 1, np.full(49, 2), 1]
    ev = CodebookEvidence(labels, 2, strokes)
    assert ev.stroke_counts == [frozenset({2}), frozenset({1, 2})]   # 1 in 200 is an accident; 1 in 50 may not be
    assert CodebookEvidence(labels, 2, strokes, min_share=0.0).stroke_counts == [frozenset({1, 2})] * 2
    with pytest.raises(ValueError, match='min_share'):
        CodebookEvidence(labels, 2, strokes, min_share=1.0)


def test_the_cloud_hands_the_order_check_its_own_cloud_as_the_path_of_a_one_stroke_touch(fitted):
    rng = np.random.default_rng(9)
    gesture = traced(STAR, rng, start=2)
    query = fitted.features(gesture)
    path = fitted.one_stroke_path_of(gesture, query)
    np.testing.assert_array_equal(path, one_stroke_path(gesture))   # the same resampling, bit for bit
    assert path.dtype == np.float64
    # Stroke ids that change along the touch (a caller's numbering): the ink-only cloud is no path; the check
    # resamples itself. Several strokes: no path at all.
    renumbered = copy.copy(gesture)
    renumbered.stroke = np.repeat(np.array([0, 1], dtype=np.int16), [10, len(gesture.stroke) - 10])
    assert fitted.one_stroke_path_of(renumbered, fitted.features(renumbered)) is None
    two = copy.copy(renumbered)
    two.strokes = 2
    assert fitted.one_stroke_path_of(two, fitted.features(two)) is None
    assert CloudRecogniser(n_points=16).one_stroke_path_of(gesture, query[:32]) is None   # not the check's 32 points
    # Handed a path, the check reads it; handed one of another length, or none, it resamples the touch.
    star = list(fitted.classes_).index('star')
    order = fitted.order_evidence_
    assert order.check(gesture, star, path) is order.check(gesture, star) is None
    assert order.check(gesture, star, np.zeros((5, 2))) is None
    scribble = shuffled_star(rng)
    assert order.check(scribble, star, fitted.one_stroke_path_of(scribble, fitted.features(scribble))) == 'order'
    assert order.check(two, star, path) is None   # several strokes: never checked


def test_the_distance_to_gathered_templates_is_the_definition():
    """path_distance against every one-stroke template of a class: the root-mean-square distance, smallest
    over the two directions (open templates) and every start (closed ones), computed point by point."""
    rng = np.random.default_rng(21)
    n = 16
    open_paths = rng.normal(0, 0.3, (4, n, 2))
    open_paths[:, -1] = open_paths[:, 0] + 1.0                          # ends apart: open
    loops = rng.normal(0, 0.3, (3, n, 2))
    loops[:, -1] = loops[:, 0] + 0.01                                   # ends together: closed
    ev = OrderEvidence(np.concatenate([open_paths, loops]), np.zeros(7, int), 1)
    assert ev._closed.tolist() == [False] * 4 + [True] * 3
    for _ in range(5):
        path = rng.normal(0, 0.3, (n, 2))
        rms = [np.sqrt(((t - p) ** 2).sum(axis=1).mean()) for t in open_paths for p in (path, path[::-1])]
        rms += [np.sqrt(((t - np.roll(p, s, axis=0)) ** 2).sum(axis=1).mean())
                for t in loops for p in (path, path[::-1]) for s in range(n)]
        # float64 sums of 2n products below 1 regrouped: a few ulp of the squared distance.
        assert ev.path_distance(path, np.arange(7)) == pytest.approx(min(rms), rel=1e-12)
        assert ev.path_distance(path, np.arange(4)) == pytest.approx(min(rms[:8]), rel=1e-12)
        assert ev.path_distance(path, np.arange(4, 7)) == pytest.approx(min(rms[8:]), rel=1e-12)


def test_a_big_class_gives_the_definition_and_its_closed_templates_are_read_in_blocks():
    """Open and closed templates in blocks small enough for one BLAS thread (_ONE_THREAD_VECTOR for the open
    ones' matrix-vector product, _ONE_THREAD_PRODUCT for the closed ones'): the nearest is found in whichever
    block it is."""
    rng = np.random.default_rng(22)
    n = 32
    paths = rng.normal(0, 0.3, (300, n, 2))
    paths[:, -1] = paths[:, 0] + 1.0                                    # open
    ev = OrderEvidence(paths, np.zeros(300, int), 1, per_class=2)
    blocks, closed = ev._by_class[0]
    assert len(blocks) > 2 and all(block.size < _ONE_THREAD_VECTOR for block, _ in blocks) and not closed
    for target in (3, 150, 299):
        path = paths[target][::-1] + rng.normal(0, 1e-3, (n, 2))
        rms = min(np.sqrt(((t - p) ** 2).sum(axis=1).mean()) for t in paths for p in (path, path[::-1]))
        assert ev.path_distance(path, np.arange(300)) == pytest.approx(rms, rel=1e-12)
    assert ev.path_distance(paths[7], np.arange(300)) == 0.0            # itself: no rounding left over
    assert np.isnan(ev.path_distance(np.full((n, 2), np.nan), np.arange(300)))   # NaN stays NaN
    loops = paths[:150].copy()
    loops[:, -1] = loops[:, 0]                                          # closed: every start, in blocks
    ev = OrderEvidence(loops, np.zeros(150, int), 1, per_class=2)
    _, blocks = ev._by_class[0]
    assert len(blocks) > 2 and all(len(block) * (2 * n) ** 2 <= _ONE_THREAD_PRODUCT for block, _ in blocks)
    for target in (1, 70, 149):
        path = np.roll(loops[target][::-1], 5, axis=0)
        rms = min(np.sqrt(((t - np.roll(p, s, axis=0)) ** 2).sum(axis=1).mean())
                  for t in loops for p in (path, path[::-1]) for s in range(n))
        # |t|^2 + |q|^2 - 2 t.q of sums below 10: float64 leaves ~1e-14 of the squared distance (~1e-7 of 0)
        assert ev.path_distance(path, np.arange(150)) == pytest.approx(rms, abs=1e-6)
    nan_loop = np.full((n, 2), np.nan)
    assert np.isnan(ev.path_distance(nan_loop, np.arange(150)))
