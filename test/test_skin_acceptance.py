"""Rejection tuned in one number, the wrong-command rate, calibrated from the codebook (issue 26, item 2).

The gestures are synthetic (test/test_skin_codebook_people.py's letters: polylines with tremor, people
drawing each letter their own way), and so are the touches that are no gesture (random corners).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from test_skin_codebook_people import LETTERS, drawn, stroke

from touch_gestures.skin import load_codebook, make_recogniser, save_codebook
from touch_gestures.skin.base import acceptance_score
from touch_gestures.skin.doubt import (
    CONTEXT_FEATURES,
    DOUBT_FEATURES,
    PRODUCT_WEIGHTS,
    context_features,
    doubt,
    doubt_features,
    touch_size_mm,
)
from touch_lab.skin.acceptance import (
    MAX_RANDOM_FIRING,
    HeldOut,
    calibrate_acceptance,
    class_scales,
    cross_person_outcomes,
    fit_weights,
    held_out_opinions,
    max_score,
    scores,
    touch_opinions,
)
from touch_lab.skin.recognisers.auto import AutoRecogniser


def scribbles(rng: np.random.Generator, count: int):
    """Touches that are no letter: 3-6 random corners over the skin (synthetic)."""
    return [stroke(rng.uniform(6, 41, (int(rng.integers(3, 7)), 2)), rng) for _ in range(count)]


def people_codebook(seed=3, people=4, name='trace'):
    rng = np.random.default_rng(seed)
    gestures, labels, who = drawn(rng, people=people, per_person=5, backwards=())
    return make_recogniser(name).fit(gestures, labels, who), rng


def test_the_score_is_distance_over_scale_times_the_ratio_to_the_runner_up():
    assert acceptance_score(1.0, 1.0, 2.0) == pytest.approx(0.25)
    assert acceptance_score(0.0, 0.0, 1.0) == 0.0
    assert acceptance_score(2.0, 0.0, 1.0) == pytest.approx(2.0)     # a tie: ratio 1
    assert acceptance_score(float('nan'), 1.0, 1.0) == math.inf


def test_held_out_opinions_read_each_person_by_the_others():
    model, _ = people_codebook()
    held = held_out_opinions(model)
    assert len(held.true) == len(model.templates_)
    assert sorted(set(held.people.tolist())) == ['p0', 'p1', 'p2', 'p3']
    # Letters drawn the same way by everyone: every held-out template named right.
    assert np.mean(held.named == held.true) == 1.0
    # A person's own repetitions are not in the codebook that reads them: each distance is one to another person.
    assert np.all(held.distances[np.arange(len(held.true)), held.true] > 0)


def test_a_codebook_without_two_people_cannot_be_calibrated():
    rng = np.random.default_rng(0)
    gestures, labels, _ = drawn(rng, people=2, per_person=3, backwards=())
    with pytest.raises(ValueError, match='two people'):
        calibrate_acceptance(make_recogniser('trace').fit(gestures, labels), 0.005)
    with pytest.raises(ValueError, match='share'):
        calibrate_acceptance(make_recogniser('trace').fit(gestures, labels, ['a'] * len(labels)), 1.5)


def test_the_limit_lets_through_no_more_wrong_commands_than_asked():
    # Hand-made opinions: 3 classes, 10 held-out touches, 3 of them named wrong with known scores.
    d = np.array([[1.0, 4.0, 8.0]] * 7 + [[1.0, 1.2, 4.0], [1.0, 1.1, 4.0], [1.0, 3.0, 4.0]])
    true = np.array([0] * 7 + [1, 1, 1])
    held = HeldOut(d, np.zeros(10, dtype=np.intp), true, np.array(['a', 'b'] * 5))
    scales = np.ones(3)
    s = scores(held, scales)
    none = HeldOut(np.empty((0, 3)), np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp), np.empty(0, dtype=str))
    assert max_score(held, none, scales, 0.0) < s[9] and max_score(held, none, scales, 0.0) >= s[0]
    assert s[9] <= max_score(held, none, scales, 0.1) < s[7]   # 1 of 10 may be wrong: the least doubtful one
    assert max_score(held, none, scales, 0.3) == math.inf      # all three may


def test_random_touches_are_held_at_their_share():
    model, rng = people_codebook()
    randoms = scribbles(rng, 200)
    calibrate_acceptance(model, 0.5, randoms)   # the wrong commands set no limit here: the random touches do
    record = model.acceptance_
    assert record['random_touches'] == len(randoms) and len(touch_opinions(model, randoms).named) > 100
    assert record['random_fired'] <= MAX_RANDOM_FIRING
    fired = np.mean([model.predict(g).label is not None for g in randoms])
    assert fired <= MAX_RANDOM_FIRING
    # Without the random touches the limit is looser and more of them fire.
    loose, _ = people_codebook()
    calibrate_acceptance(loose, 0.5)
    assert np.mean([loose.predict(g).label is not None for g in randoms]) > fired


@pytest.mark.parametrize('name', ['trace', 'fused'])
def test_new_people_of_the_same_letters_are_read_and_the_record_survives_the_file(tmp_path, name):
    model, rng = people_codebook(name=name)
    calibrate_acceptance(model, 0.005, scribbles(rng, 120))
    new, labels, _ = drawn(np.random.default_rng(99), people=2, per_person=4, backwards=())
    right = np.mean([m.label == y for m, y in zip(model.predict_many(new), labels, strict=True)])
    assert right >= 0.9, model.acceptance_
    assert {'max_wrong_rate', 'max_score', 'class_scales', 'right', 'wrong'} <= set(model.acceptance_)
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', model))
    assert loaded.acceptance_ == model.acceptance_
    assert [m.label for m in loaded.predict_many(new)] == [m.label for m in model.predict_many(new)]


def test_a_calibrated_codebook_rejects_by_score_and_an_old_one_by_distance():
    model, rng = people_codebook()
    far = scribbles(rng, 60)
    before = {model.predict(g).rejected for g in far}
    calibrate_acceptance(model, 0.005, scribbles(rng, 120))
    after = {model.predict(g).rejected for g in far}
    assert 'score' not in before and 'score' in after and 'distance' not in after


def test_bad_acceptance_records_are_refused():
    model, _ = people_codebook()
    n = len(model.classes_)
    for record in ({'class_scales': [1.0] * (n - 1), 'max_score': 1.0}, {'class_scales': [0.0] * n, 'max_score': 1.0},
                   {'class_scales': [1.0] * n, 'max_score': -1.0}, {'class_scales': [1.0] * n, 'max_score': True}):
        with pytest.raises(ValueError, match='acceptance'):
            model.set_acceptance(record)
    model.set_acceptance({'class_scales': [1.0] * n, 'max_score': None})   # no limit but the margin's sign
    assert model.acceptance_['max_score'] is None


def test_cross_person_estimate_counts_every_held_out_template():
    model, _ = people_codebook()
    held = held_out_opinions(model)
    none = touch_opinions(model, [])
    outcome = cross_person_outcomes(held, none, 0.005)
    assert outcome.shape == held.true.shape and set(outcome.tolist()) <= {-1, 0, 1}
    assert class_scales(held, len(model.classes_)).shape == (len(LETTERS),)


def test_auto_calibrates_the_recogniser_it_chose():
    rng = np.random.default_rng(5)
    gestures, labels, who = drawn(rng, people=3, per_person=4, backwards=())
    auto = AutoRecogniser().fit(gestures, labels, who)
    calibrate_acceptance(auto, 0.005)
    assert auto.acceptance_ is auto.chosen_.acceptance_
    assert all(m.label == y for m, y in zip(auto.predict_many(gestures[:10]), labels[:10], strict=True))


def test_codebook_calibrate_writes_a_calibrated_copy_and_refuses_bad_rates(tmp_path, monkeypatch, capsys):
    from touch_lab.cli.main import main
    from touch_lab.skin import acceptance
    model, rng = people_codebook()
    source = save_codebook(tmp_path / 'book.npz', model)
    randoms = scribbles(rng, 120)
    monkeypatch.setattr(acceptance, 'null_touches', lambda gap_s: randoms)   # no virtual skin in a unit test
    out = tmp_path / 'calibrated.npz'
    assert main(['codebook', 'calibrate', str(source), '--max-wrong-rate', '0.005', '-o', str(out)]) == 0
    calibrated = load_codebook(out)
    assert calibrated.acceptance_['max_wrong_rate'] == 0.005 and load_codebook(source).acceptance_ is None
    assert main(['codebook', 'info', str(out)]) == 0
    assert 'acceptance calibrated for 0.005' in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(['codebook', 'calibrate', str(source), '--max-wrong-rate', '0.7', '-o', str(out)])
    unnamed = save_codebook(tmp_path / 'unnamed.npz', make_recogniser('trace').fit(*drawn(rng, people=2)[:2]))
    assert main(['codebook', 'calibrate', str(unnamed), '--max-wrong-rate', '0.01', '-o', str(out)]) == 2
    assert 'two people' in capsys.readouterr().err


def test_the_report_names_the_command_of_every_row(tmp_path):
    from touch_lab.skin.rejection_report import format_report
    result = {'accuracy': 0.99, 'accuracy_with_rejection': 0.97, 'rejection_rate': 0.028, 'error_rate': 0.002,
              'random_touch_acceptance': 0.01,
              'acceptance': [{'wrong': 0.004, 'right': 0.96}, {'wrong': 0.006, 'right': 0.98}]}
    runs = [{'traces': 'a.csv.gz', 'vocabulary': 'a', 'samples': 10, 'subjects': ['1', '2'], 'max_wrong_rate': 0.005,
             'recognisers': {'trace': result}},
            {'traces': 'a.csv.gz', 'vocabulary': 'a', 'samples': 10, 'subjects': ['1', '2'], 'max_wrong_rate': None,
             'recognisers': {'trace': {**result, 'acceptance': None}}}]
    text = format_report(runs)
    assert '`social-touch eval skin --traces a.csv.gz --recognisers trace --json --max-wrong-rate 0.005`' in text
    assert '`social-touch eval skin --traces a.csv.gz --recognisers trace --json`' in text
    assert ('| a (10 samples, 2 people) | trace | calibrated, 0.5 %, product score, random touches (same generator) '
            '| 99.00 % | **97.00 %** |') in text
    logistic = {**runs[0], 'recognisers': {'trace': {**result, 'acceptance': [
        {'wrong': 0.004, 'right': 0.96, 'score': 'odds of no right command (logistic)'}]}}}
    assert 'calibrated, 0.5 %, logistic score, stray touches |' in format_report([logistic])
    assert '0.50 % / 97.00 %' in text   # the held-out estimate, mean over folds
    # 97 % right misses the single-stroke goal; the rest is met.
    assert sum(line.endswith('| right |') for line in text.splitlines()) == 2


def test_an_edited_codebook_drops_its_calibration():
    from touch_lab.skin.codebook_tools import remove_gestures
    model, rng = people_codebook()
    calibrate_acceptance(model, 0.005, scribbles(rng, 60))
    edited = remove_gestures(model, ['Z'])
    assert model.acceptance_ is not None and edited.acceptance_ is None
    # The old rule decides again: no 'score' rejection.
    assert all(m.rejected != 'score' for m in edited.predict_many(scribbles(rng, 30)))


def test_the_product_weights_give_the_old_score():
    rng = np.random.default_rng(1)
    scales = rng.uniform(0.5, 2.0, 5)
    for _ in range(20):
        d = rng.uniform(0.1, 3.0, 5)
        best = int(np.argmin(d))
        margin = float(np.sort(d)[1] - d[best])
        assert doubt(d, best, scales, PRODUCT_WEIGHTS) == pytest.approx(acceptance_score(d[best], margin, scales[best]))
    assert doubt(np.array([1.0, 0.5]), 0, np.ones(2), PRODUCT_WEIGHTS) == math.inf   # the runner-up is nearer
    assert doubt(np.array([0.0, 0.5]), 0, np.ones(2), (3.0, 1.0, 1.0, 1.0, 1.0)) == 0.0   # an exact match
    features, usable = doubt_features(np.array([[1.0, 2.0, 4.0]]), np.array([0]), np.array([0.5, 1.0, 1.0]))
    assert features.shape == (1, len(DOUBT_FEATURES)) and usable.all()
    assert features[0] == pytest.approx(np.log([2.0, 0.5, 2.0, 1 / 3]))
    # The robot's plain-Python score is the lab's vectorised one, edge cases included (no runner-up, inf, NaN, 0).
    from touch_gestures.skin.doubt import scores_of
    weights = rng.normal(0, 2, 5)
    for d in ([1.5], [0.3, np.inf, 0.2], [np.inf, 2.0, 1.0], [0.0, 1.0, 2.0], [1.0, np.nan, 2.0], [1.0, 1.0, 3.0]):
        d = np.asarray(d, dtype=np.float64)
        best = int(np.nanargmin(d))
        f, usable = doubt_features(d[None, :], np.array([best]), np.ones(len(d)))
        assert doubt(d, best, np.ones(len(d)), weights) == pytest.approx(scores_of(f, usable, weights)[0], rel=1e-9)


def test_the_fitted_score_ranks_right_readings_below_touches_that_are_no_gesture():
    # Hand-made opinions, 3 classes: right readings near their class and far from the others; random touches
    # about as far from every class (what a distance alone does not tell).
    rng = np.random.default_rng(2)
    n = 200
    true = rng.integers(0, 3, n)
    d = rng.uniform(2.0, 4.0, (n, 3))
    d[np.arange(n), true] = rng.uniform(0.5, 1.5, n)
    held = HeldOut(d, true, true, np.array(['a', 'b'] * (n // 2)))
    r = rng.uniform(1.0, 2.0, (n, 3))
    randoms = HeldOut(r, np.argmin(r, axis=1), np.full(n, -1), np.full(n, ''))
    scales = np.ones(3)
    weights = fit_weights(held, randoms, scales)
    assert weights.shape == (len(PRODUCT_WEIGHTS),) and np.all(np.isfinite(weights))
    right, random = scores(held, scales, weights), scores(randoms, scales, weights)
    assert np.mean(right[:, None] < random[None, :]) > 0.95
    # No touch that is no gesture: nothing to fit against, the product score.
    none = HeldOut(np.empty((0, 3)), np.empty(0, dtype=np.intp), np.empty(0, dtype=np.intp), np.empty(0, dtype=str))
    assert fit_weights(HeldOut(d, true, true, held.people), none, scales).tolist() == list(PRODUCT_WEIGHTS)


def test_a_calibration_keeps_its_weights_and_the_robot_decides_by_them(tmp_path):
    model, rng = people_codebook()
    calibrate_acceptance(model, 0.005, scribbles(rng, 120))
    record = model.acceptance_
    assert record['score_features'] == list(DOUBT_FEATURES) + list(CONTEXT_FEATURES)[:len(record['score_weights']) - 5]
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', model))
    assert loaded.acceptance_['score_weights'] == record['score_weights']
    touches = scribbles(rng, 40)
    assert [m.rejected for m in loaded.predict_many(touches)] == [m.rejected for m in model.predict_many(touches)]
    # The decision is the record's score against its limit (one opinion: no second one to disagree).
    habits = model._acceptance_habits
    for g in touches:
        per_class = model.class_distances(g)
        best = int(np.argmin(per_class))
        context = () if habits is None else context_features(habits, best, g.strokes, g.contact_s, None,
                                                             touch_size_mm(g.trajectory))
        score = doubt(per_class, best, np.asarray(record['class_scales']), record['score_weights'], context)
        match = model.predict(g)
        if match.rejected in (None, 'score'):
            assert (match.rejected is None) == (score <= (record['max_score'] or math.inf))
    n = len(model.classes_)
    with pytest.raises(ValueError, match='score_weights'):
        model.set_acceptance({'class_scales': [1.0] * n, 'max_score': 1.0, 'score_weights': [1.0, float('nan')]})
    product, _ = people_codebook()
    calibrate_acceptance(product, 0.005, scribbles(rng, 120), model=False)
    assert 'score_weights' not in product.acceptance_


def test_stray_touches_are_another_kind_of_touch_that_is_no_gesture():
    from touch_gestures.skin.gesture import ACTIVE_MM
    from touch_sim.skin.stray import STRAY_KINDS, stray_touches
    touches = stray_touches(50, seed=3)
    assert len(touches) == 50 and {t.gesture for t in touches} == {f'stray_{k}' for k in STRAY_KINDS}
    for t in touches:
        assert np.all((t.x >= 4.0 - 1e-6) & (t.x <= ACTIVE_MM - 4.0 + 1e-6))
        assert np.all((t.y >= 4.0 - 1e-6) & (t.y <= ACTIVE_MM - 4.0 + 1e-6))
        assert np.all(np.diff(t.stroke) >= 0) and np.all(np.diff(t.t_ms) >= 0)
    taps = [t for t in touches if t.gesture == 'stray_taps']
    assert all(2 <= t.n_strokes <= 4 for t in taps)
    assert all(t.n_strokes == 1 for t in touches if t.gesture != 'stray_taps')
    again = stray_touches(50, seed=3)
    assert all(np.array_equal(a.x, b.x) for a, b in zip(touches, again, strict=True))
    with pytest.raises(ValueError, match='count'):
        stray_touches(-1)


def test_the_transfer_check_measures_each_score_on_the_same_folds():
    from touch_lab.skin.acceptance_transfer import Fold, measure
    rng = np.random.default_rng(4)

    def opinions(n, near, people=('a', 'b')):
        true = rng.integers(0, 3, n)
        d = rng.uniform(2.0, 4.0, (n, 3))
        if near:
            d[np.arange(n), true] = rng.uniform(0.5, 1.5, n)
        named = np.argmin(d, axis=1)
        return HeldOut(d, named, true if near else np.full(n, -1), np.resize(np.array(people), n))

    fold = Fold(held=opinions(120, True), stray=opinions(60, False), stray_made=60, test=opinions(40, True),
                open=np.ones(40, dtype=bool), samples=40, randoms=opinions(30, False),
                random_open=np.ones(30, dtype=bool), random_made=30)
    results = {name: measure([fold], 0.005, w) for name, w in
               (('own', 'own'), ('product', 'product'), ('fixed', np.asarray(PRODUCT_WEIGHTS)))}
    assert results['fixed'] == results['product']
    for r in results.values():
        assert r['right'] + r['wrong'] + r['rejected'] == pytest.approx(1.0)
        assert 0 <= r['random_fired'] <= 1
    assert results['own']['right'] > 0.9   # right readings lie far nearer their class than any random touch
    closed = Fold(**{**vars(fold), 'open': np.zeros(40, dtype=bool)})   # every sample rejected by another rule
    assert measure([closed], 0.005, 'own')['rejected'] == 1.0


def test_the_report_shows_the_cross_vocabulary_runs_with_their_command():
    from touch_lab.skin.rejection_report import format_report
    transfer = {'fit': '/d/unistroke_dev.csv.gz', 'fit_recogniser': 'trace', 'fit_templates_per_gesture': 'all',
                'measure': '/d/multistroke_dev.csv.gz', 'measure_recogniser': 'fused', 'templates_per_gesture': 30,
                'max_wrong_rate': 0.005, 'transferred_weights': [0.0] * 5,
                'scores': {'own': {'right': 0.95, 'wrong': 0.004, 'rejected': 0.046, 'random_fired': 0.02}}}
    text = format_report([transfer])
    assert ('| multistroke_dev (fused) | unistroke_dev (trace) | 0.5 % | own | **95.00 %** | 4.60 % | **0.40 %** |'
            in text)
    assert ('`social-touch eval skin-transfer --fit /d/unistroke_dev.csv.gz --fit-recogniser trace '
            '--measure /d/multistroke_dev.csv.gz --measure-recogniser fused --templates-per-gesture 30 '
            '--max-wrong-rate 0.005 --json`') in text


def test_the_acceptance_bench_times_the_three_rules():
    from touch_lab.skin.bench import bench_acceptance
    result = bench_acceptance('trace', n_gestures=3, templates_per_gesture=3, queries=3, repeats=1)
    assert set(result['us_per_recognition']) == {'thresholds', 'product', 'logistic', 'context'}
    assert all(us > 0 for us in result['us_per_recognition'].values())
