"""The touch's size as evidence for the acceptance score (touch_gestures.skin.doubt ``size``, issue 26 item 2).

Every gesture here is synthetic: hand-made points, or test/test_skin_codebook_people.py's letters (polylines
with tremor) and random corners for touches that are no gesture. test/data/skin_codebook_main_2e02c34.npz is a
codebook written by main's code before sizes were recorded (2e02c34; synthetic letters, fused, calibrated with the
disagreement), with main's decisions on :func:`old_touches` (``..._decisions.npz``). Both were written by main's
code (its tree first on ``PYTHONPATH``) running::

    model, rng = people_codebook(seed=11, people=3, name='fused')
    calibrate_acceptance(model, 0.005, scribbles(rng, 80))
    save_codebook(path, model, vocabulary='letters', description='synthetic: test letters, main 2e02c34')
    matches = model.predict_many(old_touches())   # kept: str(m.rejected), str(m.label) of each
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_skin_acceptance import people_codebook, scribbles
from test_skin_codebook_people import drawn

from touch_gestures.skin import load_codebook, save_codebook
from touch_gestures.skin.doubt import (
    CONTEXT_FEATURES,
    FEATURE_BOUND,
    PRODUCT_WEIGHTS,
    SIZE_SPREAD_FLOOR,
    ClassHabits,
    context_features,
    doubt,
    touch_size_mm,
)
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.acceptance import calibrate_acceptance, habits_of

DATA = Path(__file__).parent / 'data'
SIZE = len(PRODUCT_WEIGHTS) + CONTEXT_FEATURES.index('size')   # the size feature's weight
# Two classes: 0 drawn about 30 mm across, 1 about 10 mm.
LABELS = np.array([0] * 20 + [1] * 20)
SIZES_MM = np.r_[np.linspace(27.0, 33.0, 20), np.linspace(9.0, 11.0, 20)]


def old_touches() -> list[TouchGesture]:
    rng = np.random.default_rng(12)
    return scribbles(rng, 40) + drawn(rng, people=1, per_person=2, backwards=())[0]


def test_a_touchs_size_is_the_diagonal_of_its_box_without_nan_points():
    assert touch_size_mm(np.array([[0.0, 0.0], [30.0, 40.0]])) == 50.0
    assert touch_size_mm(np.array([[0.0, 0.0], [np.nan, 5.0], [3.0, 4.0]])) == 5.0
    assert touch_size_mm(np.array([[7.0, 7.0]])) == 0.0                 # one point
    assert math.isnan(touch_size_mm(np.empty((0, 2))))
    assert math.isnan(touch_size_mm(np.array([[np.nan, np.nan]])))


def test_a_size_far_from_the_class_in_its_own_spread_is_implausible():
    h = ClassHabits(LABELS, 2, sizes_mm=SIZES_MM)
    assert h.size_feature(0, 30.0) < 0.5 < 3.0 < h.size_feature(0, 10.0)
    assert h.size_feature(1, 10.0) < 0.5 < 3.0 < h.size_feature(1, 30.0)
    # Log units: twice and half as large are as far.
    assert h.size_feature(0, 60.0) == pytest.approx(h.size_feature(0, 15.0), rel=0.05)
    # Not known, NaN, no extent (one point, a press in one place): no evidence.
    assert ClassHabits(LABELS, 2).size_feature(0, 1.0) == 0.0
    assert h.size_feature(0, math.nan) == h.size_feature(0, 0.0) == 0.0
    # A huge touch is far but the feature is clipped.
    assert h.size_feature(0, 1e30) > FEATURE_BOUND
    assert context_features(h, 0, 1, 1.0, None, 1e30)[-1] == FEATURE_BOUND
    # Templates of no known size say nothing; equal sizes still give a spread.
    unsized = ClassHabits(np.array([0, 0, 1]), 2, sizes_mm=np.array([np.nan, 0.0, 12.0]))
    assert unsized.size_feature(0, 50.0) == 0.0 and unsized.size_feature(1, 50.0) > 0
    same = ClassHabits(np.zeros(5, dtype=int), 1, sizes_mm=np.full(5, 20.0))
    assert same.log_size_spread[0] == SIZE_SPREAD_FLOOR and np.isfinite(same.size_feature(0, 21.0))


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(0.05, 10.0), min_size=3, max_size=6), st.floats(0.01, 1000.0), st.floats(0.01, 1000.0),
       st.floats(0.01, 3.0), st.integers(0, 1))
def test_with_a_positive_weight_the_score_grows_with_the_size_distance(d, first, second, weight, named):
    h = ClassHabits(LABELS, 2, sizes_mm=SIZES_MM)
    d = np.asarray(d)
    d[named] = min(d) * 0.5   # the named class is the nearest
    near, far = sorted((first, second), key=lambda s: h.size_feature(named, s))
    weights = (0.5, 1.0, 1.0, 0.0, 0.0, *(weight if n == 'size' else 0.0 for n in CONTEXT_FEATURES))
    at = [doubt(d, named, np.ones(len(d)), weights, context_features(h, named, 1, 1.0, None, size))
          for size in (near, far)]
    assert at[0] <= at[1]


def test_a_codebook_written_by_main_loads_and_decides_as_before(tmp_path):
    path = DATA / 'skin_codebook_main_2e02c34.npz'
    model = load_codebook(path)
    assert model.template_sizes_mm_ is None
    assert len(model.acceptance_['score_weights']) == len(PRODUCT_WEIGHTS) + 3   # before the size existed
    expected = np.load(DATA / 'skin_codebook_main_2e02c34_decisions.npz')
    touches = old_touches()
    matches = model.predict_many(touches)
    assert [str(m.rejected) for m in matches] == expected['rejected'].tolist()
    assert [str(m.label) for m in matches] == expected['label'].tolist()
    assert {'score', 'None'} <= set(expected['rejected'].tolist())   # the score decides some of them
    # Written again by this code: still without sizes, still the same decisions.
    again = load_codebook(save_codebook(tmp_path / 'again.npz', model, vocabulary='letters'))
    assert again.template_sizes_mm_ is None
    assert [str(m.rejected) for m in again.predict_many(touches)] == expected['rejected'].tolist()


def test_a_fitted_codebook_records_and_keeps_its_templates_sizes(tmp_path):
    model, _ = people_codebook(name='fused')
    assert model.template_sizes_mm_.shape == (len(model.templates_),)
    # Grouped by class like the templates: each template's size is its letter's.
    gestures, labels, _ = drawn(np.random.default_rng(3), people=4, per_person=5, backwards=())
    by_class = {c: sorted(touch_size_mm(g.trajectory) for g, y in zip(gestures, labels, strict=True) if y == c)
                for c in set(labels)}
    for c, name in enumerate(model.classes_):
        np.testing.assert_allclose(sorted(model.template_sizes_mm_[model.template_labels_ == c]), by_class[name])
    loaded = load_codebook(save_codebook(tmp_path / 'sized.npz', model))
    np.testing.assert_array_equal(loaded.template_sizes_mm_, model.template_sizes_mm_)
    with pytest.raises(ValueError, match='template_sizes_mm'):
        model.set_codebook(model.templates_, model.classes_[model.template_labels_], template_sizes_mm=[1.0])
    with pytest.raises(ValueError, match='template_sizes_mm'):
        model.set_codebook(model.templates_, model.classes_[model.template_labels_],
                           template_sizes_mm=-np.ones(len(model.templates_)))


def shrunk(gesture: TouchGesture, factor: float) -> TouchGesture:
    """The same trace drawn ``factor`` times as large about its first point (a rub or wiggle of its shape)."""
    points = gesture.trajectory.astype(np.float64)
    return TouchGesture.from_trajectory(points[0] + factor * (points - points[0]), gesture.times)


@pytest.mark.parametrize('name', ['trace', 'fused'])
def test_a_calibration_with_the_size_keeps_it_and_the_robot_decides_by_it(tmp_path, name):
    model, rng = people_codebook(name=name)
    letters = drawn(rng, people=1, per_person=2, backwards=())[0]
    # No-gesture touches the shape cannot tell: the letters, drawn a fifth as large.
    strays = scribbles(rng, 60) + [shrunk(g, 0.2) for g in drawn(rng, people=2, per_person=3, backwards=())[0]]
    calibrate_acceptance(model, 0.005, strays, context=('size',))
    record = model.acceptance_
    weights = record['score_weights']
    assert record['score_features'][-1] == 'size' and len(weights) == SIZE + 1 and weights[SIZE] > 0
    loaded = load_codebook(save_codebook(tmp_path / 's.npz', model))
    small = [shrunk(g, 0.2) for g in letters]
    touches = letters + small + scribbles(rng, 20)
    assert [m.rejected for m in loaded.predict_many(touches)] == [m.rejected for m in model.predict_many(touches)]
    h = habits_of(model)
    scores = []
    for g in touches:
        match = model.predict(g)
        cloud, second = model.opinions(g)
        best = int(np.searchsorted(model.classes_, match.nearest))
        scores.append(doubt(cloud, best, np.asarray(record['class_scales']), weights,
                            context_features(h, best, g.strokes, g.contact_s, second, touch_size_mm(g.trajectory))))
        if match.rejected in (None, 'score'):
            assert (match.rejected is None) == (scores[-1] <= (record['max_score'] or math.inf))
    # The same shape a fifth as large is more doubtful.
    assert all(s > r for r, s in zip(scores[:len(letters)], scores[len(letters):2 * len(letters)], strict=True))


def test_touches_of_no_size_nan_points_one_point_and_huge_do_not_break_a_sized_decision():
    model, rng = people_codebook(name='fused')
    strays = scribbles(rng, 60) + [shrunk(g, 0.2) for g in drawn(rng, people=2, per_person=3, backwards=())[0]]
    calibrate_acceptance(model, 0.005, strays, context=('disagreement', 'size'))
    assert len(model.acceptance_['score_weights']) == SIZE + 1
    letter = drawn(rng, people=1, per_person=1, backwards=())[0][0]
    with_nan = letter.trajectory.copy()
    with_nan[len(with_nan) // 2] = np.nan
    touches = [
        TouchGesture.from_trajectory(np.full((12, 2), 20.0), np.linspace(0, 0.5, 12)),   # pressed in one place
        TouchGesture.from_trajectory(with_nan, letter.times),
        TouchGesture.from_trajectory(np.array([[20.0, 20.0]])),                           # one point
        shrunk(letter, 1e6),                                                              # huge
    ]
    for g in touches:
        match = model.predict(g)
        assert match.rejected in (None, 'unusable', 'score', 'margin', 'strokes', 'duration', 'order'), match
