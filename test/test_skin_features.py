"""Pre-elaboration helpers: the degenerate inputs a real touch produces, and properties."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_gestures.skin.features import (
    arc_length_resample,
    arc_length_resample_complex,
    bounding_box,
    minmax_normalise,
    nna_indices,
    nna_resample,
    nna_rescale,
    shift_to_corner,
)
from touch_gestures.skin.proposed import time_bin_resample, trace_features

finite = st.floats(-1e3, 1e3, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 300), st.integers(1, 300))
def test_nna_indices_cover_the_input_in_order(n_in, n_out):
    idx = nna_indices(n_in, n_out)
    assert len(idx) == n_out and idx.min() >= 0 and idx.max() <= n_in - 1
    assert np.all(np.diff(idx) >= 0)
    if n_out >= n_in:  # magnification by pixel replication keeps every sample
        assert set(idx.tolist()) == set(range(n_in))


def test_nna_indices_rejects_empty():
    with pytest.raises(ValueError, match='n_in >= 1'):
        nna_indices(0, 4)


def test_minmax_guard_for_a_trace_along_one_row_and_a_single_point():
    row = np.array([[1.0, 7.0], [2.0, 7.0], [5.0, 7.0]])
    with np.errstate(all='raise'):  # no division by zero, not even a warning
        out = minmax_normalise(row)
        point = minmax_normalise(np.array([[3.0, 4.0]]))
    assert out[:, 0].tolist() == [0.0, 0.25, 1.0] and out[:, 1].tolist() == [0.5] * 3
    assert point.tolist() == [[0.5, 0.5]]


@settings(max_examples=60, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 40), st.just(2)), elements=finite))
def test_minmax_output_is_finite_and_in_unit_range(values):
    with np.errstate(divide='raise', invalid='raise', over='raise'):  # underflow of tiny values is fine
        out = minmax_normalise(values)
    assert np.all(np.isfinite(out)) and out.min() >= 0.0 and out.max() <= 1.0
    # Not only the range: each column is the affine map that takes its minimum to 0 and its maximum to 1
    # (order kept), and a column without extent is 0.5 throughout.
    for column, got in zip(values.T, out.T, strict=True):
        span = column.max() - column.min()
        if span < 1e-6:
            assert (got == 0.5).all()
            continue
        assert got[column.argmin()] == 0.0 and got[column.argmax()] == 1.0
        np.testing.assert_allclose(got * span + column.min(), column, rtol=1e-9, atol=1e-9 * max(1.0, abs(span)))
        assert (np.diff(got[np.argsort(column, kind='stable')]) >= 0).all()


def test_maps_empty_single_and_line():
    empty = np.zeros((12, 12), bool)
    assert bounding_box(empty) is None and nna_rescale(empty) is None
    assert not shift_to_corner(empty).any()
    one = empty.copy()
    one[7, 3] = True
    assert nna_rescale(one).all()  # one taxel fills the rescaled box
    assert shift_to_corner(one)[0, 0] and shift_to_corner(one).sum() == 1
    diag = np.eye(12, dtype=bool)[::-1]
    assert (nna_rescale(diag) == diag).all()


def test_resamplers_on_one_point_and_a_finger_that_never_moves():
    one = np.array([[3.0, 4.0]])
    assert nna_resample(one, 5).tolist() == [[3.0, 4.0]] * 5
    assert arc_length_resample(one, 3).tolist() == [[3.0, 4.0]] * 3
    still = np.repeat(one, 10, axis=0)
    assert arc_length_resample(still, 4).tolist() == [[3.0, 4.0]] * 4
    with pytest.raises(ValueError):
        arc_length_resample(np.zeros((0, 2)), 3)


def per_coordinate_resample(points: np.ndarray, n: int, stroke: np.ndarray | None) -> np.ndarray:
    """The definition, x and y interpolated apart along the ink (the resampling before complex numbers)."""
    step = np.hypot(*np.diff(points, axis=0).T)
    if stroke is not None:
        step[np.diff(stroke) != 0] = 0.0
    cum = np.concatenate([[0.0], np.cumsum(step)])
    if not cum[-1] > 0:
        return np.repeat(points[:1], n, axis=0)
    target = np.linspace(0.0, cum[-1], n)
    return np.column_stack([np.interp(target, cum, points[:, 0]), np.interp(target, cum, points[:, 1])])


@settings(max_examples=80, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 60), st.just(2)), elements=finite),
       st.lists(st.integers(0, 3), min_size=60, max_size=60), st.integers(2, 64), st.booleans())
def test_resampling_as_complex_numbers_is_the_per_coordinate_one(points, strokes, n, with_strokes):
    stroke = np.sort(np.asarray(strokes[: len(points)])) if with_strokes else None
    out = arc_length_resample(points, n, stroke)
    assert out.shape == (n, 2) and out.dtype == np.float64 and out.flags['C_CONTIGUOUS']
    assert np.array_equal(out, arc_length_resample_complex(points, n, stroke).view(np.float64).reshape(n, 2))
    ref = per_coordinate_resample(points, n, stroke)
    # np.interp on complex numbers multiplies by 1 / (xp[j+1] - xp[j]) where the real one divides and may
    # associate differently: each coordinate's slope (at most 1 in size: |dx| <= the step) times the
    # position along the ink (up to the path's length) and plus the coordinate, rounded a few times: a
    # few ulp of the larger of the coordinates and the ink's length; the path's first point is exact.
    scale = float(np.abs(points).max()) + float(np.hypot(*np.diff(points, axis=0).T).sum())
    np.testing.assert_allclose(out, ref, rtol=0, atol=4 * np.finfo(np.float64).eps * max(scale, 1.0))
    assert np.array_equal(out[0], ref[0])


def test_resampling_rejects_what_is_no_path():
    with pytest.raises(ValueError, match=r'\(m, 2\)'):
        arc_length_resample(np.zeros((4, 3)), 8)


def test_time_bins_fill_empty_bins_and_survive_bad_clocks():
    pts = np.array([[0.0, 0.0], [10.0, 0.0]])
    out = time_bin_resample(pts, np.array([0.0, 1.0]), 5)
    assert np.allclose(out[:, 0], [0, 2.5, 5, 7.5, 10])  # interpolated between the two bins that have points
    same_time = time_bin_resample(pts, np.array([2.0, 2.0]), 2)  # no duration: sample index instead
    backwards = time_bin_resample(pts, np.array([1.0, 0.0]), 2)
    assert same_time[:, 0].tolist() == [0.0, 10.0] and backwards[:, 0].tolist() == [0.0, 10.0]


def test_trace_features_of_degenerate_gestures():
    with np.errstate(all='raise'):
        assert not trace_features(np.array([[5.0, 5.0]]), np.array([0.0]), 8).any()      # one point
        assert not trace_features(np.full((20, 2), 3.0), np.arange(20.0), 8).any()      # never moves
        row = trace_features(np.column_stack([np.linspace(0, 30, 50), np.full(50, 9.0)]), np.arange(50.0), 8)
    assert np.allclose(row.reshape(8, 2)[:, 1], 0.0)          # along one row: y stays flat
    assert row.reshape(8, 2)[0, 0] < row.reshape(8, 2)[-1, 0]  # and the direction is kept


@settings(max_examples=80, deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 60), st.just(2)), elements=finite),
       st.lists(st.floats(0, 10, allow_nan=False), min_size=60, max_size=60))
def test_trace_features_are_finite_and_bounded(points, times):
    t = np.asarray(times[: len(points)])
    f = trace_features(points, t, 16)
    assert f.shape == (32,) and f.dtype == np.float32
    assert np.all(np.isfinite(f)) and np.abs(f).max() <= 0.5 + 1e-6


def test_trace_features_ignore_position_size_and_speed():
    t = np.linspace(0, 1, 80)
    path = np.column_stack([np.cos(3 * t), np.sin(5 * t)])
    base = trace_features(path, t, 32)
    moved = trace_features(path * 2.5 + [10.0, -4.0], t * 3.0 + 7.0, 32)  # bigger, elsewhere, 3x slower
    np.testing.assert_allclose(base, moved, atol=1e-5)
    reverse = trace_features(path[::-1], t, 32)
    assert np.abs(base - reverse).max() > 0.1  # direction counts


def test_a_subnormal_duration_falls_back_to_the_sample_index_without_overflow():
    import warnings

    from touch_gestures.skin.proposed import time_bin_resample
    points = np.array([[0.0, 0.0], [1.0, 0.0], [2.0, 0.0]])
    with warnings.catch_warnings():
        warnings.simplefilter('error')
        out = time_bin_resample(points, np.array([0.0, 5e-324, 1e-323]), 4)
    assert out[:, 0].tolist() == time_bin_resample(points, np.array([0.0, 0.0, 0.0]), 4)[:, 0].tolist()
