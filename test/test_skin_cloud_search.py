"""The cloud recogniser's pruned search gives the answer of solving every assignment.

:class:`~touch_gestures.skin.clouds.CloudRecogniser` solves only the assignments that can
change the nearest class or the runner-up (module doc, step 3). Its reference here solves
them all, with the same point distances (scipy's cdist, float64) and the same solver, so
the two differ only in the order of float64 sums of n = 32 distances below 3: a few ulp,
under 1e-12. ``ATOL`` is that bound, not a tuned number.
"""

from __future__ import annotations

import copy
import math
import pickle

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from touch_gestures.skin.base import Match
from touch_gestures.skin.clouds import CloudRecogniser, cloud_features
from touch_gestures.skin.gesture import TouchGesture

N = 32
ATOL = 1e-12


def matching_cost(a: np.ndarray, b: np.ndarray) -> float:
    """Mean distance of the optimal one-to-one pairing of two (n, 2) clouds (the definition)."""
    cost = cdist(a, b)
    rows, cols = linear_sum_assignment(cost)
    return float(cost[rows, cols].mean())


def closest_templates(rec: CloudRecogniser, bounds: np.ndarray, k: int) -> np.ndarray:
    """The ``k`` smallest ``bounds`` as the recogniser picks them among ties at the k-th place (numpy's
    introselect, argpartition)."""
    return np.argpartition(bounds, k - 1)[:k]


def reference(rec: CloudRecogniser, query: np.ndarray) -> np.ndarray:
    """(T,) the definition: every one of the ``exact`` closest (raster Chamfer) matched one to one,
    the others their bound raised to the farthest matched."""
    q = query.reshape(N, 2).astype(np.float64)
    out = rec._bounds(q)
    k = min(rec.exact, len(out))
    closest = closest_templates(rec, out, k)   # the recogniser's pick among ties at the k-th place
    exact = np.array([matching_cost(q, rec._clouds[t]) for t in closest])
    out = np.maximum(out, exact.max())
    out[closest] = exact
    return out


def class_minima(rec: CloudRecogniser, d: np.ndarray) -> np.ndarray:
    return np.minimum.reduceat(d, rec.class_starts_)


def random_codebook(rng: np.random.Generator, n_classes: int, per_class: int, jitter: float
                    ) -> tuple[np.ndarray, list[str]]:
    """(T, 2N) float32 clouds: one random polyline per class, its templates jittered copies."""
    feats, labels = [], []
    for c in range(n_classes):
        corners = rng.uniform(0, 40, size=(rng.integers(2, 7), 2))
        strokes = np.sort(rng.integers(0, 3, size=len(corners)))
        for _ in range(per_class):
            pts = corners + rng.normal(0, jitter, corners.shape)
            feats.append(cloud_features(pts, strokes, N))
            labels.append(f'g{c}')
    return np.stack(feats), labels


def fitted(templates: np.ndarray, labels: list[str], exact: int) -> CloudRecogniser:
    rec = CloudRecogniser(n_points=N, exact=exact)
    rec.set_codebook(templates, labels)
    return rec


def assert_same_answer(rec: CloudRecogniser, query: np.ndarray) -> None:
    fast, ref = rec.distances(query), reference(rec, query)
    # The nearest template is the definition's nearest (or one tied with it).
    assert abs(ref[int(np.argmin(fast))] - ref.min()) <= ATOL
    assert abs(fast.min() - ref.min()) <= ATOL
    # The same nearest class at the same distance, and a margin over the runner-up never larger than
    # the definition's: the same where the runner-up has a template among the ``exact`` closest.
    f, r = class_minima(rec, fast), class_minima(rec, ref)
    assert abs(r[int(np.argmin(f))] - r.min()) <= ATOL
    if len(r) > 1:
        (r1, r2), (f1, f2) = np.sort(r)[:2], np.sort(f)[:2]
        assert f2 - f1 <= r2 - r1 + ATOL
        k = min(rec.exact, len(ref))
        closest = closest_templates(rec, rec._bounds(query.reshape(N, 2).astype(np.float64)), k)
        if np.argsort(r, kind='stable')[1] in rec.template_labels_[closest]:
            assert abs((f2 - f1) - (r2 - r1)) <= ATOL
    assert np.all(f <= r + ATOL)
    # Every template is either its matching cost or at most it (a bound): never farther than the definition.
    assert np.all(fast <= ref + ATOL)


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_classes=st.integers(1, 5), per_class=st.integers(1, 6),
       exact=st.integers(1, 40), jitter=st.sampled_from([0.0, 0.5, 3.0, 10.0]))
def test_the_pruned_search_answers_as_solving_every_assignment(seed, n_classes, per_class, exact, jitter):
    rng = np.random.default_rng(seed)
    templates, labels = random_codebook(rng, n_classes, per_class, jitter)
    rec = fitted(templates, labels, exact)
    query, _ = random_codebook(rng, 1, 1, jitter)
    assert_same_answer(rec, query[0])
    # Leave one out, as the calibration and the vocabulary rule do: a template is its own query.
    i = int(rng.integers(len(templates)))
    assert_same_answer(rec, templates[i])
    fast, ref = rec.distances(templates[i]), reference(rec, templates[i])
    fast[i] = ref[i] = np.inf   # the nearest other template, as codebook_accuracy takes it
    assert fast.min() == ref.min() == np.inf or abs(fast.min() - ref.min()) <= ATOL


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), per_class=st.integers(1, 4))
def test_with_every_template_matched_the_classes_are_the_true_nearest(seed, per_class):
    """``exact`` above the codebook's size: the definition is the brute force over all templates."""
    rng = np.random.default_rng(seed)
    templates, labels = random_codebook(rng, 4, per_class, 2.0)
    rec = fitted(templates, labels, exact=10_000)
    query, _ = random_codebook(rng, 1, 1, 2.0)
    q = query[0].reshape(N, 2).astype(np.float64)
    truth = np.array([matching_cost(q, t.reshape(N, 2).astype(np.float64)) for t in templates])
    f, r = class_minima(rec, rec.distances(query[0])), class_minima(rec, truth)
    top = np.argsort(r, kind='stable')[:2]
    np.testing.assert_allclose(f[top], r[top], rtol=0, atol=ATOL)   # nearest and runner-up: exact
    rest = np.setdiff1d(np.arange(len(r)), top)
    assert np.all(f <= r + ATOL) and np.all(f[rest] >= r[top].max() - ATOL)  # the rest: bounds beyond them


def test_a_dab_matches_a_dab_at_zero_and_nothing_else_closer():
    rng = np.random.default_rng(3)
    templates, labels = random_codebook(rng, 3, 4, 1.0)
    dab = cloud_features(np.full((5, 2), 7.0), np.zeros(5, np.int16), N)   # all points equal: the origin
    assert not dab.any()
    templates = np.vstack([templates, dab[None], dab[None]])
    labels = [*labels, 'dab', 'dab']
    rec = fitted(templates, labels, exact=6)
    assert_same_answer(rec, dab)
    assert rec.predict(TouchGesture.from_trajectory(np.full((4, 2), 20.0))).nearest == 'dab'


def test_identical_templates_tie_and_keep_the_runner_up_exact():
    rng = np.random.default_rng(5)
    templates, labels = random_codebook(rng, 3, 3, 1.0)
    templates = np.vstack([templates, templates[:1]])    # a duplicate of g0's first template
    labels = [*labels, labels[0]]
    rec = fitted(templates, labels, exact=6)
    for query in (templates[0], templates[4], random_codebook(rng, 1, 1, 1.0)[0][0]):
        assert_same_answer(rec, query)
    d = rec.distances(templates[0])
    assert d[0] == 0.0 and d[np.flatnonzero(rec.template_labels_ == 0)].min() == 0.0


def test_one_template_per_class():
    rng = np.random.default_rng(8)
    templates, labels = random_codebook(rng, 6, 1, 0.0)
    rec = fitted(templates, labels, exact=3)
    for query in (*templates, random_codebook(rng, 1, 1, 0.0)[0][0]):
        assert_same_answer(rec, query)


def test_a_trace_ten_times_longer_than_any_template():
    rng = np.random.default_rng(11)
    t = np.linspace(0, 2 * np.pi, 40)
    circle = np.column_stack([20 + 10 * np.cos(t), 20 + 10 * np.sin(t)])
    line = np.column_stack([np.linspace(5, 35, 40), np.full(40, 20.0)])
    gestures = [TouchGesture.from_trajectory(s + rng.normal(0, 0.3, s.shape)) for s in (circle, line) * 3]
    rec = CloudRecogniser(n_points=N).fit(gestures, ['circle', 'line'] * 3)
    long_t = np.linspace(0, 20 * np.pi, 4000)   # ten turns of 400 points: 10x the templates' length and points
    long_circle = np.column_stack([20 + 10 * np.cos(long_t), 20 + 10 * np.sin(long_t)])
    gesture = TouchGesture.from_trajectory(long_circle)
    assert rec.predict(gesture).nearest == 'circle'
    assert_same_answer(rec, rec.features(gesture))


def test_a_raster_too_large_for_the_table_gives_the_same_field():
    rng = np.random.default_rng(13)
    templates, labels = random_codebook(rng, 3, 2, 1.0)
    rec = CloudRecogniser(n_points=N, grid=40)   # 1600 cells: no cell-to-cell table
    rec.set_codebook(templates, labels)
    assert rec._cell_table is None
    cells = rec._cells(templates[0].reshape(N, 2).astype(np.float64))
    small = CloudRecogniser(n_points=N, grid=40)
    small.set_codebook(templates, labels)
    small._cell_table = np.sqrt(((small._raster[:, None] - small._raster[None]) ** 2).sum(axis=2)).astype(np.float32)
    # The same float64 distances rounded once to float32 (the minimum commutes with sqrt and rounding).
    np.testing.assert_array_equal(rec._query_field(cells), small._query_field(cells))
    assert_same_answer(rec, templates[0])


def test_copies_and_pickles_search_as_the_original():
    templates, labels = random_codebook(np.random.default_rng(8), 3, 3, 1.0)
    rec = CloudRecogniser(n_points=N)
    rec.set_codebook(templates, labels)
    for other in (copy.copy(rec), copy.deepcopy(rec), pickle.loads(pickle.dumps(rec))):
        np.testing.assert_array_equal(other.distances(templates[1]), rec.distances(templates[1]))


def test_a_touch_with_a_nan_point_is_answered_without_an_exception():
    templates, labels = random_codebook(np.random.default_rng(4), 3, 2, 1.0)
    rec = fitted(templates, labels, exact=6)
    match = rec.predict(TouchGesture.from_trajectory(np.array([[1.0, 2.0], [np.nan, 3.0], [4.0, 5.0]])))
    assert isinstance(match, Match) and not math.isnan(match.distance) and not math.isnan(match.margin)
