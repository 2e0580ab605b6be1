"""Features relative to the touch's own peak, model files with named input columns, the wide population.

All signals and people here are synthetic, made by hand or by the seeded simulation.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from touch_gestures.bear.features import FEATURE_NAMES, RELATIVE_SHAPE, FeatureExtractor, spectral_features
from touch_gestures.bear.subtype_model import MODEL_FORMAT, SubtypeModel, check_design, design_names
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_sim.bear.people import WIDE, Population, make_scene

RATE = 3.4
ONSETS, TROUGH, DIPS = (FEATURE_NAMES.index(n) for n in RELATIVE_SHAPE)
DATA = Path(__file__).parent / 'data'


def shape(window, touch_cycles=None) -> np.ndarray:
    """(channels, 3) relative-shape features of a (n, channels) window."""
    w = np.asarray(window, dtype=np.float32)
    cycles = None if touch_cycles is None else np.asarray(touch_cycles)
    return spectral_features(w, RATE, touch_cycles=cycles)[:, [ONSETS, TROUGH, DIPS]]


def test_constant_level_is_one_onset_no_trough_no_dip() -> None:
    x = np.full((20, 1), 0.7)
    onsets, trough, dips = shape(x, [20])[0]
    assert (onsets, trough, dips) == (pytest.approx(RATE / 20), 1.0, 0.0)
    # A touch older than the buffer was already up at its first sample: no onset at all.
    assert shape(x, [40])[0, 0] == 0.0


def test_a_single_onset_is_counted_per_second_of_touch() -> None:
    x = np.zeros((20, 1))
    x[15:, 0] = [0.2, 0.9, 0.9, 0.9, 0.9]          # the touch: the last 5 samples, rising through half its peak
    onsets, trough, dips = shape(x, [5])[0]
    assert onsets == pytest.approx(1 / (5 / RATE))
    assert trough == pytest.approx(0.2 / 0.9) and dips == pytest.approx(1 / 5)


def test_the_features_do_not_see_how_hard_a_person_presses() -> None:
    t = np.arange(20) / RATE
    pats = np.clip(np.sin(2 * np.pi * 0.8 * t), 0, None)[:, None]
    np.testing.assert_allclose(shape(0.95 * pats, [20]), shape(0.4 * pats, [20]), rtol=1e-5)
    onsets, trough, dips = shape(0.95 * pats, [20])[0]
    assert onsets > 2 * RATE / 20 and trough == 0.0 and 0.3 < dips < 1.0


def test_all_zero_nan_and_one_sample_touches_are_zero_or_finite() -> None:
    assert (shape(np.zeros((20, 2)), [0, 0]) == 0).all()
    x = np.full((20, 1), 0.8)
    x[7, 0] = np.nan                               # read as 0: a dip to nothing
    onsets, trough, dips = shape(x, [20])[0]
    assert np.isfinite([onsets, trough, dips]).all() and trough == 0.0 and dips == pytest.approx(1 / 20)
    assert onsets == pytest.approx(2 * RATE / 20)  # the first rise and the rise after the NaN
    one = shape(np.array([[0.6, 0.1]]), [1, 0])
    np.testing.assert_allclose(one, [[RATE, 1.0, 0.0], [0.0, 0.0, 0.0]])
    assert (shape(np.zeros((0, 3))) == 0).all()


def test_buffer_window_takes_the_whole_buffer_as_the_touch() -> None:
    ext = FeatureExtractor(RATE, n_channels=1, window='buffer')
    x = np.zeros((20, 1), dtype=np.float32)
    x[10:] = 0.9
    row = ext.update(x).table[0]
    assert row[DIPS] == pytest.approx(0.5) and row[TROUGH] == 0.0 and row[ONSETS] == pytest.approx(RATE / 20)


# ------------------------------------------------------------------ model files


def rows(seed: int = 0, n: int = 400) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    X = rng.random((n, len(FEATURE_NAMES))).astype(np.float32)
    y = np.where(X[:, TROUGH] > 0.5, 'hold', np.where(X[:, 0] > 0.3, 'pat', 'none'))
    return X, y


def test_the_shipped_format_2_file_predicts_as_it_did() -> None:
    """The model file shipped before named columns (test/data, copied from the repo at f921596), and what
    the code of that commit predicted for fixed rows of its 12 features."""
    model = SubtypeModel.load(DATA / 'bear_subtype_model_format2.npz')
    assert model.design_ == design_names(True, FEATURE_NAMES[:12]) and model.relative is True
    with np.load(DATA / 'bear_subtype_model_format2_expected.npz') as expected:
        X = np.zeros((len(expected['X']), len(FEATURE_NAMES)), dtype=np.float32)
        X[:, :12] = expected['X']
        X[:, 12:] = np.random.default_rng(1).random((len(X), len(FEATURE_NAMES) - 12))  # new columns: unseen
        codes, confidence = model.predict_codes(X)
        np.testing.assert_array_equal(codes, expected['codes'])
        np.testing.assert_allclose(confidence, expected['confidence'], rtol=1e-5)


def test_a_model_of_chosen_columns_round_trips(tmp_path) -> None:
    X, y = rows()
    columns = ('duration_s', 'std_level/peak', *RELATIVE_SHAPE)
    model = SubtypeClassifier(columns=columns).fit(X, y)
    assert model.coef_.shape == (3, len(columns))
    path = tmp_path / 'm.npz'
    model.save(path, rate_hz=RATE, buffer_len=20)
    loaded = SubtypeModel.load(path)
    assert loaded.design_ == columns
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    # Columns it does not use do not change what it says.
    other = X.copy()
    other[:, [1, 4, 7]] = 0.123                   # base frequency, mean and latest level
    np.testing.assert_array_equal(loaded.predict(other), model.predict(X))
    with np.load(path, allow_pickle=False) as data:
        assert int(data['format']) == MODEL_FORMAT and tuple(data['design_names']) == columns


def test_unknown_columns_are_refused_clearly(tmp_path) -> None:
    with pytest.raises(ValueError, match='unknown model input columns'):
        check_design(['duration_s', 'elbow_angle'])
    with pytest.raises(ValueError, match='unknown model input columns'):
        check_design(['duration_s/peak'])            # durations have no ratio to the peak
    with pytest.raises(ValueError, match='repeat'):
        check_design(['duration_s', 'duration_s'])
    X, y = rows()
    path = tmp_path / 'm.npz'
    SubtypeClassifier(columns=('duration_s', 'dip_fraction')).fit(X, y).save(path)
    data = dict(np.load(path, allow_pickle=False))
    np.savez(path, **{**data, 'design_names': np.array(['duration_s', 'hand_size'])})
    with pytest.raises(ValueError, match=r'hand_size.*retrain'):
        SubtypeModel.load(path)
    # A format-2 file names the 12 features it was trained on; with other inputs it is refused.
    np.savez(path, **{**data, 'format': np.int64(2)})
    with pytest.raises(ValueError, match='trained on features'):
        SubtypeModel.load(path)


# ------------------------------------------------------------------ the wide population


def levels(scene, step_s: float = 0.29) -> np.ndarray:
    return np.array([scene.proximity(t) for t in np.arange(0.0, scene.duration_s, step_s)])


def test_the_wide_population_is_seeded_and_the_old_one_unchanged() -> None:
    kw = {'n_people': 2, 'seed': 11, 'subtype_reps': 1, 'gesture_reps': 1}
    a, b = make_scene(**kw, population=WIDE), make_scene(**kw, population=WIDE)
    np.testing.assert_array_equal(levels(a), levels(b))
    assert [lab.label for lab in a.labels] == [lab.label for lab in b.labels]
    old = make_scene(**kw)
    # The same people perform the same plan; the wide population only changes how they do it.
    assert [(lab.kind, lab.label, lab.sensors) for lab in old.labels] == \
        [(lab.kind, lab.label, lab.sensors) for lab in a.labels]
    assert not np.array_equal(levels(old)[:500], levels(a)[:500])
    assert all(c.rhythm == c.noise == c.drift == c.jitter_s == 0 for c in old.contacts)
    lv = levels(a)
    assert np.isfinite(lv).all() and lv.min() >= 0 and lv.max() <= 1


def test_a_population_of_one_style_sets_every_contact() -> None:
    firm = Population(pressure=(0.5, 0.5), tempo=(2.0, 2.0), persistence=(1.0, 1.0), rhythm=(0.0, 0.0),
                      noise=(0.0, 0.0), drift=(0.0, 0.0), jitter_s=(0.0, 0.0), person_share=0.25)
    kw = {'n_people': 1, 'seed': 4, 'subtype_reps': 1, 'gesture_reps': 0}
    old, light = make_scene(**kw), make_scene(**kw, population=firm)
    for c0, c1 in zip(old.contacts, light.contacts, strict=True):
        assert c1.amplitude == pytest.approx(c0.amplitude * 0.5)
        assert c1.frequency_hz == pytest.approx(c0.frequency_hz * 2.0)
        assert c1.end_s - c1.start_s == pytest.approx(c0.end_s - c0.start_s)


def test_training_populations_are_named_and_seeded_apart() -> None:
    from touch_lab.bear.transfer import POPULATIONS, population_scene, train_seed
    assert POPULATIONS == ('script', 'hands', 'wide')
    wide = population_scene('wide', 1, 3, 1, 0)
    assert 'wide population' in wide.description and any(c.jitter_s > 0 for c in wide.contacts)
    assert len({train_seed(p, 0) for p in ('script', 'wide')}) == 2       # other people, not restyled ones
    with pytest.raises(ValueError, match='unknown population'):
        population_scene('crowd', 1, 3, 1, 0)
