"""The acceptance score's context features: a second opinion's disagreement, plausible strokes and duration
(touch_gestures.skin.doubt, issue 26 item 2).

Every gesture here is synthetic: hand-made numbers, or test/test_skin_codebook_people.py's letters (polylines
with tremor) and random corners for touches that are no gesture.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from test_skin_acceptance import people_codebook, scribbles
from test_skin_codebook_people import drawn

from touch_gestures.skin import load_codebook, save_codebook
from touch_gestures.skin.doubt import (
    CONTEXT_FEATURES,
    DOUBT_FEATURES,
    DURATION_SPREAD_FLOOR,
    FEATURE_BOUND,
    PRODUCT_WEIGHTS,
    ClassHabits,
    context_features,
    disagreement,
    doubt,
    touch_size_mm,
)
from touch_lab.skin.acceptance import HeldOut, calibrate_acceptance, fit_weights, scores

# Two classes: 0 always one stroke of about 1 s, 1 always three strokes of about 3 s.
LABELS = np.array([0] * 20 + [1] * 20)
STROKES = np.array([1] * 20 + [3] * 20)
CONTACT_S = np.r_[np.linspace(0.9, 1.1, 20), np.linspace(2.7, 3.3, 20)]


def habits(strokes=STROKES, contact_s=CONTACT_S, labels=LABELS, n_classes=2):
    return ClassHabits(labels, n_classes, strokes, contact_s)


def test_a_stroke_count_the_class_never_shows_is_implausible():
    h = habits()
    assert h.strokes_feature(0, 1) < 0.1 < h.strokes_feature(0, 3)
    assert h.strokes_feature(1, 3) < 0.1 < h.strokes_feature(1, 1)
    assert h.strokes_feature(0, 2) == h.strokes_feature(0, 3) == pytest.approx(-math.log(0.5 / 21))
    # Not recorded or not known: no evidence.
    assert habits(strokes=None).strokes_feature(0, 5) == 0.0
    assert h.strokes_feature(0, float('nan')) == 0.0
    assert np.isfinite(h.strokes_feature(0, 0))   # no stroke at all: as rare as any unseen count


def test_a_duration_far_from_the_class_in_its_own_spread_is_implausible():
    h = habits()
    assert h.duration_feature(0, 1.0) < 0.5 < 3.0 < h.duration_feature(0, 3.0)
    assert h.duration_feature(1, 3.0) < 0.5 < 3.0 < h.duration_feature(1, 1.0)
    # Log units: twice and half as long are as far.
    assert h.duration_feature(0, 2.0) == pytest.approx(h.duration_feature(0, 0.5), rel=0.05)
    assert habits(contact_s=None).duration_feature(0, 9.0) == 0.0
    assert h.duration_feature(0, float('nan')) == 0.0
    # A touch of no time in contact (one frame) is far but finite; the feature is clipped.
    assert 3.0 < h.duration_feature(0, 0.0) < math.inf
    assert context_features(h, 0, 1, 0.0)[2] <= FEATURE_BOUND


def test_one_template_per_class_and_equal_durations_still_give_finite_features():
    one = ClassHabits(np.array([0, 1]), 2, np.array([1, 2]), np.array([1.0, 2.0]))
    assert one.log_contact_spread.tolist() == [DURATION_SPREAD_FLOOR] * 2   # no class has a spread of its own
    assert np.isfinite(one.duration_feature(0, 1.5)) and one.duration_feature(0, 1.0) == 0.0
    assert one.strokes_feature(0, 1) < one.strokes_feature(0, 2)
    same = ClassHabits(np.zeros(5, dtype=int), 1, None, np.ones(5))
    assert same.log_contact_spread[0] == DURATION_SPREAD_FLOOR
    # A class without one timed template (NaN, 0 s) says nothing of durations.
    untimed = ClassHabits(np.array([0, 0, 1]), 2, None, np.array([np.nan, 0.0, 1.0]))
    assert untimed.duration_feature(0, 7.0) == 0.0 and untimed.duration_feature(1, 7.0) > 0


def test_disagreement_is_how_much_nearer_the_second_opinion_finds_another_class():
    assert disagreement(None, 0) == 0.0
    assert disagreement(np.array([1.0, 2.0]), 0) == 0.0
    assert disagreement(np.array([1.0, 2.0]), 1) == pytest.approx(math.log(2.0))
    assert disagreement(np.array([1.0, np.nan]), 0) == FEATURE_BOUND
    assert disagreement(np.array([0.0, 2.0]), 1) == FEATURE_BOUND    # an exact match elsewhere
    assert disagreement(np.array([1.0, np.inf]), 1) == FEATURE_BOUND  # a class the second opinion lacks
    assert disagreement(np.array([0.0, 0.0]), 1) == 0.0


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.05, 10.0), min_size=3, max_size=6), st.floats(0.0, 20.0), st.floats(0.0, 20.0),
       st.integers(0, 2), st.floats(0.01, 3.0))
def test_with_positive_weights_the_score_grows_with_each_context_feature(d, low, high, column, weight):
    d = np.asarray(d)
    best = int(np.argmin(d))
    low, high = sorted((low, high))
    weights = (0.5, 1.0, 1.0, 0.0, 0.0, *(weight if k == column else 0.0 for k in range(len(CONTEXT_FEATURES))))
    context = [0.0] * len(CONTEXT_FEATURES)
    at = [doubt(d, best, np.ones(len(d)), weights, [*context[:column], v, *context[column + 1:]])
          for v in (low, high)]
    assert at[0] <= at[1]


def test_rarer_strokes_and_odder_durations_raise_a_fitted_score():
    # Hand-made opinions: right readings and touches that are no gesture equally far from their class, but the
    # touches show a stroke count and a duration the class does not.
    rng = np.random.default_rng(3)
    n = 200
    h = habits()
    true = rng.integers(0, 2, n)
    d = rng.uniform(2.0, 3.0, (n, 2))
    d[np.arange(n), true] = rng.uniform(0.8, 1.5, n)
    context = np.array([context_features(h, c, STROKES[20 * c], CONTACT_S[20 * c] * rng.uniform(0.9, 1.1))
                        for c in true])
    held = HeldOut(d, true, true, np.array(['a', 'b'] * (n // 2)), context)
    odd = np.array([context_features(h, c, 2, rng.uniform(5.0, 9.0)) for c in true])
    randoms = HeldOut(d.copy(), true, np.full(n, -1), np.full(n, ''), odd)
    scales = np.ones(2)
    plain = fit_weights(held, randoms, scales)
    full = fit_weights(held, randoms, scales, context=CONTEXT_FEATURES)
    assert plain.shape == (len(PRODUCT_WEIGHTS),) and full.shape == (len(PRODUCT_WEIGHTS) + len(CONTEXT_FEATURES),)
    column = {n: len(PRODUCT_WEIGHTS) + k for k, n in enumerate(CONTEXT_FEATURES)}
    assert full[column['strokes']] > 0 and full[column['duration']] > 0   # strokes and duration weigh for doubt
    right, odd_scores = scores(held, scales, full), scores(randoms, scales, full)
    assert np.mean(right[:, None] < odd_scores[None, :]) > 0.99
    only = fit_weights(held, randoms, scales, context=('duration',))
    assert [only[column[n]] > 0 for n in CONTEXT_FEATURES] == [n == 'duration' for n in CONTEXT_FEATURES]
    with pytest.raises(ValueError, match='unknown context'):
        fit_weights(held, randoms, scales, context=('pressure',))


def test_an_old_record_decides_exactly_as_before(tmp_path):
    model, rng = people_codebook()
    calibrate_acceptance(model, 0.005, scribbles(rng, 120), context=())
    record = model.acceptance_
    assert len(record['score_weights']) == len(PRODUCT_WEIGHTS) and record['score_features'] == list(DOUBT_FEATURES)
    loaded = load_codebook(save_codebook(tmp_path / 'old.npz', model))
    touches = scribbles(rng, 30) + drawn(rng, people=1, per_person=2, backwards=())[0]   # a new person's letters
    scales = np.asarray(record['class_scales'])
    for g in touches:
        match = loaded.predict(g)
        if match.rejected in (None, 'score'):
            per_class = loaded.class_distances(g)
            best = int(np.argmin(per_class))
            score = doubt(per_class, best, scales, record['score_weights'])   # no context: the old score
            assert (match.rejected is None) == (score <= (record['max_score'] or math.inf))
    # Zero weights on the context decide as no context at all.
    padded = dict(record, score_weights=record['score_weights'] + [0.0] * len(CONTEXT_FEATURES))
    loaded.set_acceptance(padded)
    again = load_codebook(tmp_path / 'old.npz')
    assert [m.rejected for m in loaded.predict_many(touches)] == [m.rejected for m in again.predict_many(touches)]


@pytest.mark.parametrize('name', ['trace', 'fused'])
def test_a_calibration_with_context_keeps_it_and_the_robot_decides_by_it(tmp_path, name):
    model, rng = people_codebook(name=name)
    calibrate_acceptance(model, 0.005, scribbles(rng, 120), context=CONTEXT_FEATURES)
    record = model.acceptance_
    assert record['score_features'] == list(DOUBT_FEATURES) + list(CONTEXT_FEATURES)
    assert len(record['score_weights']) == len(PRODUCT_WEIGHTS) + len(CONTEXT_FEATURES)
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', model))
    assert loaded.acceptance_['score_weights'] == record['score_weights']
    touches = scribbles(rng, 30)
    assert [m.rejected for m in loaded.predict_many(touches)] == [m.rejected for m in model.predict_many(touches)]
    h = ClassHabits(model.template_labels_, len(model.classes_), model.template_strokes_, model.template_contact_s_,
                    model.template_sizes_mm_)
    for g in touches:
        match = model.predict(g)
        if match.rejected in (None, 'score'):
            cloud, second = model.opinions(g)
            best = int(np.searchsorted(model.classes_, match.nearest))
            score = doubt(cloud, best, np.asarray(record['class_scales']), record['score_weights'],
                          context_features(h, best, g.strokes, g.contact_s, second, touch_size_mm(g.trajectory)))
            assert (match.rejected is None) == (score <= (record['max_score'] or math.inf))
    # Distances alone (no gesture to read the context off): no evidence, the context features are 0.
    per_class = model.class_distances(touches[0])
    assert model.decide(per_class).distance == pytest.approx(per_class.min())


def test_the_fused_recogniser_gives_both_opinions():
    model, rng = people_codebook(name='fused')
    g = scribbles(rng, 1)[0]
    cloud, trace = model.opinions(g)
    assert cloud.tolist() == model.class_distances(g).tolist()
    assert trace.tolist() == model.trace_.class_distances(g).tolist()
    assert model.opinions(g, cloud)[0] is cloud
    plain, _ = people_codebook(name='trace')
    assert plain.opinions(g)[1] is None


def test_the_transfer_check_adds_context_features_fold_by_fold():
    from touch_lab.skin.acceptance_transfer import Fold, measure
    rng = np.random.default_rng(5)
    h = habits()

    def opinions(n, gesture, people=('a', 'b')):
        # Touches that are no gesture lie as near a class as gestures do; only their stroke counts tell.
        true = rng.integers(0, 2, n)
        d = rng.uniform(2.0, 3.0, (n, 2))
        d[np.arange(n), true] = rng.uniform(0.8, 1.5, n)
        context = np.array([context_features(h, c, STROKES[20 * c] if gesture else 2, CONTACT_S[20 * c])
                            for c in true])
        return HeldOut(d, true, true if gesture else np.full(n, -1), np.resize(np.array(people), n), context)

    fold = Fold(held=opinions(200, True), stray=opinions(100, False), stray_made=100, test=opinions(60, True),
                open=np.ones(60, dtype=bool), samples=60, randoms=opinions(50, False),
                random_open=np.ones(50, dtype=bool), random_made=50)
    plain, strokes = measure([fold], 0.005, 'own'), measure([fold], 0.005, 'own', ('strokes',))
    assert strokes['right'] > plain['right'] and strokes['random_fired'] <= plain['random_fired']
    assert strokes['right'] > 0.9


def test_the_report_names_a_score_with_context():
    from touch_lab.skin.rejection_report import _score
    held = [{'score': 'odds', 'score_weights': [0.0] * (len(PRODUCT_WEIGHTS) + len(CONTEXT_FEATURES))}]
    assert _score(held) == 'logistic score with context, stray touches'
    assert _score([{'score': 'odds', 'score_weights': [0.0] * len(PRODUCT_WEIGHTS)}]) == 'logistic score, stray touches'
    assert _score([{}]).startswith('product score')


def test_the_default_calibration_adds_the_second_opinion_only_where_there_is_one():
    from touch_lab.skin.acceptance import SCORE_CONTEXT
    assert set(SCORE_CONTEXT) <= set(CONTEXT_FEATURES)
    trace, rng = people_codebook(name='trace')
    calibrate_acceptance(trace, 0.005, scribbles(rng, 80))
    weights = trace.acceptance_['score_weights']
    # One opinion: the disagreement weighs nothing, whatever else the calibration keeps.
    assert trace.acceptance_['score_features'][:len(weights)] == (list(DOUBT_FEATURES) + list(CONTEXT_FEATURES))[
        :len(weights)]
    if len(weights) > len(PRODUCT_WEIGHTS):
        assert weights[len(PRODUCT_WEIGHTS) + CONTEXT_FEATURES.index('disagreement')] == 0.0
    fused, rng = people_codebook(name='fused')
    calibrate_acceptance(fused, 0.005, scribbles(rng, 80))
    weights = fused.acceptance_['score_weights']
    # Context features weighing nothing after the last that weighs are left off the record.
    assert len(PRODUCT_WEIGHTS) <= len(weights) <= len(PRODUCT_WEIGHTS) + len(CONTEXT_FEATURES)
    assert len(weights) == len(PRODUCT_WEIGHTS) or weights[-1] != 0.0
    for name, w in zip(CONTEXT_FEATURES, weights[len(PRODUCT_WEIGHTS):], strict=False):
        assert name in SCORE_CONTEXT or w == 0.0
