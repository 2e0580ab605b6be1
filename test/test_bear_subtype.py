"""Touch subtypes: the paper's V.D rule, the trainable model (scikit-learn API, .npz files), change events."""

from __future__ import annotations

import numpy as np
import pytest
from sklearn.base import clone

from touch_gestures.bear.features import FEATURE_NAMES
from touch_gestures.bear.subtype import PaperRuleClassifier, SubtypeTracker
from touch_gestures.bear.subtype_labels import SUBTYPES, TOUCH_SUBTYPES, subtype_index
from touch_gestures.bear.subtype_model import DEFAULT_FEATURES, MODEL_FORMAT, RELATIVE_FEATURES
from touch_gestures.estimator import NotFittedError
from touch_lab.bear.subtype_training import SubtypeClassifier

F = len(FEATURE_NAMES)


def rows(peak, base_hz, spread_hz, duration_s) -> np.ndarray:
    X = np.zeros((len(peak), F), dtype=np.float32)
    X[:, 0], X[:, 1], X[:, 2], X[:, 3] = peak, base_hz, spread_hz, duration_s
    return X


def test_rule_follows_the_pseudocode_with_table_ii_defaults() -> None:
    X = rows(peak=[0.29, 0.9, 0.9, 0.9, 0.9, 0.9], base_hz=[9, 9, 7.5, 1.25, 0.1, 0.0],
             spread_hz=[0, 0, 1.0, 0.2, 0.0, 0.0], duration_s=[10, 2.9, 5, 5, 5, 5])
    assert list(PaperRuleClassifier().predict(X)) == ['none', 'poke', 'tickle', 'pet', 'hold', 'hold']


def test_every_rule_constant_is_a_parameter() -> None:
    X = rows(peak=[0.25], base_hz=[1.25], spread_hz=[0.0], duration_s=[5])
    assert PaperRuleClassifier().predict(X)[0] == 'none'
    assert PaperRuleClassifier(amplitude_threshold=0.2).predict(X)[0] == 'pet'
    assert PaperRuleClassifier(amplitude_threshold=0.2, poke_max_s=6).predict(X)[0] == 'poke'
    assert PaperRuleClassifier(amplitude_threshold=0.2, pet_cutoff=2.0).predict(X)[0] == 'hold'
    assert PaperRuleClassifier(amplitude_threshold=0.2, alpha=4.0).predict(X)[0] == 'tickle'
    X2 = rows(peak=[0.9], base_hz=[0.0], spread_hz=[4.0], duration_s=[5])
    assert PaperRuleClassifier(beta=0.0).predict(X2)[0] == 'hold'
    assert PaperRuleClassifier(beta=1.0).predict(X2)[0] == 'tickle'


def test_rule_handles_nan_rows_and_rejects_wrong_shapes() -> None:
    X = rows(peak=[np.nan], base_hz=[np.nan], spread_hz=[0], duration_s=[np.inf])
    assert PaperRuleClassifier().predict(X)[0] == 'none'
    with pytest.raises(ValueError, match='columns'):
        PaperRuleClassifier().predict(np.zeros((3, 4)))


def test_rule_cutoff_tuning_separates_what_it_can() -> None:
    rng = np.random.default_rng(0)
    n = 60
    X = rows(peak=np.full(3 * n, 0.9), base_hz=np.r_[rng.uniform(0.9, 1.4, n), rng.uniform(0.3, 0.6, n), np.zeros(n)],
             spread_hz=np.zeros(3 * n), duration_s=np.full(3 * n, 6.0))
    y = ['tickle'] * n + ['pet'] * n + ['hold'] * n       # as at 3.4 Hz: an aliased tickle sits low
    default = PaperRuleClassifier()
    assert np.mean(default.predict(X) == np.array(y)) < 0.7
    tuned = PaperRuleClassifier(tune_cutoffs=True).fit(X, y)
    assert tuned.tickle_cutoff_ < 1.0 and np.mean(tuned.predict(X) == np.array(y)) > 0.95
    assert default.fit(X, y) is default and not hasattr(default, 'tickle_cutoff_')


def synthetic_rows(seed: int = 0, n: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """Well-separated fake feature rows, one cluster per subtype (a learning sanity check, not data)."""
    rng = np.random.default_rng(seed)
    X, y = [], []
    for k, name in enumerate(SUBTYPES):
        centre = np.zeros(F)
        centre[k % F] = 3.0
        centre[(k + 3) % F] += 2.0
        X.append(centre + rng.normal(0, 0.3, (n, F)))
        y += [name] * n
    return np.concatenate(X).astype(np.float32), np.array(y)


def test_model_follows_the_estimator_api() -> None:
    X, y = synthetic_rows()
    model = SubtypeClassifier(C=2.0)
    assert model.get_params()['C'] == 2.0 and not hasattr(model, 'coef_')
    with pytest.raises(NotFittedError):
        model.predict(X)
    assert model.fit(X, y) is model
    assert list(model.classes_) == list(SUBTYPES)
    assert np.mean(model.predict(X) == y) > 0.95
    assert model.score(X, y) > 0.95
    np.testing.assert_allclose(model.predict_proba(X).sum(axis=1), 1.0, rtol=1e-6)
    codes, confidence = model.predict_codes(X)
    assert np.array_equal(np.asarray(SUBTYPES)[codes], model.predict(X))
    assert np.all((confidence > 0) & (confidence <= 1))
    assert clone(model).get_params() == model.get_params()


def test_model_log_probabilities_survive_extreme_inputs() -> None:
    X, y = synthetic_rows()
    model = SubtypeClassifier().fit(X, y)
    extreme = np.full((2, F), 1e6, dtype=np.float32)
    extreme[1] = np.nan
    logp = model.predict_log_proba(extreme)
    assert np.isfinite(logp).all() and np.allclose(np.exp(logp).sum(axis=1), 1.0)


def test_model_accepts_codes_and_two_classes() -> None:
    X, y = synthetic_rows()
    keep = np.isin(y, ['none', 'hold'])
    codes = np.array([subtype_index(v) for v in y[keep]])
    model = SubtypeClassifier().fit(X[keep], codes)
    assert list(model.classes_) == ['none', 'hold'] and np.mean(model.predict(X[keep]) == y[keep]) > 0.95
    with pytest.raises(ValueError, match='two subtypes'):
        SubtypeClassifier().fit(X[:5], ['none'] * 5)
    with pytest.raises(ValueError, match='unknown touch subtype'):
        SubtypeClassifier().fit(X[:2], ['none', 'hug'])


def test_model_file_round_trip_without_pickle(tmp_path) -> None:
    X, y = synthetic_rows()
    model = SubtypeClassifier().fit(X, y)
    path = tmp_path / 'bear_subtype.npz'
    model.save(path, rate_hz=3.4, buffer_len=20)
    loaded = SubtypeClassifier.load(path)
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    assert (loaded.trained_rate_hz_, loaded.trained_buffer_len_) == (3.4, 20)
    with np.load(path, allow_pickle=False) as data:      # every array loads without pickle
        assert int(data['format']) == MODEL_FORMAT and tuple(data['feature_names']) == FEATURE_NAMES
        assert tuple(data['design_names'])[-len(RELATIVE_FEATURES):] == tuple(f'{n}/peak' for n in RELATIVE_FEATURES)


def test_relative_features_see_the_shape_of_a_touch_not_its_strength(tmp_path) -> None:
    X, y = synthetic_rows()
    firm = X.copy()
    light = X.copy()
    cols = [FEATURE_NAMES.index(n) for n in ('peak_amplitude', *RELATIVE_FEATURES)]
    light[:, cols] *= 0.5                      # the same touches by a lighter hand
    model = SubtypeClassifier().fit(X, y)
    assert model.coef_.shape[1] == len(DEFAULT_FEATURES) + len(RELATIVE_FEATURES)
    from touch_gestures.bear.subtype_model import _transform
    keep = X[:, 0] >= 0.1
    ratios = slice(len(DEFAULT_FEATURES), None)
    np.testing.assert_allclose(_transform(light, True)[keep, ratios], _transform(firm, True)[keep, ratios], rtol=1e-5)
    # A format-1 file (no relative columns) still loads and predicts as it did.
    old = SubtypeClassifier(columns=FEATURE_NAMES[:12]).fit(X, y)
    path = tmp_path / 'format1.npz'
    old.save(path)
    data = dict(np.load(path, allow_pickle=False))
    del data['design_names']
    np.savez(path, **{**data, 'format': np.int64(1), 'feature_names': np.array(FEATURE_NAMES[:12])})
    loaded = SubtypeClassifier.load(path)
    assert loaded.relative is False
    np.testing.assert_array_equal(loaded.predict(X), old.predict(X))


def test_model_file_mismatches_are_clear(tmp_path) -> None:
    X, y = synthetic_rows()
    model = SubtypeClassifier().fit(X, y)
    good = tmp_path / 'good.npz'
    model.save(good)
    data = dict(np.load(good, allow_pickle=False))
    for key, value, message in [('format', np.int64(9), 'format 9'),
                                ('feature_names', np.array(['a'] * F), 'features'),
                                ('classes', np.array(['none', 'hug', *TOUCH_SUBTYPES[:-1]]), 'unknown subtype')]:
        bad = tmp_path / f'bad_{key}.npz'
        np.savez(bad, **{**data, key: value})
        with pytest.raises(ValueError, match=message):
            SubtypeClassifier.load(bad)
    missing = tmp_path / 'missing.npz'
    np.savez(missing, format=np.int64(1))
    with pytest.raises(ValueError, match='not a bear subtype model'):
        SubtypeClassifier.load(missing)


def test_tracker_reports_changes_including_back_to_none() -> None:
    fitted = np.zeros(64, dtype=bool)
    fitted[[1, 2]] = True
    tracker = SubtypeTracker(fitted)
    codes = np.zeros(64, dtype=np.int8)
    codes[[1, 13]] = subtype_index('poke')                 # 13 is unfitted: never reported
    changes = tracker.update(0.0, codes)
    assert [(c.channel, c.previous, c.subtype) for c in changes] == [(1, 'none', 'poke')]
    assert tracker.update(0.3, codes) == []
    codes[1] = subtype_index('pet')
    assert [(c.previous, c.subtype) for c in tracker.update(0.6, codes)] == [('poke', 'pet')]
    assert tracker.labels() == {1: 'pet'}
    codes[1] = 0
    assert [(c.previous, c.subtype, c.t) for c in tracker.update(0.9, codes)] == [('pet', 'none', 0.9)]
