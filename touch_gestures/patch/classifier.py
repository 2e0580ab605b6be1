"""Maximum-likelihood patch gesture classifier: one Gaussian mixture per class (sympartner2018 6.2).

For each gesture class ``c`` a mixture ``p(f | c) = sum_k w_k N(f | mu_k, Sigma_k)`` of the
window features; with a uniform prior the posterior is ``p(c | f) = p(f | c) / sum_c' p(f | c')``,
computed in the log domain. The mixtures are fitted by EM (scikit-learn's ``GaussianMixture``)
in the lab, :class:`touch_lab.patch.training.PatchGestureClassifier`; this module evaluates fitted
ones with numpy alone (:class:`GestureMixtures`), so the node's process never loads scikit-learn.

Per frame, :meth:`GestureMixtures.log_posterior` evaluates all the classes' mixtures with one
matrix product on parameters prepared once (precision Cholesky factors, with the feature
standardisation folded in); :class:`EventDetector` turns posteriors into gesture events.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..estimator import NotFittedError

__all__ = ['NOT_RECOGNISED', 'Detection', 'EventDetector', 'GaussianMixtureParams', 'GestureMixtures', 'decide',
           'precision_cholesky']

#: Decision index of a sample whose best posterior stays below the threshold.
NOT_RECOGNISED = -1
_LOG_2PI = math.log(2.0 * math.pi)


def precision_cholesky(covariances: np.ndarray) -> np.ndarray:
    """Upper factors ``U`` with ``U @ U.T = inv(Sigma)`` for (K, d, d) covariances.

    Raises:
        np.linalg.LinAlgError: when a covariance is not positive definite.
    """
    cov = np.asarray(covariances, dtype=np.float64)
    if not np.isfinite(cov).all():
        raise np.linalg.LinAlgError('a covariance has NaN or infinite entries')
    lower = np.linalg.cholesky(cov)                 # (K, d, d), raises LinAlgError if not positive definite
    eye = np.broadcast_to(np.eye(cov.shape[-1]), cov.shape)
    return np.linalg.solve(lower, eye).transpose(0, 2, 1)


@dataclass(frozen=True)
class GaussianMixtureParams:
    """The fitted mixtures of all classes, in standardised feature units.

    Attributes:
        classes: (C,) class names.
        component_class: (K,) int, class index of each component (grouped by class).
        weights: (K,) float64 mixture weights, summing to 1 within each class.
        means: (K, d) float64 component means.
        covariances: (K, d, d) float64 full covariances (diagonal/spherical fits expanded).
        feature_mean: (d,) float64 mean subtracted before the mixtures (standardisation).
        feature_scale: (d,) float64 divisor after the subtraction (1 for constant features).
    """

    classes: tuple[str, ...]
    component_class: np.ndarray
    weights: np.ndarray
    means: np.ndarray
    covariances: np.ndarray
    feature_mean: np.ndarray
    feature_scale: np.ndarray


class _Evaluator:
    """All mixtures as one affine map plus per-component constants (prepared once)."""

    def __init__(self, params: GaussianMixtureParams) -> None:
        n_classes = len(params.classes)
        d = params.means.shape[1]
        counts = np.bincount(params.component_class, minlength=n_classes)
        m = int(counts.max())
        prec = precision_cholesky(params.covariances)           # (K, d, d)
        inv_scale = 1.0 / params.feature_scale
        # y_k = ((x - mean) / scale - mu_k) @ U_k = x @ (diag(1/scale) U_k) - (mean/scale + mu_k) @ U_k
        shift = params.feature_mean * inv_scale                  # (d,)
        # Slots (class, j) padded to m per class; padded slots have constant -inf.
        weight = np.zeros((n_classes, m, d, d))
        offset = np.zeros((n_classes, m, d))
        const = np.full((n_classes, m), -np.inf)
        slot = np.zeros(n_classes, dtype=int)
        log_det = np.log(np.diagonal(prec, axis1=1, axis2=2)).sum(axis=1)
        for comp, c in enumerate(params.component_class):
            j = slot[c]
            slot[c] += 1
            weight[c, j] = inv_scale[:, None] * prec[comp]
            offset[c, j] = (shift + params.means[comp]) @ prec[comp]
            with np.errstate(divide='ignore'):
                const[c, j] = math.log(params.weights[comp]) if params.weights[comp] > 0 else -np.inf
            const[c, j] += log_det[comp] - 0.5 * d * _LOG_2PI
        self.n_classes, self.m, self.d = n_classes, m, d
        # (d, C*m*d): one matrix product evaluates every component of every class.
        self.matrix = np.ascontiguousarray(weight.transpose(2, 0, 1, 3).reshape(d, n_classes * m * d))
        self.offset = offset.reshape(-1)
        self.const = const
        # The standardisation's Jacobian, the same for every class: only log_likelihood needs it.
        self.log_jacobian = -float(np.log(params.feature_scale).sum())
        self.uniform = np.full(n_classes, -math.log(n_classes))

    def class_log_likelihood(self, X: np.ndarray) -> np.ndarray:
        """(n, C) log p(x | c), up to the shared Jacobian; NaN rows where x is not finite."""
        y = X @ self.matrix - self.offset
        maha = np.einsum('nj,nj->n', y.reshape(-1, self.d), y.reshape(-1, self.d))
        logp = self.const[None] - 0.5 * maha.reshape(X.shape[0], self.n_classes, self.m)
        top = logp.max(axis=2)
        safe = np.where(np.isfinite(top), top, 0.0)
        with np.errstate(divide='ignore', invalid='ignore', over='ignore'):
            return safe + np.log(np.exp(logp - safe[..., None]).sum(axis=2))

    def log_posterior_batch(self, X: np.ndarray) -> np.ndarray:
        ll = self.class_log_likelihood(X)
        top = ll.max(axis=1, keepdims=True)
        ok = np.isfinite(top[:, 0])
        out = np.tile(self.uniform, (X.shape[0], 1))
        if ok.any():
            shifted = ll[ok] - top[ok]
            out[ok] = shifted - np.log(np.exp(shifted).sum(axis=1, keepdims=True))
        return out

    def log_posterior_one(self, x: np.ndarray) -> np.ndarray:
        y = x @ self.matrix - self.offset
        y *= y
        logp = self.const - 0.5 * y.reshape(self.n_classes, self.m, self.d).sum(axis=2)
        top = logp.max(axis=1)
        ll = top + np.log(np.exp(logp - top[:, None]).sum(axis=1))
        best = ll.max()
        if not math.isfinite(best):  # x not finite or astronomically far from every class
            return self.uniform.copy()
        ll -= best
        ll -= math.log(np.exp(ll).sum())
        return ll


class GestureMixtures:
    """Fitted patch gesture mixtures: one Gaussian mixture per class, uniform prior, log-domain posterior.

    What a node evaluates, with numpy only: made from stored parameters (:meth:`from_params`, as
    :func:`~.model_io.load_model` does) or fitted by :class:`touch_lab.patch.training.PatchGestureClassifier`
    (scikit-learn's EM), which is this class with ``fit``.

    Args:
        threshold: posterior a class must reach to be recognised (sympartner2018 6.3: 0.99).
        covariance_type: what EM fitted ('full', 'diag', 'tied' or 'spherical'); the parameters
            always hold full covariances, so it only describes the model.

    Attributes (once fitted or loaded):
        classes_: (C,) class names. n_features_in_: 12 for the patch features.
        n_components_: (C,) components per class. reg_covar_: (C,) regularisation used per class
            (NaN when loaded: the file does not keep it).
        params_: :class:`GaussianMixtureParams`, what a model file stores.
    """

    def __init__(self, threshold: float = 0.99, covariance_type: str = 'full') -> None:
        self.threshold = threshold
        self.covariance_type = covariance_type

    @classmethod
    def from_params(cls, params: GaussianMixtureParams, threshold: float = 0.99, **kwargs) -> GestureMixtures:
        """Fitted mixtures from stored parameters (see model_io); ``kwargs`` are ``__init__``'s."""
        model = cls(threshold=threshold, **kwargs)
        model._install(params, n_components=np.bincount(params.component_class, minlength=len(params.classes)),
                       reg_covar=np.full(len(params.classes), np.nan))
        return model

    def _install(self, params: GaussianMixtureParams, n_components: np.ndarray, reg_covar: np.ndarray) -> None:
        self.classes_ = np.array(params.classes)
        self.n_features_in_ = params.means.shape[1]
        self.n_components_ = np.asarray(n_components)
        self.reg_covar_ = np.asarray(reg_covar, dtype=np.float64)
        self.params_ = params
        self._evaluator = _Evaluator(params)

    # ------------------------------------------------------------------ inference
    def log_posterior(self, x: np.ndarray) -> np.ndarray:
        """log p(c | x) of one feature vector, the per-frame path (no validation beyond shape).

        Args:
            x: (d,) float64 features.

        Returns:
            (C,) float64 log posteriors (logsumexp = 0). A non-finite ``x`` gives the uniform
            posterior (no evidence) rather than NaN.
        """
        try:
            evaluator = self._evaluator
        except AttributeError:
            raise NotFittedError(f'this {type(self).__name__} is not fitted yet; call fit(X, y) or load a '
                                 'model file first') from None
        return evaluator.log_posterior_one(x)

    def _check_batch(self, X: np.ndarray, allow_nan: bool) -> np.ndarray:
        if not hasattr(self, 'params_'):
            raise NotFittedError(f'this {type(self).__name__} is not fitted yet; call fit(X, y) or load a '
                                 'model file first')
        X = np.asarray(X, dtype=np.float64)
        if X.ndim != 2:
            raise ValueError(f'expected a 2D array of feature rows; got shape {X.shape}')
        if not allow_nan and not np.isfinite(X).all():
            raise ValueError('Input X contains NaN or infinity')
        if X.shape[1] != self.n_features_in_:
            raise ValueError(f'X has {X.shape[1]} features; this classifier was fitted on {self.n_features_in_}')
        return X

    def predict_log_proba(self, X: np.ndarray) -> np.ndarray:
        """(n, C) log posteriors of a batch; rows with non-finite features are uniform."""
        X = self._check_batch(X, allow_nan=True)
        out = np.empty((X.shape[0], len(self.classes_)))
        for start in range(0, X.shape[0], 4096):  # bounds the (n, K*d) temporary
            out[start:start + 4096] = self._evaluator.log_posterior_batch(X[start:start + 4096])
        return out

    def predict_proba(self, X: np.ndarray) -> np.ndarray:
        """(n, C) posteriors p(c | x) of a batch."""
        return np.exp(self.predict_log_proba(X))

    def predict(self, X: np.ndarray) -> np.ndarray:
        """(n,) most probable class of each row (no threshold; see :meth:`recognise`)."""
        log_proba = self.predict_log_proba(X)
        return self.classes_[np.argmax(log_proba, axis=1)]

    def recognise(self, X: np.ndarray) -> np.ndarray:
        """(n,) class index whose posterior reaches ``threshold``, else ``NOT_RECOGNISED`` (-1)."""
        return decide(self.predict_log_proba(X), self.threshold)

    def log_likelihood(self, X: np.ndarray) -> np.ndarray:
        """(n, C) log p(x | c) in the units of the features."""
        X = self._check_batch(X, allow_nan=False)
        ev = self._evaluator
        return ev.class_log_likelihood(X) + ev.log_jacobian


def decide(log_posteriors: np.ndarray, threshold: float) -> np.ndarray:
    """(n,) index of the class whose posterior reaches ``threshold``, else -1.

    >>> decide(np.log([[0.995, 0.005], [0.6, 0.4]]), 0.99)
    array([ 0, -1])
    """
    lp = np.asarray(log_posteriors)
    best = np.argmax(lp, axis=1)
    ok = lp[np.arange(len(lp)), best] >= math.log(threshold)
    return np.where(ok, best, NOT_RECOGNISED)


@dataclass(frozen=True)
class Detection:
    """A gesture event (one /touch/gesture message).

    Attributes:
        gesture: class name. index: class index. probability: its posterior in [0, 1].
        posteriors: (C,) posteriors of all classes. frame: frame number of the decision.
        time_s: time of the decision, s. latency_s: time since the first active frame in the
            window, s (what GestureEvent.latency_s carries).
    """

    gesture: str
    index: int
    probability: float
    posteriors: np.ndarray
    frame: int
    time_s: float
    latency_s: float


class EventDetector:
    """The event rule of sympartner2018 6.2, per frame.

    An event is sent when one class's posterior reaches ``threshold`` for ``dwell`` consecutive
    frames and the class differs from the current one; never from a window without an active
    frame. The current class is forgotten when its posterior falls below ``release`` (hysteresis;
    ``release == threshold`` is the paper's rule) or the window holds no active frame.

    Args:
        classes: class names, in the classifier's order.
        threshold: posterior needed for an event (paper: 0.99).
        release: posterior below which the current class is forgotten (default 0.9).
        rate_hz: frame rate, to turn frame counts into seconds (patch: 20 Hz).
        dwell: consecutive frames above the threshold before an event (paper: 1).
    """

    def __init__(self, classes: tuple[str, ...] | list[str], threshold: float = 0.99, release: float = 0.9,
                 rate_hz: float = 20.0, dwell: int = 1) -> None:
        if not 0.0 < threshold <= 1.0:
            raise ValueError(f'threshold must be in (0, 1]; got {threshold!r}')
        if not 0.0 <= release <= threshold:
            raise ValueError(f'release must be in [0, threshold={threshold}]; got {release!r}')
        if not rate_hz > 0:
            raise ValueError(f'rate_hz must be > 0; got {rate_hz!r}')
        self.classes = tuple(classes)
        self.threshold = threshold
        self.release = release
        if int(dwell) != dwell or dwell < 1:
            raise ValueError(f'dwell must be a positive number of frames; got {dwell!r}')
        self.rate_hz = float(rate_hz)
        self.dwell = int(dwell)
        self._candidate = -1
        self._run = 0
        self._log_threshold = math.log(threshold)
        self._log_release = math.log(release) if release > 0 else -math.inf
        self.current: int | None = None
        self.frame = -1
        self.events = 0

    def reset(self) -> None:
        self.current = None
        self.frame = -1
        self._candidate, self._run = -1, 0

    def update(self, log_posterior: np.ndarray, onset_age: int | None, time_s: float | None = None) -> Detection | None:
        """Feed one frame's (C,) log posterior; return the event it triggers, if any.

        Args:
            log_posterior: (C,) log p(c | window).
            onset_age: frames from the first active frame in the window to this frame
                (``WindowFeatures.onset_age``), or None when the window holds no contact.
            time_s: time of the frame, s (default: frame number / rate).
        """
        self.frame += 1
        if onset_age is None:
            self.current = None
            self._run = 0
            return None
        best = int(np.argmax(log_posterior))
        lp_best = float(log_posterior[best])
        if lp_best >= self._log_threshold:
            self._run = self._run + 1 if best == self._candidate else 1
            self._candidate = best
        else:
            self._run = 0
        if self._run >= self.dwell and best != self.current:
            self.current = best
            self.events += 1
            t = self.frame / self.rate_hz if time_s is None else time_s
            post = np.exp(log_posterior)
            return Detection(self.classes[best], best, float(post[best]), post, self.frame, t,
                             onset_age / self.rate_hz)
        if self.current is not None and float(log_posterior[self.current]) < self._log_release:
            self.current = None
        return None
