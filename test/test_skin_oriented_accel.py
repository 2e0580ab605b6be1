"""The oriented cloud's compiled query (cloud_accel.oriented_cells, oriented_mean) against its numpy reference."""

from __future__ import annotations

import math
import os

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from leak_testing import assert_no_leak

from touch_gestures.skin import cloud_accel
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.oriented import OrientedCloudRecogniser, gather_mean, oriented_cloud, raster_cells

REQUIRED = os.environ.get('SOCIAL_TOUCH_REQUIRE_SKIN_ACCEL') == '1'
needs_accel = pytest.mark.skipif(not cloud_accel.available() and not REQUIRED,
                                 reason=f'the compiled cloud search was not built here: {cloud_accel.IMPORT_ERROR}')


def _compiled():
    from touch_gestures.skin import _cloud_accel
    return _cloud_accel


def _near_a_bin_edge(cloud: np.ndarray, bins: int) -> np.ndarray:
    """(n,) True where a point's orientation is within 1e-9 half turns of a bin's edge: libm's atan2 and numpy's may
    round to either side there (an ulp apart)."""
    half_turns = np.arctan2(cloud[:, 3], cloud[:, 2]) * (bins / (2 * math.pi)) + 0.5
    return np.abs(half_turns - np.round(half_turns)) < 1e-9


_POINTS = arrays(np.float64, st.tuples(st.integers(1, 40), st.just(2)),
                 elements=st.floats(-60.0, 60.0, allow_nan=False, allow_subnormal=False))


@needs_accel
@settings(max_examples=200, deadline=None)
@given(_POINTS, st.integers(0, 3), st.sampled_from([(32, 24, 8), (16, 12, 4), (5, 3, 1), (2, 7, 6)]))
def test_the_compiled_cells_are_numpys(points, cuts, params):
    n, grid, bins = params
    strokes = np.sort(np.random.default_rng(len(points)).integers(0, cuts + 1, len(points))).astype(np.int16)
    for stroke in (strokes, None):
        cloud = oriented_cloud(points, stroke, n)
        expected = raster_cells(cloud, grid, bins)
        got = _compiled().oriented_cells(points, stroke, n, grid, bins)
        assert got.dtype == np.intp and got.shape == (n,)
        differ = got != expected
        # Only an orientation at a bin's edge may fall on the other side; the position's cell is the same.
        assert not (differ & ~_near_a_bin_edge(cloud, bins)).any()
        assert (got[differ] // (bins + 1) == expected[differ] // (bins + 1)).all()


@needs_accel
@settings(max_examples=100, deadline=None)
@given(arrays(np.float32, st.tuples(st.integers(1, 30), st.integers(1, 20)),
              elements=st.floats(0.0, 4.0, width=32)), st.data())
def test_the_compiled_mean_is_numpys_bit_for_bit(fields, data):
    # Both add the rows in order in float32 and divide once (gather_mean); a single template's column too, which
    # numpy's mean(axis=0) would add pairwise (hypothesis found fields [[1.232329], [0]], cells 0 x 6 + 1 x 2).
    cells = np.array(data.draw(st.lists(st.integers(0, len(fields) - 1), min_size=1, max_size=40)), dtype=np.intp)
    got = _compiled().oriented_mean(fields, cells)
    assert got.dtype == np.float32
    np.testing.assert_array_equal(got, gather_mean(fields, cells))


@needs_accel
def test_a_single_template_column_is_added_in_order_not_pairwise():
    fields = np.array([[1.232329], [0.0]], dtype=np.float32)
    cells = np.array([0, 0, 0, 0, 0, 0, 1, 1], dtype=np.intp)
    np.testing.assert_array_equal(_compiled().oriented_mean(fields, cells), gather_mean(fields, cells))
    total = np.float32(0)
    for cell in cells:                     # the rows one after the other, each sum rounded to float32
        total = np.float32(total + fields[cell, 0])
    assert gather_mean(fields, cells).tolist() == [total / np.float32(len(cells))]


@needs_accel
def test_the_recogniser_answers_the_same_with_either_query_path():
    rng = np.random.default_rng(3)
    gestures = [TouchGesture.from_trajectory(np.cumsum(rng.normal(0, 2, (40, 2)), axis=0)) for _ in range(12)]
    r = OrientedCloudRecogniser().fit(gestures, [f'c{k % 4}' for k in range(12)])
    for g in gestures:
        cells = raster_cells(oriented_cloud(g.trajectory, g.stroke, r.n_points), r.grid, r.bins)
        expected = np.minimum.reduceat(gather_mean(r._fields, cells), r.class_starts_).astype(np.float64)
        np.testing.assert_array_equal(r.class_distances(g), expected)


@needs_accel
def test_bad_input_is_refused_with_what_was_expected():
    c = _compiled()
    good = np.array([[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ValueError, match='finite'):
        c.oriented_cells(np.array([[0.0, 0.0], [np.nan, 1.0]]), None, 8, 4, 4)
    with pytest.raises(ValueError, match='empty path'):
        c.oriented_cells(np.zeros((0, 2)), None, 8, 4, 4)
    with pytest.raises(ValueError, match='one stroke id per point'):
        c.oriented_cells(good, np.zeros(3), 8, 4, 4)
    with pytest.raises(OverflowError, match='overflows'):   # finite points whose ink is no finite number
        c.oriented_cells(np.array([[0.0, 0.0], [1e308, 1e308], [-1e308, 3.0]]), None, 8, 4, 4)
    with pytest.raises(ValueError, match='n >= 2'):
        c.oriented_cells(good, None, 1, 4, 4)
    fields = np.zeros((5, 3), dtype=np.float32)
    with pytest.raises(IndexError, match='outside'):
        c.oriented_mean(fields, np.array([0, 5], dtype=np.intp))
    with pytest.raises(ValueError, match='float32'):
        c.oriented_mean(fields.astype(np.float64), np.array([0], dtype=np.intp))
    with pytest.raises(ValueError, match='non-empty'):
        c.oriented_mean(fields, np.array([], dtype=np.intp))


@needs_accel
def test_the_compiled_query_leaks_nothing():
    c = _compiled()
    points, stroke = np.random.default_rng(4).normal(0, 10, (30, 2)), np.repeat([0, 1, 2], 10)
    fields = np.random.default_rng(5).random((24 * 24 * 9, 50)).astype(np.float32)
    bad = np.array([[0.0, 0.0], [np.inf, 0.0]])

    def run(rounds: int) -> None:
        for _ in range(rounds):
            c.oriented_mean(fields, c.oriented_cells(points, stroke, 32, 24, 8))
            with pytest.raises(ValueError):
                c.oriented_cells(bad, None, 32, 24, 8)

    assert_no_leak(run, (points, stroke, fields, bad))
