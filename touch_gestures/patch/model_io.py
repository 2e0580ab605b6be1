"""Patch gesture model files: ``.npz`` without pickle, versioned, checked at load.

A model file is a numpy ``.npz`` archive read with ``allow_pickle=False``, so opening one
cannot run code: it holds only numeric and fixed-width unicode arrays. Format
(``format = 'social_touch.patch_gmm'``, ``format_version = 1``):

==================  =============  ==================================================
key                 shape, dtype   meaning
==================  =============  ==================================================
format              () str         ``social_touch.patch_gmm``
format_version      () int64       1
feature_names       (d,) str       window features, in order (features.FEATURE_NAMES)
class_names         (C,) str       gesture classes, in posterior order
window              () int64       window length, frames (paper: 60)
rate_hz             () float64     frame rate the window was made for, Hz (paper: 20)
k                   () float64     activation floor of eq. (2) (paper: 0.08)
grid                (2,) int64     activation map rows, cols (patch: 16, 16)
threshold           () float64     posterior threshold for events (paper: 0.99)
release             () float64     event rule: posterior below which the class is forgotten
hold                () int64       event rule: the dwell, frames above the threshold before an event (paper: 1)
covariance_type     () str         what EM fitted (stored covariances are always full)
component_class     (K,) int64     class index of each mixture component
weights             (K,) float64   component weights, sum to 1 within each class
means               (K, d) float64 component means, standardised units
covariances         (K, d, d) f64  full covariances, standardised units, positive definite
feature_mean        (d,) float64   subtracted from the features before the mixtures
feature_scale       (d,) float64   divides them after (> 0)
metadata            () str         optional: a JSON object of strings, numbers and
                                   booleans (how the model was made: data, command,
                                   ``synthetic``); older readers ignore it
==================  =============  ==================================================

>>> import tempfile, os, numpy as np
>>> from touch_lab.patch.training import PatchGestureClassifier   # training: scikit-learn's EM
>>> rng = np.random.default_rng(0)
>>> X = np.concatenate([rng.normal(0, 1, (40, 12)), rng.normal(3, 1, (40, 12))])
>>> clf = PatchGestureClassifier(n_components=2).fit(X, ['stroke'] * 40 + ['push'] * 40)
>>> path = os.path.join(tempfile.mkdtemp(), 'm.npz')
>>> save_model(path, PatchModel(clf, window=60, rate_hz=20.0))
>>> load_model(path).classifier.classes_.tolist()
['push', 'stroke']
"""

from __future__ import annotations

import json
import os
import zipfile
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from touch_graph.errors import ConfigError
from touch_graph.files import replacing

from .classifier import EventDetector, GaussianMixtureParams, GestureMixtures, precision_cholesky
from .features import FEATURE_NAMES, WindowFeatures

__all__ = ['FORMAT', 'FORMAT_VERSION', 'ModelFileError', 'PatchModel', 'load_model', 'save_model']

FORMAT = 'social_touch.patch_gmm'
FORMAT_VERSION = 1
_KEYS = ('format', 'format_version', 'feature_names', 'class_names', 'window', 'rate_hz', 'k', 'grid',
         'threshold', 'release', 'hold', 'covariance_type', 'component_class', 'weights', 'means', 'covariances',
         'feature_mean', 'feature_scale')


class ModelFileError(ConfigError):
    """A patch model file is missing, unreadable, of another format or version, or inconsistent."""


@dataclass
class PatchModel:
    """A fitted classifier with the feature settings it was trained for.

    Attributes:
        classifier: the fitted :class:`~.classifier.GestureMixtures` (threshold included).
        window: window length in frames. rate_hz: frame rate, Hz. k: activation floor.
        grid: (rows, cols) of the activation maps.
        feature_names: the features the classifier expects, in order.
        release, dwell: the event rule's settings (see :class:`EventDetector`); the file stores
            ``dwell`` (frames) under its older key ``hold``, so files stay readable both ways.
        metadata: how the model was made (training data, command, ``synthetic``): JSON-able
            scalars by name, stored in the file's optional ``metadata`` key.
    """

    classifier: GestureMixtures
    window: int = 60
    rate_hz: float = 20.0
    k: float = 0.08
    grid: tuple[int, int] = (16, 16)
    feature_names: tuple[str, ...] = FEATURE_NAMES
    release: float = 0.9
    dwell: int = 1
    metadata: dict = field(default_factory=dict)

    @property
    def synthetic(self) -> bool:
        """True when the metadata say the model was trained on synthetic (simulated) data."""
        return bool(self.metadata.get('synthetic', False))

    @property
    def classes(self) -> tuple[str, ...]:
        return tuple(str(c) for c in self.classifier.classes_)

    def features(self) -> WindowFeatures:
        """A fresh :class:`WindowFeatures` with the model's window, floor and grid."""
        return WindowFeatures(self.window, k=self.k, grid=self.grid)

    def detector(self) -> EventDetector:
        """A fresh :class:`EventDetector` with the model's classes and event-rule settings."""
        return EventDetector(self.classes, threshold=self.classifier.threshold,
                             release=min(self.release, self.classifier.threshold), rate_hz=self.rate_hz,
                             dwell=self.dwell)


def save_model(path: str | os.PathLike, model: PatchModel) -> None:
    """Write ``model`` to ``path`` (an ``.npz``); the file is replaced atomically."""
    clf = model.classifier
    params: GaussianMixtureParams = clf.params_
    arrays = {
        'format': np.array(FORMAT), 'format_version': np.array(FORMAT_VERSION, dtype=np.int64),
        'feature_names': np.array(model.feature_names, dtype=str), 'class_names': np.array(params.classes, dtype=str),
        'window': np.array(model.window, dtype=np.int64), 'rate_hz': np.array(model.rate_hz, dtype=np.float64),
        'k': np.array(model.k, dtype=np.float64), 'grid': np.array(model.grid, dtype=np.int64),
        'threshold': np.array(clf.threshold, dtype=np.float64),
        'release': np.array(model.release, dtype=np.float64), 'hold': np.array(model.dwell, dtype=np.int64),
        'covariance_type': np.array(clf.covariance_type),
        'component_class': params.component_class.astype(np.int64), 'weights': params.weights,
        'means': params.means, 'covariances': params.covariances,
        'feature_mean': params.feature_mean, 'feature_scale': params.feature_scale,
    }
    if model.metadata:
        arrays['metadata'] = np.array(_metadata_json(model.metadata))
    with replacing(Path(path)) as tmp:
        np.savez(tmp, **arrays)


def _metadata_json(metadata: dict) -> str:
    """``metadata`` as a JSON object; ValueError for values other than str, number, bool or None."""
    for key, value in metadata.items():
        if not isinstance(key, str) or not (value is None or isinstance(value, (str, bool, int, float))):
            raise ValueError(f'model metadata must map names to str, number, bool or None; got {key!r}: {value!r}')
    return json.dumps(metadata, sort_keys=True)


def _read_metadata(data: dict, where: str) -> dict:
    if 'metadata' not in data:
        return {}
    value = data['metadata']
    try:
        if value.shape != () or value.dtype.kind != 'U':
            raise ValueError(f'dtype {value.dtype} shape {value.shape}')
        meta = json.loads(str(value))
        if not isinstance(meta, dict):
            raise ValueError(f'a JSON {type(meta).__name__}')
    except ValueError as err:
        raise ModelFileError(f"'metadata' must be a JSON object in a str scalar; got {err}", where) from err
    return meta


def _scalar(data: dict, key: str, kind: str, where: str):
    value = data[key]
    if value.shape != () or value.dtype.kind not in kind:
        raise ModelFileError(f"'{key}' must be a scalar of kind {kind!r}; got dtype {value.dtype} shape {value.shape}",
                             where)
    return value.item()


def load_model(path: str | os.PathLike, feature_names: tuple[str, ...] = FEATURE_NAMES,
               classes: tuple[str, ...] | None = None, grid: tuple[int, int] | None = None) -> PatchModel:
    """Read and check a model file.

    Args:
        path: the ``.npz`` file.
        feature_names: the features this build computes; the file must list the same, in order.
        classes: if given, the classes the caller expects (e.g. from a scene config).
        grid: if given, the activation map shape the caller will feed.

    Raises:
        ModelFileError: naming the file and what is wrong, for a missing or unreadable file,
            another format, a newer version, missing keys, a model made for other features,
            classes or grid, or inconsistent or non-finite parameters.
    """
    where = str(path)
    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {key: npz[key] for key in npz.files}
    except FileNotFoundError as err:
        raise ModelFileError('model file not found; train one with `social-touch train patch`', where) from err
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as err:
        raise ModelFileError(f'not a readable .npz model file ({err}); it may be truncated, or a pickle '
                             '(which is never loaded)', where) from err
    if 'format' not in data or data['format'].shape != () or str(data['format']) != FORMAT:
        got = str(data['format']) if 'format' in data and data['format'].shape == () else 'no format key'
        raise ModelFileError(f"expected a '{FORMAT}' model file; got {got}", where)
    missing = [k for k in _KEYS if k not in data]
    if missing:
        raise ModelFileError(f'model file lacks {", ".join(missing)}; it is damaged or from an unfinished writer',
                             where)
    version = _scalar(data, 'format_version', 'iu', where)
    if version != FORMAT_VERSION:
        raise ModelFileError(f'model format version {version}; this build reads version {FORMAT_VERSION} '
                             '(retrain with `social-touch train patch`)', where)
    names = tuple(str(s) for s in data['feature_names'].tolist())
    if names != tuple(feature_names):
        raise ModelFileError(f'model was trained on features {list(names)}; this build computes '
                             f'{list(feature_names)}; retrain it with `social-touch train patch`', where)
    class_names = tuple(str(s) for s in data['class_names'].tolist())
    if len(class_names) < 2 or len(set(class_names)) != len(class_names):
        raise ModelFileError(f'class_names must be at least two distinct names; got {list(class_names)}', where)
    if classes is not None and set(classes) != set(class_names):
        raise ModelFileError(f'model knows classes {sorted(class_names)}; the configuration expects '
                             f'{sorted(classes)}', where)
    file_grid = tuple(int(v) for v in np.asarray(data['grid']).reshape(-1))
    if len(file_grid) != 2 or min(file_grid) < 1:
        raise ModelFileError(f'grid must be two positive ints; got {file_grid}', where)
    if grid is not None and tuple(grid) != file_grid:
        raise ModelFileError(f'model was trained on {file_grid[0]}x{file_grid[1]} maps; the sensor gives '
                             f'{grid[0]}x{grid[1]}', where)
    window = _scalar(data, 'window', 'iu', where)
    rate_hz = float(_scalar(data, 'rate_hz', 'fiu', where))
    k = float(_scalar(data, 'k', 'fiu', where))
    threshold = float(_scalar(data, 'threshold', 'fiu', where))
    release = float(_scalar(data, 'release', 'fiu', where))
    dwell = _scalar(data, 'hold', 'iu', where)
    if window < 1 or not rate_hz > 0 or not 0 < threshold <= 1 or not np.isfinite(k) or dwell < 1 \
            or not 0 <= release <= 1:
        raise ModelFileError(f'bad settings: window={window}, rate_hz={rate_hz}, threshold={threshold}, k={k}, '
                             f'release={release}, hold={dwell} (the dwell, frames)', where)
    params = _check_params(data, class_names, len(names), where)
    clf = GestureMixtures.from_params(params, threshold=threshold,
                                      covariance_type=str(data['covariance_type']))
    return PatchModel(clf, window=int(window), rate_hz=rate_hz, k=k, grid=file_grid, feature_names=names,
                      release=release, dwell=int(dwell), metadata=_read_metadata(data, where))


def _check_params(data: dict, classes: tuple[str, ...], d: int, where: str) -> GaussianMixtureParams:
    comp = np.asarray(data['component_class'])
    n = comp.shape[0] if comp.ndim == 1 else -1
    shapes = {'component_class': (n,), 'weights': (n,), 'means': (n, d), 'covariances': (n, d, d),
              'feature_mean': (d,), 'feature_scale': (d,)}
    for key, shape in shapes.items():
        arr = data[key]
        if n < 1 or arr.shape != shape:
            raise ModelFileError(f"'{key}' has shape {arr.shape}; expected {shape} for {max(n, 0)} components "
                                 f'and {d} features', where)
        if key != 'component_class' and (arr.dtype.kind != 'f' or not np.isfinite(arr).all()):
            raise ModelFileError(f"'{key}' must be finite floats; got dtype {arr.dtype}", where)
    if comp.dtype.kind not in 'iu' or comp.min() < 0 or comp.max() >= len(classes) \
            or np.any(np.diff(comp) < 0) or len(np.unique(comp)) != len(classes):
        raise ModelFileError(f'component_class must be sorted class indices covering all {len(classes)} classes; '
                             f'got {comp.tolist()}', where)
    weights = data['weights']
    sums = np.bincount(comp, weights=weights, minlength=len(classes))
    if np.any(weights < 0) or not np.allclose(sums, 1.0, atol=1e-6):
        raise ModelFileError(f'component weights must be >= 0 and sum to 1 per class; sums are {sums.tolist()}',
                             where)
    if np.any(data['feature_scale'] <= 0):
        raise ModelFileError('feature_scale must be > 0', where)
    try:
        precision_cholesky(data['covariances'])
    except np.linalg.LinAlgError as err:
        raise ModelFileError(f'a covariance is not positive definite ({err})', where) from err
    return GaussianMixtureParams(classes=classes, component_class=comp.astype(np.int64),
                                 weights=weights.astype(np.float64), means=data['means'].astype(np.float64),
                                 covariances=data['covariances'].astype(np.float64),
                                 feature_mean=data['feature_mean'].astype(np.float64),
                                 feature_scale=data['feature_scale'].astype(np.float64))
