"""The cloud and the trace summed (touch_gestures.skin.fused), on synthetic symbols."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from test_lab_skin_refereed import NAMES, held_out
from test_skin_multistroke import codebook

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.early import ordered_recogniser
from touch_gestures.skin.fused import FusedRecogniser, relative_distances
from touch_lab.skin.recognisers import load_codebook, make_recogniser, save_codebook


@pytest.fixture(scope='module')
def fitted():
    gestures, labels = codebook(np.random.default_rng(0), names=NAMES, per_class=10)
    return FusedRecogniser().fit(gestures, labels), CloudRecogniser().fit(gestures, labels)


def test_with_the_strict_rule_it_fires_only_what_the_cloud_fires_and_names_mostly_the_right_class(fitted):
    _, cloud = fitted
    gestures, labels = codebook(np.random.default_rng(0), names=NAMES, per_class=10)
    fused = FusedRecogniser(disagreement='always').fit(gestures, labels)
    gestures, labels = held_out()
    for g in gestures:
        mine, its = fused.predict(g), cloud.predict(g)
        # The cloud's rejection rule decides: the same command, or none where the sum named another class.
        assert mine.label in (its.label, None)
        if mine.nearest == its.nearest:
            assert mine == its
    assert np.mean([fused.predict(g).nearest == y for g, y in zip(gestures, labels, strict=True)]) >= 0.9


class _Trace:
    """Stands in for the trace: fixed class distances."""

    def __init__(self, distances) -> None:
        self.distances = distances

    def class_distances(self, gesture):
        return None if self.distances is None else np.asarray(self.distances, dtype=np.float64)


def test_the_class_of_the_smallest_sum_of_relative_distances_is_named_among_those_allowed(fitted):
    fused, _ = fitted
    g = held_out()[0][0]
    saved = fused.trace_
    cloud = np.array([1.0, 1.1, 3.0, 4.0, 5.0])
    try:
        fused.trace_ = _Trace([2.0, 1.0, 9.0, 9.0, 9.0])      # sums 3.0 and 2.1: the trace's nearest wins
        assert fused._nearest(g, cloud, None) == 1
        fused.trace_ = _Trace([1.0, 1.05, 9.0, 9.0, 9.0])     # sums 2.0 and 2.15: the cloud's nearest stays
        assert fused._nearest(g, cloud, None) == 0
        fused.trace_ = _Trace([2.0, 1.0, 9.0, 9.0, 9.0])
        assert fused._nearest(g, cloud, np.array([True, False, True, True, True])) == 0   # class 1 ruled out
        fused.trace_ = _Trace(None)                            # the trace cannot read it: the cloud alone
        assert fused._nearest(g, cloud, None) == 0
        fused.trace_ = _Trace([0.0, 1.0, 9.0, 9.0, 9.0])      # an exact match of the trace: its class
        assert fused._nearest(g, cloud, None) == 0
        fused.trace_ = _Trace([1.0, 0.0, 9.0, 9.0, 9.0])
        assert fused._nearest(g, cloud, None) == 1
    finally:
        fused.trace_ = saved


@given(st.lists(st.floats(0.0, 1e6, allow_nan=False), min_size=1, max_size=20))
def test_relative_distances_keep_the_order_and_put_the_nearest_at_one(values):
    d = np.array(values)
    rel = relative_distances(d)
    assert rel.dtype == np.float64 and not np.isnan(rel).any()
    assert int(np.argmin(rel)) == int(np.argmin(d))
    if d.min() > 0:
        assert rel.min() == pytest.approx(1.0, rel=1e-12)   # x / x in float64
    ordered = rel[np.argsort(d, kind='stable')]
    assert (ordered[1:] >= ordered[:-1]).all()


def test_unreadable_distances_stay_as_they_are():
    assert np.isinf(relative_distances(np.array([np.inf, np.inf]))).all()


def test_a_fused_codebook_file_loads_with_both_parts_and_ends_gestures_by_its_cloud(fitted, tmp_path):
    fused, _ = fitted
    loaded = load_codebook(save_codebook(tmp_path / 'symbols.npz', fused, vocabulary='symbols'))
    assert isinstance(loaded, FusedRecogniser) and ordered_recogniser(loaded) is loaded.cloud_
    for g in held_out()[0]:
        assert loaded.predict(g) == fused.predict(g)
    for bad in (1, 0, 2.5, True):
        with pytest.raises(ValueError, match='trace_points'):
            make_recogniser('fused', trace_points=bad).fit(*codebook(np.random.default_rng(1), names=NAMES,
                                                                     per_class=2))
