"""The skin recognisers: shared interface, direction, hard cases, rejection (synthetic gestures)."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from touch_gestures.estimator import NotFittedError
from touch_gestures.skin import TouchGesture
from touch_lab.skin.recognisers import RECOGNISERS, make_recogniser
from touch_sim.skin.synthetic import PAPER_CENTROID_SET, random_touches, synthetic_traces

# $1 (rotated to its indicative angle) and Protractor (free rotation) make a line and its reverse one
# shape: they follow the trace's order but are blind to a line's direction.
DIRECTION_AWARE = ['centroid', 'dtw', 'trace']
FAST = ['static', 'map', 'centroid', 'protractor', 'trace']  # cheap enough to run on every test


def as_gesture(sample):
    return TouchGesture.from_trajectory(np.column_stack([sample.x, sample.y]), sample.t_ms / 1000.0)


@pytest.fixture(scope='module')
def fig8():
    """cirillo2017 Fig. 8 gestures by 4 synthetic performers: 3 for the codebook, 1 to test."""
    traces = synthetic_traces(PAPER_CENTROID_SET, performers=4, repetitions=4, seed=11, rate_hz=150.0)
    train = [(as_gesture(s), s.gesture) for s in traces if s.subject != 'synthetic3']
    test = [(as_gesture(s), s.gesture) for s in traces if s.subject == 'synthetic3']
    return train, test


@pytest.mark.parametrize('name', list(RECOGNISERS))
def test_interface_and_accuracy_on_an_unseen_performer(name, fig8):
    train, test = fig8
    model = make_recogniser(name)
    with pytest.raises(NotFittedError):
        model.predict(test[0][0])
    assert model.fit([g for g, _ in train], [y for _, y in train]) is model
    assert list(model.classes_) == sorted(PAPER_CENTROID_SET)
    assert model.templates_.dtype == np.float32 and model.class_thresholds_.shape == (5,)
    nearest = [model.predict(g).nearest for g, _ in test]
    accuracy = np.mean([p == y for p, (_, y) in zip(nearest, test, strict=True)])
    assert accuracy >= 0.4, (name, accuracy)  # twice chance, whatever the method
    # auto is whichever recogniser the codebook's rule chose, and as direction-aware as that one
    assert model.direction_aware == ((model.choice_ if name == 'auto' else name) in DIRECTION_AWARE)
    if name in ('trace', 'dtw'):  # direction-aware and robust to slant, shake and speed
        assert accuracy >= 0.95, (name, accuracy)
    clone(model)  # a proper scikit-learn estimator: parameters round-trip through get_params


@pytest.mark.parametrize('name', ['map', 'static', 'pdollar', 'dollar1', 'protractor'])
def test_blind_recognisers_cannot_tell_a_reversed_line(name):
    t = np.linspace(0, 1, 60)
    right = TouchGesture.from_trajectory(np.column_stack([5 + 35 * t, 5 + 35 * t]), t)
    left = TouchGesture.from_trajectory(np.column_stack([40 - 35 * t, 40 - 35 * t]), t)
    other = TouchGesture.from_trajectory(np.column_stack([40 - 35 * t, 5 + 35 * t]), t)
    model = make_recogniser(name, max_distance=None).fit([right, other], ['right', 'other'])
    # The reversed line is exactly as close as the line itself (Protractor: as close as any line).
    np.testing.assert_allclose(model.class_distances(left), model.class_distances(right), atol=1e-3)


@pytest.mark.parametrize('name', DIRECTION_AWARE)
def test_direction_aware_recognisers_tell_a_reversed_line(name):
    t = np.linspace(0, 1, 60)
    right = TouchGesture.from_trajectory(np.column_stack([5 + 35 * t, 20 + 0.5 * np.sin(9 * t)]), t)
    left = TouchGesture.from_trajectory(np.column_stack([40 - 35 * t, 22 + 0.5 * np.cos(7 * t)]), t)
    model = make_recogniser(name, max_distance=None).fit([right, left], ['right', 'left'])
    query = TouchGesture.from_trajectory(np.column_stack([38 - 30 * t, 25 + 0.3 * np.sin(5 * t)]), t)
    assert model.predict(query).nearest == 'left'


def _hard_cases():
    t = np.linspace(0, 0.5, 40)
    return {
        'one point': TouchGesture.from_trajectory(np.array([[20.0, 20.0]]), np.array([0.0])),
        'along one row': TouchGesture.from_trajectory(np.column_stack([5 + 30 * t, np.full(40, 12.0)]), t),
        'never moves': TouchGesture.from_trajectory(np.full((30, 2), 7.0), np.linspace(0, 1, 30)),
        'no clock': TouchGesture.from_trajectory(np.column_stack([t, t]) * 40, np.zeros(40)),
    }


@pytest.mark.parametrize('name', list(RECOGNISERS))
def test_hard_cases_give_finite_answers_without_warnings(name, fig8):
    train, _ = fig8
    model = make_recogniser(name).fit([g for g, _ in train[:40]], [y for _, y in train[:40]])
    with np.errstate(divide='raise', invalid='raise', over='raise'):
        for case, gesture in _hard_cases().items():
            match = model.predict(gesture)
            assert np.isfinite(match.distance) and match.nearest is not None, case
    empty = TouchGesture(np.zeros((12, 12), bool), np.zeros((12, 12)), np.zeros((0, 2)), np.zeros(0))
    match = model.predict(empty)
    assert match.label is None and match.rejected == 'unusable'


@pytest.mark.parametrize('name', FAST)
def test_codebook_with_one_class_or_one_repetition(name, fig8):
    train, test = fig8
    ones = [(g, y) for g, y in train if y == 'one']
    model = make_recogniser(name).fit([g for g, _ in ones], [y for _, y in ones])
    match = model.predict(test[0][0])
    assert match.margin == float('inf') and match.nearest == 'one'  # no runner-up, no division by it
    first = {}
    for g, y in train:
        first.setdefault(y, g)
    model = make_recogniser(name).fit(list(first.values()), list(first))
    assert np.isfinite(model.class_thresholds_).all() and (model.class_thresholds_ > 0).all()
    single = make_recogniser(name).fit([train[0][0]], [train[0][1]])
    assert single.class_thresholds_.tolist() == [float('inf')]
    assert single.predict(test[1][0]).label == train[0][1]


def test_a_touch_far_from_every_template_fires_nothing(fig8):
    train, test = fig8
    model = make_recogniser('trace').fit([g for g, _ in train], [y for _, y in train])
    accepted = [model.predict(g).label for g, _ in test]
    assert np.mean([a == y for a, (_, y) in zip(accepted, test, strict=True)]) >= 0.8
    touches = [as_gesture(s) for s in random_touches(45, seed=3)]
    fired = np.mean([model.predict(g).label is not None for g in touches])
    assert fired <= 0.25, fired
    t = np.linspace(0, 2 * np.pi, 120)
    circle = TouchGesture.from_trajectory(np.column_stack([23 + 15 * np.cos(t), 23 + 15 * np.sin(t)]), t)
    assert model.predict(circle).label is None and model.predict(circle).rejected == 'distance'


def test_margin_rule_rejects_ambiguous_touches():
    t = np.linspace(0, 1, 50)
    a = TouchGesture.from_trajectory(np.column_stack([5 + 30 * t, 5 + 30 * t]), t)
    b = TouchGesture.from_trajectory(np.column_stack([5 + 30 * t, 5 + 30 * t ** 1.3]), t)
    model = make_recogniser('trace', max_distance=None, min_margin=1.0).fit([a, b], ['a', 'b'])
    mid = TouchGesture.from_trajectory(np.column_stack([5 + 30 * t, 5 + 30 * t ** 1.15]), t)
    match = model.predict(mid)
    assert match.label is None and match.rejected == 'margin' and match.margin < match.distance


def test_fit_and_parameter_errors(fig8):
    train, _ = fig8
    with pytest.raises(ValueError, match=r'one label \(and person, if given\) per gesture'):
        make_recogniser('trace').fit([train[0][0]], ['a', 'b'])
    empty = TouchGesture(np.zeros((12, 12), bool), np.zeros((12, 12)), np.zeros((0, 2)), np.zeros(0))
    with pytest.raises(ValueError, match='usable template'):
        make_recogniser('centroid').fit([empty], ['a'])
    with pytest.raises(ValueError, match="max_distance must be 'auto'"):
        make_recogniser('trace', max_distance=-1).fit([train[0][0]], ['a'])
    with pytest.raises(ValueError, match="did you mean 'n_points'"):
        make_recogniser('trace', n_point=16)
    with pytest.raises(ValueError, match='unknown recogniser'):
        make_recogniser('centriod')


def test_the_runtime_names_what_a_robot_runs_and_points_to_the_lab_for_the_rest():
    from touch_gestures.skin import registry as runtime
    assert set(runtime.RECOGNISERS) < set(RECOGNISERS)
    assert all(RECOGNISERS[name] is cls for name, cls in runtime.RECOGNISERS.items())   # the lab extends it
    with pytest.raises(ValueError, match=r"unknown recogniser 'refereed'.*touch_lab\.skin\.recognisers"):
        runtime.make_recogniser('refereed')
    assert make_recogniser('refereed').name == 'refereed'
