"""Patch model files: .npz without pickle, versioned, checked at load."""

import pickle

import numpy as np
import pytest
from doctest_testing import check_doctests

from touch_gestures.patch import model_io
from touch_gestures.patch.features import FEATURE_NAMES
from touch_gestures.patch.model_io import ModelFileError, PatchModel, load_model, save_model
from touch_graph.errors import ConfigError
from touch_lab.patch.training import PatchGestureClassifier


@pytest.fixture(scope='module')
def model():
    rng = np.random.default_rng(0)
    X = np.concatenate([rng.normal(i, 1.0, (150, 12)) for i in range(3)])
    y = np.repeat(['push', 'slap', 'stroke'], 150)
    clf = PatchGestureClassifier(n_components=3, threshold=0.995).fit(X, y)
    return PatchModel(clf, window=40, rate_hz=20.0, k=0.08, grid=(16, 16), release=0.8, dwell=6), X


def saved(tmp_path, model):
    path = tmp_path / 'model.npz'
    save_model(path, model)
    return path


def rewrite(path, **changes):
    with np.load(path, allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    for key, value in changes.items():
        if value is None:
            data.pop(key)
        else:
            data[key] = value
    np.savez(path, **data)


def test_round_trip_gives_the_same_posteriors(tmp_path, model):
    m, X = model
    loaded = load_model(saved(tmp_path, m))
    assert loaded.classes == ('push', 'slap', 'stroke')
    assert (loaded.window, loaded.rate_hz, loaded.k, loaded.grid) == (40, 20.0, 0.08, (16, 16))
    assert (loaded.release, loaded.dwell, loaded.classifier.threshold) == (0.8, 6, 0.995)
    np.testing.assert_allclose(loaded.classifier.predict_log_proba(X), m.classifier.predict_log_proba(X), atol=1e-10)
    np.testing.assert_allclose(loaded.classifier.log_posterior(X[3]), m.classifier.log_posterior(X[3]), atol=1e-10)
    det = loaded.detector()
    assert det.dwell == 6 and det.threshold == 0.995 and det.classes == loaded.classes
    assert loaded.features().window == 40


def test_file_holds_no_objects(tmp_path, model):
    path = saved(tmp_path, model[0])
    with np.load(path, allow_pickle=False) as npz:
        assert all(npz[k].dtype.kind in 'iufU' for k in npz.files)
        assert sorted(npz.files) == sorted(model_io._KEYS)


def test_model_from_another_feature_set_is_refused(tmp_path, model):
    path = saved(tmp_path, model[0])
    other = np.array([*list(FEATURE_NAMES[:11]), 'centre_speed'])
    rewrite(path, feature_names=other)
    with pytest.raises(ModelFileError, match=r'centre_speed.*retrain') as err:
        load_model(path)
    assert isinstance(err.value, ConfigError) and str(path) in str(err.value)


def test_expected_classes_and_grid_are_checked(tmp_path, model):
    path = saved(tmp_path, model[0])
    with pytest.raises(ModelFileError, match='tickle'):
        load_model(path, classes=('push', 'slap', 'stroke', 'tickle'))
    with pytest.raises(ModelFileError, match='8x8'):
        load_model(path, grid=(8, 8))
    assert load_model(path, classes=('stroke', 'push', 'slap'), grid=(16, 16)).classes == ('push', 'slap', 'stroke')


def test_pickle_files_are_never_unpickled(tmp_path):
    class Boom:
        def __reduce__(self):
            return (print, ('unpickled!',))

    path = tmp_path / 'evil.npz'
    path.write_bytes(pickle.dumps(Boom()))
    with pytest.raises(ModelFileError, match='pickle'):
        load_model(path)
    obj = tmp_path / 'objects.npz'
    np.savez(obj, format=np.array(['x', None], dtype=object))
    with pytest.raises(ModelFileError):
        load_model(obj)


@pytest.mark.parametrize('change, match', [
    ({'format': np.array('something.else')}, 'social_touch.patch_gmm'),
    ({'format_version': np.array(2)}, 'version 2'),
    ({'weights': None}, 'lacks weights'),
    ({'means': np.zeros((3, 12))}, 'means'),
    ({'weights': np.full(9, 0.5)}, 'sum to 1'),
    ({'feature_scale': np.zeros(12)}, 'feature_scale'),
    ({'covariances': -np.tile(np.eye(12), (9, 1, 1))}, 'positive definite'),
    ({'hold': np.array(0)}, 'hold=0'),
    ({'component_class': np.zeros(9, dtype=np.int64)}, 'component_class'),
    ({'class_names': np.array(['a', 'a', 'b'])}, 'distinct'),
])
def test_damaged_files_give_clear_errors(tmp_path, model, change, match):
    path = saved(tmp_path, model[0])
    rewrite(path, **change)
    with pytest.raises(ModelFileError, match=match):
        load_model(path)


def test_nan_parameters_are_refused(tmp_path, model):
    path = saved(tmp_path, model[0])
    with np.load(path) as npz:
        means = npz['means'].copy()
    means[0, 0] = np.nan
    rewrite(path, means=means)
    with pytest.raises(ModelFileError, match='finite'):
        load_model(path)


def test_missing_and_truncated_files(tmp_path, model):
    with pytest.raises(ModelFileError, match='not found'):
        load_model(tmp_path / 'nope.npz')
    path = saved(tmp_path, model[0])
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ModelFileError, match='readable'):
        load_model(path)


def test_doctests():
    check_doctests(model_io)
