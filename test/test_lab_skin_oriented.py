"""Clouds whose points carry the ink's orientation (touch_lab.skin.recognisers.oriented), on synthetic symbols."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays
from test_lab_skin_refereed import NAMES, held_out
from test_skin_multistroke import codebook

from touch_gestures.skin.early import ordered_recogniser
from touch_gestures.skin.fused import FusedRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.recognisers import load_codebook, make_recogniser, save_codebook
from touch_lab.skin.recognisers.oriented import (
    OrientedCloudRecogniser,
    OrientedFusedRecogniser,
    exact_oriented_chamfer,
    gather_mean,
    oriented_cloud,
    raster_cells,
)


def strokes_gesture(strokes: list[np.ndarray]) -> TouchGesture:
    """One gesture of the given (m_i, 2) strokes, mm, 150 Hz with a 0.3 s lift between strokes."""
    points = np.concatenate(strokes)
    ids = np.concatenate([np.full(len(s), k, dtype=np.int16) for k, s in enumerate(strokes)])
    times = np.arange(len(points)) / 150.0 + ids * 0.3
    g = TouchGesture.from_trajectory(points, times)
    g.stroke, g.strokes = ids, len(strokes)
    return g


def segment(a, b, n=30) -> np.ndarray:
    return np.linspace(a, b, n)


@pytest.fixture(scope='module')
def fitted():
    gestures, labels = codebook(np.random.default_rng(0), names=NAMES, per_class=10)
    return OrientedFusedRecogniser().fit(gestures, labels), FusedRecogniser().fit(gestures, labels)


def test_each_point_carries_the_undirected_orientation_of_its_ink():
    horizontal = oriented_cloud(segment([0, 0], [20, 0]), None, 8)
    assert np.allclose(horizontal[:, 2:], [1.0, 0.0], atol=1e-12)          # cos 0, sin 0
    backwards = oriented_cloud(segment([20, 0], [0, 0]), None, 8)          # the same line traced the other way
    assert np.allclose(backwards[:, 2:], horizontal[:, 2:], atol=1e-12)
    diagonal = oriented_cloud(segment([0, 0], [20, 20]), None, 8)          # 45 degrees: cos 90 = 0, sin 90 = 1
    assert np.allclose(diagonal[:, 2:], [0.0, 1.0], atol=1e-12)


def test_a_dot_has_no_orientation_and_a_dab_stays_at_the_origin():
    dab = oriented_cloud(np.zeros((5, 2)), None, 6)
    assert np.isfinite(dab).all() and not dab.any()
    # An exclamation point's dot: a stroke of almost no ink gets one point (the last), with no neighbour of
    # its stroke: (0, 0).
    cloud = oriented_cloud(np.vstack([segment([0, 0], [0, 40]), [[0, 50], [0.3, 50]]]),
                           np.r_[np.zeros(30, dtype=int), 1, 1], 16)
    assert (cloud[-1, 2:] == 0).all() and np.allclose(np.hypot(cloud[:-1, 2], cloud[:-1, 3]), 1.0)


def test_the_stroke_order_and_directions_do_not_change_the_distance():
    bar_a, bar_b = segment([0, 0], [20, 20]), segment([20, 0], [0, 20])
    one = oriented_cloud(np.vstack([bar_a, bar_b]), np.r_[np.zeros(30), np.ones(30)], 32)
    other = oriented_cloud(np.vstack([bar_b[::-1], bar_a]), np.r_[np.zeros(30), np.ones(30)], 32)
    # The same ink with the same orientations; the 32 points fall along it at other offsets, each within half a
    # step of one of the other cloud (step: the ink, 2 diagonals of the 20 mm box's side, over 31).
    half_step = 0.5 * 2 * math.sqrt(2.0) / 31
    assert 0.0 <= exact_oriented_chamfer(one, other, 0.35) <= half_step + 1e-12
    assert exact_oriented_chamfer(one, one, 0.35) == 0.0


def test_orientation_tells_an_n_from_an_h_where_the_points_alone_are_close():
    legs = [segment([0, 0], [0, 30]), segment([30, 0], [30, 30])]
    n = oriented_cloud(np.vstack([legs[0], segment([0, 30], [30, 0]), legs[1]]), np.repeat([0, 1, 2], 30), 32)
    h = oriented_cloud(np.vstack([legs[0], segment([0, 15], [30, 15]), legs[1]]), np.repeat([0, 1, 2], 30), 32)
    assert exact_oriented_chamfer(n, h, 0.35) > exact_oriented_chamfer(n, h, 0.0) + 0.05


def _raster_bound(r: OrientedCloudRecogniser) -> float:
    """How far a directed mean read from the raster can be from the exact one (module doc): a point is read at
    its cell's centre (half a diagonal away) and at its bin's centre (w * 2 sin(pi / (2 bins)) away)."""
    return math.sqrt(2.0) / r.grid + r.orientation_weight * 2.0 * math.sin(math.pi / (2 * r.bins))


_CLOUD_POINTS = arrays(np.float64, (8, 2), elements=st.floats(-40.0, 40.0, allow_nan=False))


@settings(max_examples=40, deadline=None)
@given(_CLOUD_POINTS, _CLOUD_POINTS, st.sampled_from([(24, 8, 0.35), (12, 4, 1.0), (32, 12, 0.0)]))
def test_the_raster_distance_is_within_its_cells_and_bins_of_the_exact_one(a, b, params):
    grid, bins, weight = params
    r = OrientedCloudRecogniser(n_points=16, grid=grid, bins=bins, orientation_weight=weight, max_distance=None)
    template, query = (TouchGesture.from_trajectory(p) for p in (a, b))
    r.fit([template], ['a'])
    exact = exact_oriented_chamfer(*(oriented_cloud(g.trajectory, g.stroke, 16) for g in (query, template)), weight)
    raster = float(r.distances(r.features(query))[0])
    # Each point is read at its cell's and bin's centre; float32 fields add ~1e-7 relative to distances below 4.
    assert raster == pytest.approx(exact, abs=_raster_bound(r) + 1e-5)


def test_a_template_is_within_the_raster_bound_of_itself():
    g = strokes_gesture([segment([0, 0], [30, 30]), segment([30, 0], [0, 30])])
    r = OrientedCloudRecogniser(max_distance=None).fit([g, g], ['X', 'X'])
    d = r.distances(r.features(g))
    assert (d >= 0).all() and (d <= _raster_bound(r) + 1e-6).all()


def test_bad_points_make_no_features_and_bad_parameters_are_refused():
    r = OrientedCloudRecogniser()
    bad = TouchGesture.from_trajectory(np.array([[0.0, 0.0], [np.nan, 1.0], [2.0, 2.0]]))
    assert r.features(bad) is None
    for key, value in (('grid', 1), ('bins', 0), ('n_points', 1.5), ('orientation_weight', -0.1),
                       ('orientation_weight', float('nan')), ('bins', True)):
        with pytest.raises(ValueError, match=key):
            make_recogniser('oriented', **{key: value}).fit(*codebook(np.random.default_rng(1), names=NAMES,
                                                                        per_class=2))


def test_one_template_per_class_is_enough_to_name_a_class():
    gestures, labels = codebook(np.random.default_rng(2), names=NAMES, per_class=1)
    r = OrientedCloudRecogniser(max_distance=None).fit(gestures, labels)
    assert [r.predict(g).nearest for g in gestures] == list(labels)


def test_fused_oriented_fires_only_what_the_cloud_fires_and_names_mostly_the_right_class(fitted):
    oriented, fused = fitted
    gestures, labels = held_out()
    for g in gestures:
        mine, its = oriented.predict(g), fused.predict(g)
        # The cloud's rejection rule decides in both: the same command, or none where the sum named another class.
        assert mine.label in (its.label, None)
        if mine.nearest == its.nearest:
            assert mine == its
    assert np.mean([oriented.predict(g).nearest == y for g, y in zip(gestures, labels, strict=True)]) >= 0.9


def test_a_fused_oriented_codebook_file_loads_with_its_three_parts(fitted, tmp_path):
    oriented, _ = fitted
    loaded = load_codebook(save_codebook(tmp_path / 'symbols.npz', oriented, vocabulary='symbols'))
    assert isinstance(loaded, OrientedFusedRecogniser) and ordered_recogniser(loaded) is loaded.fused_.cloud_
    for g in held_out()[0]:
        assert loaded.predict(g) == oriented.predict(g)
    with pytest.raises(ValueError, match='a fused_oriented codebook holds the cloud'):
        labels = oriented.classes_[oriented.template_labels_]
        OrientedFusedRecogniser().set_codebook(oriented.templates_[:, :-1], labels)


def test_a_touch_of_one_point_and_a_trace_ten_times_longer_than_any_template_get_an_answer(fitted):
    oriented, _ = fitted
    dab = TouchGesture.from_trajectory(np.array([[12.0, 20.0]]))
    assert np.isfinite(oriented.oriented_.class_distances(dab)).all()
    oriented.predict(dab)   # named or rejected, never raised
    # The farthest apart float32 points a gesture can hold: their ink is a finite float64, so is every distance.
    big = float(np.finfo(np.float32).max)
    apart = TouchGesture(np.zeros((12, 12), bool), np.zeros((12, 12), np.float32),
                         np.array([[0.0, 0.0], [big, big], [-big, 3.0]]), np.arange(3) / 150.0)
    assert np.isfinite(oriented.oriented_.class_distances(apart)).all()
    assert np.isfinite(oriented.oriented_.features(apart)).all()
    rng = np.random.default_rng(11)
    long = TouchGesture.from_trajectory(np.cumsum(rng.normal(0, 1.5, (4000, 2)), axis=0))
    assert np.isfinite(oriented.oriented_.class_distances(long)).all()
    oriented.predict(long)


def test_a_single_template_column_is_added_in_order_not_pairwise():
    # numpy's mean(axis=0) adds one column pairwise; gather_mean adds the rows in order, each sum in float32
    # (hypothesis found fields [[1.232329], [0]], cells 0 x 6 + 1 x 2 when a compiled twin summed in order).
    fields = np.array([[1.232329], [0.0]], dtype=np.float32)
    cells = np.array([0, 0, 0, 0, 0, 0, 1, 1], dtype=np.intp)
    total = np.float32(0)
    for cell in cells:
        total = np.float32(total + fields[cell, 0])
    assert gather_mean(fields, cells).tolist() == [total / np.float32(len(cells))]


def test_the_class_distances_read_the_cells_of_the_features():
    rng = np.random.default_rng(3)
    gestures = [TouchGesture.from_trajectory(np.cumsum(rng.normal(0, 2, (40, 2)), axis=0)) for _ in range(12)]
    r = OrientedCloudRecogniser().fit(gestures, [f'c{k % 4}' for k in range(12)])
    for g in gestures:
        cells = raster_cells(oriented_cloud(g.trajectory, g.stroke, r.n_points), r.grid, r.bins)
        expected = np.minimum.reduceat(gather_mean(r._fields, cells), r.class_starts_).astype(np.float64)
        np.testing.assert_array_equal(r.class_distances(g), expected)
