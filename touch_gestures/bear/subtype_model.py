"""The eight-subtype model (knight2009 Table I): a fitted logistic regression, evaluated with numpy.

Multinomial logistic regression on the standardised feature table of :mod:`.features` (durations
through ``log1p``), trained in the lab (:class:`touch_lab.bear.subtype_training.SubtypeClassifier`)
and evaluated here in the log domain (:class:`SubtypeModel`), so the node never loads scikit-learn.
Why this model: docs/bear-evaluation.md, "Choice of the subtype model".

With ``relative=True`` (the default) the model also sees :data:`RELATIVE_FEATURES`: the level
features over the buffer's own peak (the shape of a touch, not how hard this person touches).
Format-1 files (without them) load with ``relative=False``.

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

__all__ = ['MODEL_FORMAT', 'RELATIVE_FEATURES', 'SubtypeModel', 'design_names']

#: Version of the .npz model file written by :meth:`SubtypeModel.save`.
MODEL_FORMAT = 2
_LOG_COLUMNS = [FEATURE_NAMES.index('duration_s'), FEATURE_NAMES.index('since_active_s')]
#: Level features the model also sees divided by the buffer's peak (``relative=True``), named ``<feature>/peak``.
RELATIVE_FEATURES = ('mean_level', 'std_level', 'latest_level', 'roughness_per_s')
_RELATIVE_COLUMNS = [FEATURE_NAMES.index(n) for n in RELATIVE_FEATURES]
#: Peak below which the ratios use this floor instead (an untouched sensor's noise is not a shape).
_PEAK_FLOOR = 0.05


def design_names(relative: bool) -> tuple[str, ...]:
    """Names of the model's input columns: the feature table's, then the relative ones."""
    return FEATURE_NAMES + (tuple(f'{n}/peak' for n in RELATIVE_FEATURES) if relative else ())


def _transform(X: np.ndarray, relative: bool) -> np.ndarray:
    out = X.astype(np.float32, copy=True)
    out[:, _LOG_COLUMNS] = np.log1p(np.maximum(out[:, _LOG_COLUMNS], 0.0))
    if not relative:
        return out
    peak = np.maximum(X[:, 0], _PEAK_FLOOR)[:, None]
    return np.hstack([out, (X[:, _RELATIVE_COLUMNS] / peak).astype(np.float32)])


class SubtypeModel:
    """Multinomial logistic regression over the buffer features, one row per sensor and cycle, fitted.

    Made by :meth:`load` (or by the lab's ``SubtypeClassifier.fit``); the arguments say how it is
    (or was) trained.

    Args:
        C: inverse L2 regularisation strength (scikit-learn's ``LogisticRegression.C``).
        class_weight: ``'balanced'`` (default: rare subtypes such as tap count as much as 'none') or None.
        max_iter: L-BFGS iterations.
        relative: also use :data:`RELATIVE_FEATURES` over the buffer's peak (module doc).

    Learned attributes: ``classes_`` (subtype names), ``mean_`` and ``scale_`` (feature standardisation),
    ``coef_`` ((n_classes, len(design_names(relative))) float32) and ``intercept_`` ((n_classes,) float32).
    """

    def __init__(self, C: float = 1.0, class_weight: str | None = 'balanced', max_iter: int = 2000,
                 relative: bool = True) -> None:
        self.C = C
        self.class_weight = class_weight
        self.max_iter = max_iter
        self.relative = relative

    def _set(self, classes, mean, scale, coef, intercept) -> None:
        self.classes_ = np.array(classes)
        self.mean_ = np.asarray(mean, dtype=np.float32)
        self.scale_ = np.asarray(scale, dtype=np.float32)
        self.coef_ = np.asarray(coef, dtype=np.float32)
        self.intercept_ = np.asarray(intercept, dtype=np.float32)
        self.n_features_in_ = len(FEATURE_NAMES)
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
        return _transform(check_feature_table(X), self.relative) @ self._w + self._b

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
                     design_names=np.array(design_names(self.relative)),
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
                design = tuple(str(s) for s in data['design_names']) if 'design_names' in data else FEATURE_NAMES
            except KeyError as err:
                raise ValueError(f'{path}: not a bear subtype model (missing {err}); write one with '
                                 'SubtypeModel.save') from None
        if version not in (1, MODEL_FORMAT):
            raise ValueError(f'{path}: model format {version}, this code reads formats 1 and {MODEL_FORMAT}; '
                             'retrain it')
        if features != FEATURE_NAMES:
            raise ValueError(f'{path}: trained on features {features}, this code computes {FEATURE_NAMES}; retrain it')
        unknown = [c for c in classes if c not in SUBTYPES]
        if unknown:
            raise ValueError(f'{path}: unknown subtype classes {unknown}; expected some of {SUBTYPES}')
        relative = design == design_names(True)
        if design not in (design_names(True), design_names(False)):
            raise ValueError(f'{path}: model inputs {design} are not this code\'s {design_names(True)}; retrain it')
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
        model = cls(relative=relative)
        model._set(classes, *arrays)
        #: scan rate (Hz) and buffer length (cycles) the model was trained at; None when unknown
        model.trained_rate_hz_ = None if np.isnan(trained_at[0]) else float(trained_at[0])
        model.trained_buffer_len_ = None if np.isnan(trained_at[1]) else int(trained_at[1])
        return model
