"""The compiled trace features, class minima and fused sum (cloud_accel.trace, trace_minima, relative_sum)
against the numpy they replace.

Both run the same float64 steps in the same order: each point's bin is the same product truncated, the bins'
sums add the points in index order (as ``np.bincount`` does), each is divided by its count, empty bins take
np.interp's arithmetic, and the scaling is the same subtraction and division rounded once to float32. So
the features are compared bit for bit, not within a tolerance. The compiled twin refuses NaN and infinite
points and times (numpy's answers to them are accidents of its steps); ``trace_features`` then answers
with the reference, so a recogniser sees the same numbers whichever path runs. The fused sum is two
divisions and an addition per class, the same float64 operations: bit for bit too, NaN, inf and 0 included.
The class minima follow numpy's BLAS product (left to numpy): the same float32 steps per template and the
same minimum per class, equal values (the sign of a zero is the one freedom: numpy's SIMD maximum and
minimum may keep either of 0.0 and -0.0).
"""

from __future__ import annotations

import contextlib
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from leak_testing import assert_no_leak
from test_skin_cloud_accel import needs_accel

from touch_gestures.skin import cloud_accel
from touch_gestures.skin.fused import relative_distances
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.proposed import TraceRecogniser, trace_features


def numpy_trace(points, times, n: int, aspect_floor: float = 1.0) -> np.ndarray:
    """The numpy reference whatever the implementation chosen (quiet where aspect_floor 0 divides a flat line's
    zero height by zero, or an infinite point's extent is inf - inf: NaN on both paths)."""
    with mock.patch.object(cloud_accel, 'trace', None), np.errstate(invalid='ignore', divide='ignore'):
        return trace_features(points, times, n, aspect_floor)


def compiled_trace(points, times, n: int, aspect_floor: float = 1.0) -> np.ndarray:
    from touch_gestures.skin import _cloud_accel
    return _cloud_accel.trace(points, times, n, aspect_floor)


def assert_same_bits(points, times, n: int, aspect_floor: float = 1.0) -> None:
    mine, want = compiled_trace(points, times, n, aspect_floor), numpy_trace(points, times, n, aspect_floor)
    assert mine.dtype == want.dtype == np.float32 and mine.shape == want.shape == (2 * n,)
    assert mine.tobytes() == want.tobytes(), (mine, want)


TIMES = st.sampled_from(['rising', 'steps', 'constant', 'backwards', 'subnormal'])


def make_times(kind: str, m: int, rng: np.random.Generator) -> np.ndarray:
    if kind == 'rising':
        return np.sort(rng.uniform(0.0, 3.0, m))
    if kind == 'steps':   # repeated times: several points at one instant, many empty bins
        return np.sort(rng.integers(0, 4, m)).astype(np.float64)
    if kind == 'constant':
        return np.full(m, 2.5)
    if kind == 'backwards':
        return rng.uniform(0.0, 3.0, m)
    return 1e3 + np.arange(m) * 5e-324 if m > 1 else np.zeros(1)   # durations too small to divide by


@needs_accel
@settings(max_examples=300, deadline=None)
@given(m=st.integers(1, 90), n=st.integers(1, 48), kind=TIMES, seed=st.integers(0, 2 ** 32 - 1),
       spread=st.sampled_from([1e-12, 1e-3, 1.0, 60.0, 1e6]), aspect_floor=st.sampled_from([1.0, 0.3, 0.0]),
       dtype=st.sampled_from([np.float32, np.float64]))
def test_the_compiled_trace_is_numpys_bit_for_bit(m, n, kind, seed, spread, aspect_floor, dtype):
    rng = np.random.default_rng(seed)
    points = (rng.normal(0.0, spread, (m, 2)) + rng.uniform(-100, 100, 2)).astype(dtype)
    assert_same_bits(points, make_times(kind, m, rng), n, aspect_floor)


@needs_accel
@pytest.mark.parametrize(('points', 'times'), [
    ([[5.0, 5.0]], [0.0]),                                   # one point: no shape
    ([[0.0, 5.0], [10.0, 5.0]], [0.0, 1.0]),                 # two points: the bins between interpolated
    ([[0.0, 0.0], [3.0, 4.0]], [1.0, 1.0]),                  # constant time: by sample index
    ([[0.0, 0.0], [3.0, 4.0], [6.0, 1.0]], [2.0, 1.0, 3.0]),  # time goes backwards: by sample index
    ([[0.0, 0.0], [3.0, 4.0], [6.0, 1.0]], [0.0, 5e-324, 1e-323]),  # subnormal duration: by sample index
    ([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [9.0, 9.0]], [0.0, 0.0, 0.0, 1.0]),  # all but one at the start
    (np.full((20, 2), 3.0), np.arange(20.0)),                # never moves
    (np.column_stack([np.linspace(0, 30, 50), np.full(50, 9.0)]), np.arange(50.0)),  # a flat line
])
@pytest.mark.parametrize('n', [1, 2, 3, 32, 100])
def test_hard_cases_are_numpys_bit_for_bit(points, times, n):
    for aspect_floor in (1.0, 0.3, 0.0):
        assert_same_bits(np.asarray(points, dtype=np.float64), np.asarray(times, dtype=np.float64), n, aspect_floor)


@needs_accel
@pytest.mark.parametrize('bad', ['point', 'time', 'inf'])
def test_nan_is_refused_by_the_kernel_and_answered_by_the_reference(bad):
    points, times = np.array([[0.0, 0.0], [3.0, 4.0], [6.0, 1.0]]), np.array([0.0, 0.5, 1.0])
    if bad == 'point':
        points[1, 0] = np.nan
    elif bad == 'time':
        times[0] = np.nan
    else:
        points[2, 1] = np.inf
    with pytest.raises(ValueError, match='finite points and times'):
        compiled_trace(points, times, 8)
    want = numpy_trace(points, times, 8)   # whatever numpy makes of it, trace_features says the same
    with np.errstate(invalid='ignore'):
        assert trace_features(points, times, 8).tobytes() == want.tobytes()


@needs_accel
@pytest.mark.parametrize(('points', 'times', 'n', 'words'), [
    (np.zeros((0, 2)), np.zeros(0), 8, 'empty'),
    (np.zeros((3, 2)), np.zeros(2), 8, 'one time per point'),
    (np.zeros((3, 3)), np.zeros(3), 8, r'\(m, 2\)'),
    (np.zeros((3, 2)), np.zeros(3), 0, 'n >= 1'),
])
def test_bad_arguments_are_refused_clearly(points, times, n, words):
    with pytest.raises(ValueError, match=words):
        compiled_trace(points, times, n)


@needs_accel
def test_the_recogniser_measures_the_same_with_either_path():
    rng = np.random.default_rng(3)
    shapes = [np.column_stack([np.linspace(0, 20, 40), a * np.linspace(0, 20, 40)]) for a in (0.0, 1.0, -1.0)]
    gestures, labels = [], []
    for label, shape in enumerate(shapes):
        for _ in range(4):
            gestures.append(TouchGesture.from_trajectory(shape + rng.normal(0, 0.5, shape.shape)))
            labels.append(str(label))
    compiled = TraceRecogniser().fit(gestures, labels)
    with mock.patch.object(cloud_accel, 'trace', None), mock.patch.object(cloud_accel, 'trace_minima', None):
        reference = TraceRecogniser().fit(gestures, labels)
        want = [reference.class_distances(g) for g in gestures]
    assert np.array_equal(compiled.templates_, reference.templates_)
    for g, w in zip(gestures, want, strict=True):
        assert compiled.class_distances(g).tobytes() == w.tobytes()


@needs_accel
def test_the_compiled_trace_leaks_nothing():
    points, times = np.random.default_rng(5).normal(0, 9, (40, 2)).astype(np.float32), np.linspace(0, 1, 40)
    bad = np.array([[np.nan, 0.0], [1.0, 1.0]])

    def run(times_run: int) -> None:
        for _ in range(times_run):
            compiled_trace(points, times, 32)
            for args in ((bad, times[:2], 8), (points, times[:3], 8), (points[:0], times[:0], 8)):
                with contextlib.suppress(ValueError):
                    compiled_trace(*args)

    assert_no_leak(run, (points, times, bad))


DISTANCE = st.one_of(st.floats(0.0, 1e300), st.sampled_from([0.0, 5e-324, 1e-310, np.inf, np.nan]))


@needs_accel
@settings(max_examples=300, deadline=None)
@given(pairs=st.lists(st.tuples(DISTANCE, DISTANCE), min_size=1, max_size=24))
def test_the_compiled_relative_sum_is_numpys_bit_for_bit(pairs):
    from touch_gestures.skin import _cloud_accel
    first, second = (np.array(column, dtype=np.float64) for column in zip(*pairs, strict=True))
    with np.errstate(invalid='ignore'):   # inf + (-inf) cannot happen (distances >= 0); NaN + x is quiet
        want = relative_distances(first) + relative_distances(second)
    assert _cloud_accel.relative_sum(first, second).tobytes() == want.tobytes()


@needs_accel
def test_the_compiled_relative_sum_refuses_mismatched_classes_and_leaks_nothing():
    from touch_gestures.skin import _cloud_accel
    first, second = np.array([1.0, 2.0, np.inf]), np.array([0.0, 3.0, 4.0])
    with pytest.raises(ValueError, match='two distances per class'):
        _cloud_accel.relative_sum(first, second[:2])

    def run(times: int) -> None:
        for _ in range(times):
            _cloud_accel.relative_sum(first, second)
            with contextlib.suppress(ValueError):
                _cloud_accel.relative_sum(first, second[:2])

    assert_no_leak(run, (first, second))


def numpy_minima(sq_norms, products, query_sq, n_points, starts) -> np.ndarray:
    """proposed.py's _distances (after the product) and base.py's class minima, as numpy runs them."""
    with np.errstate(invalid='ignore', over='ignore'):   # inf - inf: NaN on both paths
        d2 = sq_norms - 2.0 * products + query_sq
        return np.minimum.reduceat(np.sqrt(np.maximum(d2, 0.0) / n_points), starts).astype(np.float64, copy=False)


FLOAT32 = st.one_of(st.floats(-1e3, 1e3, width=32), st.sampled_from([0.0, -0.0, np.nan, np.inf, 1e-45]))


@needs_accel
@settings(max_examples=300, deadline=None)
@given(rows=st.lists(st.tuples(FLOAT32, FLOAT32), min_size=1, max_size=40), query_sq=FLOAT32,
       n_points=st.integers(1, 64), cuts=st.lists(st.integers(0, 39), min_size=0, max_size=8))
def test_the_compiled_trace_minima_are_numpys(rows, query_sq, n_points, cuts):
    # Equal values compared: the sign of a zero is the one freedom (numpy's SIMD maximum and minimum may
    # keep either of two equal operands, 0.0 and -0.0), and no distance or decision tells them apart.
    from touch_gestures.skin import _cloud_accel
    sq_norms, products = (np.array(column, dtype=np.float32) for column in zip(*rows, strict=True))
    starts = np.array(sorted({0, *(c % len(rows) for c in cuts)}), dtype=np.intp)
    if len(starts) > 2:   # a run that does not rise (reduceat: its first element)
        starts = np.sort(np.append(starts, starts[1]))
    query_sq = float(np.float32(query_sq))
    mine = _cloud_accel.trace_minima(sq_norms, products, query_sq, n_points, starts)
    want = numpy_minima(sq_norms, products, query_sq, n_points, starts)
    assert mine.dtype == want.dtype == np.float64
    assert np.array_equal(mine, want, equal_nan=True), (mine, want)


@needs_accel
def test_the_compiled_trace_minima_refuse_bad_runs_and_leak_nothing():
    from touch_gestures.skin import _cloud_accel
    norms, products, starts = np.ones(4, np.float32), np.zeros(4, np.float32), np.array([0, 2], dtype=np.intp)
    for bad_starts in (np.array([0, 4]), np.array([-1, 2])):
        with pytest.raises(ValueError, match='outside 4 templates'):
            _cloud_accel.trace_minima(norms, products, 1.0, 8, bad_starts)
    with pytest.raises(ValueError, match='as many products as norms'):
        _cloud_accel.trace_minima(norms, products[:3], 1.0, 8, starts)

    def run(times: int) -> None:
        for _ in range(times):
            _cloud_accel.trace_minima(norms, products, 1.0, 8, starts)
            with contextlib.suppress(ValueError):
                _cloud_accel.trace_minima(norms, products, 1.0, 8, starts + 3)

    assert_no_leak(run, (norms, products, starts))
