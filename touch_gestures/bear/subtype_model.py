"""The eight-subtype model (knight2009 Table I): a fitted logistic regression, evaluated with numpy.

Multinomial logistic regression on the standardised feature table of :mod:`.features` (durations
through ``log1p``), trained in the lab (:class:`touch_lab.bear.subtype_training.SubtypeClassifier`)
and evaluated here in the log domain (:class:`SubtypeModel`), so the node never loads scikit-learn.
Why this model: docs/bear-evaluation.md, "Choice of the subtype model".

The model's input columns (its *design*, :func:`design_names`) are named and stored in the model file:
a column is a feature of the table (``duration_s`` and ``since_active_s`` through ``log1p``) or
``<feature>/peak``, a level feature over the buffer's own peak (the shape of a touch, not how hard this
person touches). ``columns=None`` takes the default design: the features of :data:`DEFAULT_FEATURES`,
and with ``relative=True`` :data:`RELATIVE_FEATURES` over the peak too. The features relative to the
touch's own peak (``features.RELATIVE_SHAPE``) and ``band_share`` are columns a model may be given, not in
the default: across families of simulated people they did not make a model that holds on both
(``social-touch eval bear-models``). Files of formats 1 (12 inputs) and 2 (16 inputs) load and
predict as they did; a format-3 file reads its columns by name, so features appended since it was
written change nothing for it.

>>> from touch_graph.paths import share_file
>>> model = SubtypeModel.load(share_file('config', 'bear_subtype_model.npz'))   # the shipped model
>>> model.classes_.tolist()
['none', 'pet', 'poke', 'tickle', 'pat', 'hold', 'tap', 'shake', 'rub']
>>> model.predict_proba(np.zeros((3, len(FEATURE_NAMES)), dtype=np.float32)).shape   # 3 sensors' buffers
(3, 9)
"""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from touch_graph.files import replacing

from ..estimator import NotFittedError
from .features import FEATURE_NAMES
from .subtype import check_feature_table
from .subtype_labels import SUBTYPES, subtype_index

__all__ = ['DEFAULT_FEATURES', 'MODEL_FORMAT', 'RELATIVE_FEATURES', 'SubtypeModel', 'check_design', 'design_names']

#: Version of the .npz model file written by :meth:`SubtypeModel.save` (3: named input columns, any subset).
MODEL_FORMAT = 3
#: The first 12 features: the columns of every format-1 and format-2 file, and of the default design.
_OLD_FEATURES = FEATURE_NAMES[:12]
DEFAULT_FEATURES = _OLD_FEATURES
_LOG_FEATURES = ('duration_s', 'since_active_s')
#: Level features the model also sees divided by the buffer's peak (``relative=True``), named ``<feature>/peak``.
RELATIVE_FEATURES = ('mean_level', 'std_level', 'latest_level', 'roughness_per_s')
#: Peak below which the ratios use this floor instead (an untouched sensor's noise is not a shape).
_PEAK_FLOOR = 0.05


def design_names(relative: bool, features: tuple[str, ...] = DEFAULT_FEATURES) -> tuple[str, ...]:
    """The default design: the names of ``features``, then (``relative``) :data:`RELATIVE_FEATURES` over the peak."""
    return tuple(features) + (tuple(f'{n}/peak' for n in RELATIVE_FEATURES) if relative else ())


def check_design(columns) -> tuple[str, ...]:
    """``columns`` as a tuple of design names; ValueError naming what this code cannot compute."""
    columns = tuple(str(c) for c in columns)
    if not columns:
        raise ValueError('a subtype model needs at least one input column')
    bad = [c for c in columns if c.removesuffix('/peak') not in FEATURE_NAMES
           or (c.endswith('/peak') and c.removesuffix('/peak') not in RELATIVE_FEATURES)]
    if bad:
        raise ValueError(f'unknown model input columns {bad}; a column is one of {", ".join(FEATURE_NAMES)} or '
                         f'one of {", ".join(f"{n}/peak" for n in RELATIVE_FEATURES)}')
    if len(set(columns)) != len(columns):
        raise ValueError(f'model input columns repeat: {list(columns)}')
    return columns


class _Design:
    """How the (n, len(FEATURE_NAMES)) feature table becomes the model's columns (named by :func:`design_names`)."""

    def __init__(self, columns: tuple[str, ...]) -> None:
        self.columns = check_design(columns)
        self.source = np.array([FEATURE_NAMES.index(c.removesuffix('/peak')) for c in self.columns])
        self.logged = np.array([c in _LOG_FEATURES for c in self.columns])
        self.ratio = np.array([c.endswith('/peak') for c in self.columns])

    def transform(self, X: np.ndarray) -> np.ndarray:
        """(n, len(columns)) float32 model inputs of (n, len(FEATURE_NAMES)) finite feature rows."""
        # Row-major as the fit has always seen it: column indexing returns column-major, and a float32
        # mean over another memory order rounds differently (the fit would not reproduce a shipped file).
        out = np.ascontiguousarray(X[:, self.source], dtype=np.float32)
        if self.logged.any():
            out[:, self.logged] = np.log1p(np.maximum(out[:, self.logged], 0.0))
        if self.ratio.any():
            out[:, self.ratio] /= np.maximum(X[:, :1], _PEAK_FLOOR)
        return out


def _transform(X: np.ndarray, relative: bool, columns: tuple[str, ...] | None = None) -> np.ndarray:
    return _Design(design_names(relative) if columns is None else columns).transform(X)


class SubtypeModel:
    """Multinomial logistic regression over the buffer features, one row per sensor and cycle, fitted.

    Made by :meth:`load` (or by the lab's ``SubtypeClassifier.fit``); the arguments say how it is
    (or was) trained.

    Args:
        C: inverse L2 regularisation strength (scikit-learn's ``LogisticRegression.C``).
        class_weight: ``'balanced'`` (default: rare subtypes such as tap count as much as 'none') or None.
        max_iter: L-BFGS iterations.
        relative: with ``columns=None``, also use :data:`RELATIVE_FEATURES` over the buffer's peak (module doc).
        columns: the model's input columns by name (:func:`check_design`); None: :func:`design_names`.

    Learned attributes: ``classes_`` (subtype names), ``mean_`` and ``scale_`` (feature standardisation),
    ``coef_`` ((n_classes, len(columns)) float32) and ``intercept_`` ((n_classes,) float32).
    """

    def __init__(self, C: float = 1.0, class_weight: str | None = 'balanced', max_iter: int = 2000,
                 relative: bool = True, columns: tuple[str, ...] | None = None) -> None:
        self.C = C
        self.class_weight = class_weight
        self.max_iter = max_iter
        self.relative = relative
        self.columns = columns

    @property
    def design_(self) -> tuple[str, ...]:
        """The model's input columns, by name."""
        return design_names(self.relative) if self.columns is None else check_design(self.columns)

    def _set(self, classes, mean, scale, coef, intercept) -> None:
        self.classes_ = np.array(classes)
        self.mean_ = np.asarray(mean, dtype=np.float32)
        self.scale_ = np.asarray(scale, dtype=np.float32)
        self.coef_ = np.asarray(coef, dtype=np.float32)
        self.intercept_ = np.asarray(intercept, dtype=np.float32)
        self.n_features_in_ = len(FEATURE_NAMES)
        self._design = _Design(self.design_)
        self._codes = np.array([subtype_index(c) for c in classes], dtype=np.int8)
        # Fold the standardisation into the weights once: z = X' @ W + b.
        self._w = (self.coef_ / self.scale_[None, :]).T.astype(np.float32)
        self._b = (self.intercept_ - self.coef_ @ (self.mean_ / self.scale_)).astype(np.float32)

    def _check_fitted(self) -> None:
        if not hasattr(self, 'coef_'):
            raise NotFittedError(f'this {type(self).__name__} is not fitted yet; call fit(X, y) or load(path) first')

    def decision_function(self, X) -> np.ndarray:
        """(n_samples, n_classes) float32 class scores (logits)."""
        self._check_fitted()
        return self._design.transform(check_feature_table(X)) @ self._w + self._b

    def predict_log_proba(self, X) -> np.ndarray:
        """(n_samples, n_classes) float64 log probabilities (log-softmax with max subtraction)."""
        z = self.decision_function(X).astype(np.float64)
        z -= z.max(axis=1, keepdims=True)
        return z - np.log(np.exp(z).sum(axis=1, keepdims=True))

    def predict_proba(self, X) -> np.ndarray:
        return np.exp(self.predict_log_proba(X))

    def predict_codes(self, X) -> tuple[np.ndarray, np.ndarray]:
        """(n_samples,) int8 codes into SUBTYPES and (n_samples,) float32 confidence (the winner's probability)."""
        z = self.decision_function(X)
        best = z.argmax(axis=1)
        top = z[np.arange(z.shape[0]), best]
        confidence = 1.0 / np.exp(z - top[:, None]).sum(axis=1)
        return self._codes[best], confidence.astype(np.float32)

    def predict(self, X) -> np.ndarray:
        """(n_samples,) subtype names."""
        scores = self.decision_function(X)
        return self.classes_[scores.argmax(axis=1)]

    # ------------------------------------------------------------------ files (.npz, never pickle)
    def save(self, path: str | Path, rate_hz: float | None = None, buffer_len: int | None = None) -> None:
        """Write the model as .npz with its format version, feature names and classes, and (optionally) the
        scan rate and buffer length its features were computed at (NaN when not given)."""
        self._check_fitted()
        trained_at = np.array([np.nan if rate_hz is None else float(rate_hz),
                               np.nan if buffer_len is None else float(buffer_len)])
        path = Path(path) if str(path).endswith('.npz') else Path(f'{path}.npz')  # where np.savez would write
        with replacing(path) as tmp:  # whole or not at all: a full disk keeps the previous model
            np.savez(tmp, format=np.int64(MODEL_FORMAT), feature_names=np.array(FEATURE_NAMES), classes=self.classes_,
                     design_names=np.array(self.design_),
                     mean=self.mean_, scale=self.scale_, coef=self.coef_, intercept=self.intercept_,
                     params=np.array([float(self.C), float(self.max_iter)]), trained_at=trained_at)

    @classmethod
    def load(cls, path: str | Path) -> SubtypeModel:
        """Read a model written by :meth:`save`; ValueError when the format, features or classes do not match."""
        try:
            archive = np.load(path, allow_pickle=False)
        except FileNotFoundError as err:
            raise ValueError(f'{path}: model file not found; train one with `social-touch train bear`') from err
        except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
            raise ValueError(f'{path}: not a readable .npz model (truncated or empty?): {type(err).__name__}: '
                             f'{err}') from err
        with archive as data:
            try:
                version = int(data['format'])
                features = tuple(str(s) for s in data['feature_names'])
                classes = [str(s) for s in data['classes']]
                arrays = [data[k] for k in ('mean', 'scale', 'coef', 'intercept')]
                trained_at = data['trained_at'] if 'trained_at' in data else np.array([np.nan, np.nan])
                design = tuple(str(s) for s in data['design_names']) if 'design_names' in data else features
            except KeyError as err:
                raise ValueError(f'{path}: not a bear subtype model (missing {err}); write one with '
                                 'SubtypeModel.save') from None
        if version not in (1, 2, MODEL_FORMAT):
            raise ValueError(f'{path}: model format {version}, this code reads formats 1 to {MODEL_FORMAT}; '
                             'retrain it')
        # Features are only ever appended: a format-3 file of fewer features reads the same columns by name.
        expected = _OLD_FEATURES if version < 3 else FEATURE_NAMES[:len(features)]
        if features != expected:
            raise ValueError(f'{path}: trained on features {features}, this code computes {expected}; retrain it')
        unknown = [c for c in classes if c not in SUBTYPES]
        if unknown:
            raise ValueError(f'{path}: unknown subtype classes {unknown}; expected some of {SUBTYPES}')
        old_designs = (design_names(True, _OLD_FEATURES), design_names(False, _OLD_FEATURES))
        if version < 3 and design not in old_designs:
            raise ValueError(f'{path}: model inputs {design} are not those of a format-{version} file '
                             f'{old_designs[0]}; retrain it')
        try:
            design = check_design(design)
        except ValueError as err:
            raise ValueError(f'{path}: {err}; retrain it') from None
        n, f = len(classes), len(design)
        shapes = [(f,), (f,), (n, f), (n,)]
        if [a.shape for a in arrays] != shapes:
            raise ValueError(f'{path}: array shapes {[a.shape for a in arrays]} do not match {shapes}')
        for name, array in zip(('mean', 'scale', 'coef', 'intercept'), arrays, strict=True):
            if not np.isfinite(array).all():
                raise ValueError(f'{path}: {int((~np.isfinite(array)).sum())} non-finite values in {name!r}; '
                                 'the model is damaged: retrain it')
        if not (arrays[1] > 0).all():
            raise ValueError(f'{path}: feature scales must be > 0; the model is damaged: retrain it')
        model = cls(relative=design == old_designs[0], columns=design)
        model._set(classes, *arrays)
        #: scan rate (Hz) and buffer length (cycles) the model was trained at; None when unknown
        model.trained_rate_hz_ = None if np.isnan(trained_at[0]) else float(trained_at[0])
        model.trained_buffer_len_ = None if np.isnan(trained_at[1]) else int(trained_at[1])
        return model
