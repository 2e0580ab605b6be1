"""The compiled cloud search (touch_gestures.skin.cloud_accel) against the numpy path it replaces.

Both run the same steps on the same arrays. The raster bounds are the same float32 operations in the
same order (query points in order, then each template's cells ascending, as numpy's sum along axis 0 and
scipy's CSR product), and the query's field the same float64 squares and float32 roots: they are
compared bit for bit. Except with one template: numpy then sums the (n, 1) column as one contiguous run,
pairwise, so the order differs; float32 sums of 2 n = 64 values below 3 (the raster's diagonal) in two
orders differ by at most 2 x 64 x 6e-8 relative of a sum below 192, times 0.5 / n: ``BOUND_ATOL`` 2.5e-5.
Where two templates tie for the ``exact``-th smallest bound, the kernel matches the first in template
order and numpy's introselect either: both are the module's rule (test_skin_cloud_search.py checks the
answer against the definition), the per-template distances may differ, and such cases are left out here.
The exact distances are float64 sums of n = 32 distances below 3 (the raster's
diagonal) added in another order than numpy's pairwise sums: a few ulp apart, so ``ATOL`` = 1e-12
(32 x 3 x 2.2e-16 ~ 2e-14, with room). The classes are compared by name: the same nearest class and the
same runner-up, unless the two lie within ``ATOL`` of each other.
"""

from __future__ import annotations

import contextlib
import copy
import os
import pickle
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from leak_testing import assert_no_leak
from scipy.optimize import linear_sum_assignment
from test_skin_cloud_search import N, random_codebook

from touch_gestures.skin import cloud_accel
from touch_gestures.skin.clouds import CloudRecogniser, cloud_features
from touch_gestures.skin.gesture import TouchGesture

ATOL = 1e-12
BOUND_ATOL = 2.5e-5
REQUIRED = os.environ.get('SOCIAL_TOUCH_REQUIRE_SKIN_ACCEL') == '1'
FORCED_PYTHON = os.environ.get(cloud_accel.ACCEL_VARIABLE, '').strip().lower() == 'python'

needs_accel = pytest.mark.skipif(not cloud_accel.available() and not REQUIRED,
                                 reason=f'the compiled cloud search was not built here: {cloud_accel.IMPORT_ERROR}')


def test_the_compiled_search_is_built_where_required_and_chosen_unless_told_otherwise():
    if REQUIRED:  # CI sets it: a failed build must not leave only the numpy path tested
        assert cloud_accel.available(), f'the compiled cloud search did not build: {cloud_accel.IMPORT_ERROR}'
    expected = 'c' if cloud_accel.available() and not FORCED_PYTHON else 'python'
    assert cloud_accel.implementation() == expected
    templates, labels = random_codebook(np.random.default_rng(0), 2, 2, 1.0)
    rec = CloudRecogniser(n_points=N)
    rec.set_codebook(templates, labels)
    assert rec.implementation_ == expected


@pytest.mark.parametrize(('value', 'expected'), [('python', 'python'), (' Python ', 'python'), ('', None)])
def test_the_environment_variable_chooses_the_implementation(value, expected):
    code = 'from touch_gestures.skin import cloud_accel; print(cloud_accel.implementation())'
    env = {**os.environ, cloud_accel.ACCEL_VARIABLE: value}
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == (expected or ('c' if cloud_accel.available() else 'python'))


def test_an_unknown_implementation_is_refused_clearly():
    env = {**os.environ, cloud_accel.ACCEL_VARIABLE: 'fortran'}
    out = subprocess.run([sys.executable, '-c', 'import touch_gestures.skin.clouds'], env=env, capture_output=True,
                         text=True)
    assert out.returncode != 0 and "SOCIAL_TOUCH_SKIN_ACCEL='fortran': expected 'c'" in out.stderr


def twins(templates: np.ndarray, labels: list[str], **params) -> tuple[CloudRecogniser, CloudRecogniser]:
    """The same codebook searched by the compiled kernel and by numpy."""
    compiled = CloudRecogniser(n_points=N, **params)
    compiled.set_codebook(templates, labels)
    if compiled._accel is None:   # the numpy path was chosen (SOCIAL_TOUCH_SKIN_ACCEL=python): build it anyway
        compiled._accel = cloud_accel._cloud_accel.Codebook(
            compiled._fields, compiled._clouds, compiled.template_labels_.astype(np.intp), len(compiled.classes_),
            compiled.grid, compiled.exact, compiled._cell_table)
    numpy_path = copy.copy(compiled)
    numpy_path._accel = None
    return compiled, numpy_path


def assert_same(compiled: CloudRecogniser, numpy_path: CloudRecogniser, query: np.ndarray) -> None:
    q = query.reshape(N, 2).astype(np.float64)
    atol = ATOL
    if len(compiled.templates_) > 1:
        np.testing.assert_array_equal(compiled._bounds(q), numpy_path._bounds(q))
    else:   # numpy's pairwise sum of one column (module doc)
        np.testing.assert_allclose(compiled._bounds(q), numpy_path._bounds(q), rtol=0, atol=BOUND_ATOL)
        atol = BOUND_ATOL
    bounds, k = np.sort(numpy_path._bounds(q)), min(compiled.exact, len(compiled.templates_))
    if 0 < k < len(bounds) and bounds[k - 1] == bounds[k]:
        return   # a tie at the k-th place: numpy's introselect and the kernel (template order) may match another
    fast, ref = compiled._distances(query), numpy_path._distances(query)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=atol)
    f, r = (np.minimum.reduceat(d, compiled.class_starts_) for d in (fast, ref))
    order = np.argsort(r, kind='stable')
    for rank in range(min(2, len(r))):   # the nearest class and the runner-up
        named = int(np.argsort(f, kind='stable')[rank])
        assert named == order[rank] or abs(r[named] - r[order[rank]]) <= atol


@needs_accel
@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_classes=st.integers(1, 6), per_class=st.integers(1, 6),
       exact=st.integers(0, 40), jitter=st.sampled_from([0.0, 0.5, 3.0, 10.0]), grid=st.sampled_from([2, 9, 24, 40]))
def test_the_compiled_search_names_what_numpy_names_at_the_same_distances(seed, n_classes, per_class, exact, jitter,
                                                                          grid):
    rng = np.random.default_rng(seed)
    templates, labels = random_codebook(rng, n_classes, per_class, jitter)
    compiled, numpy_path = twins(templates, labels, exact=exact, grid=grid)   # grid 40: no cell table
    query, _ = random_codebook(rng, 1, 1, jitter)
    assert_same(compiled, numpy_path, query[0])
    assert_same(compiled, numpy_path, templates[int(rng.integers(len(templates)))])   # a query equal to a template


@needs_accel
def test_hard_cases_a_dab_duplicates_one_template_per_class():
    rng = np.random.default_rng(3)
    templates, labels = random_codebook(rng, 4, 1, 1.0)             # one template per class
    dab = cloud_features(np.full((5, 2), 7.0), np.zeros(5, np.int16), N)   # all points equal: the origin
    templates = np.vstack([templates, dab[None], dab[None], templates[:1]])   # a dab twice, a duplicate
    labels = [*labels, 'dab', 'dab', labels[0]]
    for exact in (0, 1, 6, 100):
        compiled, numpy_path = twins(templates, labels, exact=exact)
        for query in (dab, templates[0], templates[2], random_codebook(rng, 1, 1, 1.0)[0][0]):
            assert_same(compiled, numpy_path, query)
        dot = TouchGesture.from_trajectory(np.full((4, 2), 20.0))
        mine, its = compiled.predict(dot), numpy_path.predict(dot)
        assert (mine.nearest, mine.label) == (its.nearest, its.label) and abs(mine.distance - its.distance) <= ATOL


@needs_accel
def test_bad_queries_and_codebooks_are_refused_before_the_kernel():
    templates, labels = random_codebook(np.random.default_rng(4), 3, 2, 1.0)
    compiled, numpy_path = twins(templates, labels)
    q = templates[0].reshape(N, 2).astype(np.float64)
    for bad in (np.where(np.arange(2 * N).reshape(N, 2) == 5, np.nan, q), np.full((N, 2), np.inf)):
        with pytest.raises(ValueError, match='NaN or infinite'):
            compiled._accel.distances(bad, linear_sum_assignment)
    for bad in (q[:-1], q.astype(np.float32), np.asfortranarray(np.hstack([q, q]))[:, :2], q.reshape(-1), [[0.0, 0.0]]):
        with pytest.raises((ValueError, TypeError)):
            compiled._accel.bounds(bad)
    with pytest.raises(TypeError, match='callable'):
        compiled._accel.distances(q, None)
    # A touch with a NaN point answers on both paths alike (no exception): no NaN reaches the kernel.
    nan_touch = TouchGesture.from_trajectory(np.array([[1.0, 2.0], [np.nan, 3.0], [4.0, 5.0]]))
    mine, its = compiled.predict(nan_touch), numpy_path.predict(nan_touch)
    assert (mine.nearest, mine.rejected) == (its.nearest, its.rejected) and abs(mine.distance - its.distance) <= ATOL
    Codebook = cloud_accel._cloud_accel.Codebook
    fields, clouds = compiled._fields, compiled._clouds
    labels_ok = compiled.template_labels_.astype(np.intp)
    for args in [(fields[:-1], clouds, labels_ok, 3, 24, 6),               # fields of another raster
                 (fields, clouds, labels_ok, 2, 24, 6),                    # a label beyond the classes
                 (fields, clouds, labels_ok.astype(np.int32), 3, 24, 6),   # labels of another dtype
                 (fields, np.where(clouds == clouds[0, 0, 0], np.nan, clouds), labels_ok, 3, 24, 6),
                 (fields, clouds, labels_ok, 3, 24, -1),
                 (fields, clouds, labels_ok, 3, 24, 6, np.zeros((4, 4), np.float32))]:
        with pytest.raises((ValueError, TypeError)):
            Codebook(*args)
    with pytest.raises(ValueError, match='not initialised'):
        Codebook.__new__(Codebook).bounds(q)


@needs_accel
def test_a_solver_that_fails_or_answers_nonsense_raises_and_leaks_nothing():
    rng = np.random.default_rng(6)
    templates, labels = random_codebook(rng, 3, 4, 3.0)
    compiled, _ = twins(templates, labels, exact=12)
    queries = [random_codebook(rng, 1, 1, 3.0)[0][0].reshape(N, 2).astype(np.float64) for _ in range(20)]
    calls = []

    def counting(cost):
        calls.append(cost.shape)
        return linear_sum_assignment(cost)

    for q in queries:
        compiled._accel.distances(q, counting)
    assert calls and set(calls) == {(N, N)}   # the random queries need the Hungarian now and then

    def broken(cost):
        raise RuntimeError('solver down')

    def short(cost):
        return np.arange(3), np.arange(3)

    def outside(cost):
        return np.arange(N), np.full(N, N + 5)

    for solver, error in ((broken, RuntimeError), (short, ValueError), (outside, ValueError), (len, TypeError)):
        with pytest.raises(error):
            for q in queries:
                compiled._accel.distances(q, solver)


@needs_accel
def test_no_references_or_blocks_leak_on_success_and_on_failure():
    rng = np.random.default_rng(7)
    templates, labels = random_codebook(rng, 3, 4, 3.0)
    compiled, _ = twins(templates, labels, exact=12)
    accel = compiled._accel
    good = random_codebook(rng, 1, 1, 3.0)[0][0].reshape(N, 2).astype(np.float64)
    bad = np.full((N, 2), np.nan)

    def broken(cost):
        raise RuntimeError('solver down')

    watched = [accel, good, bad, linear_sum_assignment, broken]

    def run(times: int) -> None:
        for _ in range(times):
            accel.distances(good, linear_sum_assignment)
            accel.bounds(good)
            for args in ((bad, linear_sum_assignment), (good, broken), (good[:3], linear_sum_assignment)):
                with contextlib.suppress(ValueError, RuntimeError):
                    accel.distances(*args)
            Codebook = type(accel)
            Codebook(compiled._fields, compiled._clouds, compiled.template_labels_.astype(np.intp),
                     len(compiled.classes_), compiled.grid, compiled.exact, compiled._cell_table)

    assert_no_leak(run, watched)


def test_copies_and_pickles_search_as_the_original():
    templates, labels = random_codebook(np.random.default_rng(8), 3, 3, 1.0)
    rec = CloudRecogniser(n_points=N)
    rec.set_codebook(templates, labels)
    for other in (copy.copy(rec), copy.deepcopy(rec), pickle.loads(pickle.dumps(rec))):
        assert other.implementation_ == rec.implementation_
        np.testing.assert_array_equal(other._distances(templates[1]), rec._distances(templates[1]))
    assert '_accel' in rec.__dict__   # pickling did not take it from the original


# ----------------------------------------------------------------------------- the compiled features
def numpy_twins():
    """The numpy resampling, cloud and unistroke (the module's code with the compiled functions off)."""
    from touch_gestures.skin import clouds, features, ndollar
    saved = cloud_accel.resample, cloud_accel.cloud, cloud_accel.unistroke, cloud_accel.ink
    cloud_accel.resample = cloud_accel.cloud = cloud_accel.unistroke = cloud_accel.ink = None
    try:
        yield (features.arc_length_resample_complex, clouds.cloud_features, ndollar.unistroke_vectors,
               ndollar.ink_features)
    finally:
        cloud_accel.resample, cloud_accel.cloud, cloud_accel.unistroke, cloud_accel.ink = saved


paths = st.integers(0, 2**32 - 1).map(np.random.default_rng).flatmap(lambda rng: st.just((
    rng.normal(0, 10, (int(rng.integers(1, 150)), 2)) * rng.choice([1e-6, 1.0, 1e4]),
    rng.random())))


@needs_accel
@settings(max_examples=150, deadline=None)
@given(drawn=paths, n=st.sampled_from([1, 2, 32, 96, 128]), strokes=st.sampled_from([0, 1, 4, 40, 300]),
       still=st.booleans())
def test_the_compiled_features_are_numpys(drawn, n, strokes, still):
    # The resampling and the cloud: numpy's arithmetic step by step, so the same numbers where numpy's
    # complex absolute value takes its AVX-512 loop (this machine's, checked bit for bit when so); its
    # scalar loop may round a step's length an ulp apart: then 4 ulp of float64 per point (relative to
    # the path's extent), and one float32 ulp for the cloud. The unistroke: float64 of 96 points through
    # sums, rotations and a norm, ~1e-14 (ATOL).
    points, share = drawn
    if still:
        points[share < 0.5:] = points[0]       # a path that stops moving, or never moves (a dab)
    ids = None if not strokes else np.sort(np.random.default_rng(len(points)).integers(0, strokes + 1,
                                                                                        len(points)))
    twins = numpy_twins()
    resample, cloud_features_numpy, unistroke_numpy, ink_numpy = next(twins)
    try:
        want = resample(points, n, ids)
        want_cloud = cloud_features_numpy(points, ids, n)
        want_ink = ink_numpy(points, ids, n)
        want_vec, want_angle = unistroke_numpy(points[None], max(n, 16), 0.25) if n >= 16 else (None, None)
    finally:
        next(twins, None)
    extent = float(np.abs(points - points[0]).max()) or 1.0
    got = cloud_accel._cloud_accel.resample(points, ids, n)
    np.testing.assert_allclose(got.view(np.float64), want.view(np.float64), rtol=0,
                               atol=4 * np.spacing(extent + float(np.abs(points).max())))
    got_cloud = cloud_accel._cloud_accel.cloud(points, ids, n)
    assert got_cloud.dtype == np.float32 and got_cloud.shape == want_cloud.shape
    np.testing.assert_allclose(got_cloud, want_cloud, rtol=0, atol=np.spacing(np.float32(1.0)))
    got_ink = cloud_accel._cloud_accel.ink(points, ids, n)   # $N's features: the cloud's reasoning, per stroke
    assert (got_ink is None) == (want_ink is None)
    if got_ink is not None:
        np.testing.assert_allclose(got_ink, want_ink, rtol=0, atol=np.spacing(np.float32(1.0)))
    # A dab (a path that never moves) has no direction: numpy's unit vector is then the direction of the
    # rounding residue its centring leaves (sums of equal numbers), an arbitrary one, the kernel's 0 or
    # another residue; both are finite, and neither is compared.
    if want_vec is not None and np.ptp(points, axis=0).max() > 0:
        vec, angle = cloud_accel._cloud_accel.unistroke(points, max(n, 16), 0.25)
        np.testing.assert_allclose(vec, want_vec[0], rtol=0, atol=ATOL)
        assert np.isnan(angle) == np.isnan(want_angle[0])
        if not np.isnan(angle):   # a start angle near +-pi may come out on the other side
            assert abs(np.angle(np.exp(1j * (angle - want_angle[0])))) <= ATOL


@needs_accel
def test_the_compiled_features_refuse_what_numpy_refuses_with_the_same_words():
    A = cloud_accel._cloud_accel
    for bad, words in ((np.empty((0, 2)), 'empty path'), (np.zeros(3), r'got shape \(3,\)'),
                       (np.zeros((3, 3)), r'got shape \(3, 3\)')):
        for call in (lambda p: A.resample(p, None, 4), lambda p: A.cloud(p, None, 4),
                     lambda p: A.unistroke(p, 16, 0.25), lambda p: A.ink(p, None, 8)):
            with pytest.raises(ValueError, match=words):
                call(bad)
    with pytest.raises(ValueError, match='one stroke id per point'):
        A.resample(np.zeros((3, 2)), np.zeros(2), 4)
    with pytest.raises(ValueError):
        A.resample(np.zeros((3, 2)), None, 0)
    with pytest.raises(ValueError):
        A.unistroke(np.zeros((3, 2)), 16, 1.5)
    # lists and float32 are converted, as np.ascontiguousarray converts them
    assert A.resample([[0.0, 0.0], [2.0, 0.0]], None, 3).tolist() == [0j, 1 + 0j, 2 + 0j]
    assert A.cloud(np.array([[0, 0], [4, 0]], np.float32), [0, 0], 2).tolist() == [-0.5, 0.0, 0.5, 0.0]


@needs_accel
def test_the_compiled_features_leak_nothing():
    A = cloud_accel._cloud_accel
    rng = np.random.default_rng(9)
    points, ids = rng.normal(size=(40, 2)), np.sort(rng.integers(0, 3, 40))

    def run(times: int) -> None:
        for _ in range(times):
            A.resample(points, ids, 32)
            A.cloud(points, None, 32)
            A.unistroke(points, 96, 0.25)
            A.ink(points, ids, 128)
            A.ink(points, np.arange(40), 8)   # more strokes than points: None
            for bad in (np.empty((0, 2)), np.zeros(3)):
                with contextlib.suppress(ValueError):
                    A.cloud(bad, None, 32)

    assert_no_leak(run, (points, ids))
