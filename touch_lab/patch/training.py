"""Training the patch gesture mixtures (sympartner2018 6.2) with scikit-learn's EM.

Per class ``c``, ``p(f | c) = sum_k w_k N(f | mu_k, Sigma_k)`` is fitted by ``GaussianMixture`` to the
window features of every frame of its sessions. :class:`PatchGestureClassifier` is the node's
:class:`~touch_gestures.patch.classifier.GestureMixtures` with ``fit``, kept in the lab so that the node
never loads scikit-learn. A class with fewer distinct frames than components gets one component per
distinct frame; if EM fails, ``reg_covar`` is raised tenfold (up to three times), kept in ``reg_covar_``.
"""

from __future__ import annotations

import warnings

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.exceptions import ConvergenceWarning
from sklearn.mixture import GaussianMixture
from sklearn.utils.validation import check_X_y

from touch_gestures.patch.classifier import GaussianMixtureParams, GestureMixtures, precision_cholesky

__all__ = ['PatchGestureClassifier', 'full_covariances']


class PatchGestureClassifier(ClassifierMixin, BaseEstimator, GestureMixtures):
    """:class:`~touch_gestures.patch.classifier.GestureMixtures` fitted by EM: one Gaussian mixture per class.

    Args:
        n_components: mixture components per class (sympartner2018 6.3: best at 5).
        threshold: posterior a class must reach to be recognised (sympartner2018 6.3: 0.99).
        covariance_type: 'full', 'diag', 'tied' or 'spherical' (GaussianMixture's).
        reg_covar: added to covariance diagonals, in standardised units (features are scaled
            to unit variance first, so one value suits features of any scale).
        max_iter, n_init, tol: EM settings passed to GaussianMixture.
        random_state: seed for the EM initialisation.

    Attributes (after fit):
        classes_: (C,) class names. n_features_in_: 12 for the patch features.
        n_components_: (C,) components actually fitted per class.
        reg_covar_: (C,) regularisation actually used per class.
        mixtures_: the fitted GaussianMixture objects (standardised units), for reference.
        params_: :class:`GaussianMixtureParams`, what a model file stores.
    """

    def __init__(self, n_components: int = 5, threshold: float = 0.99, covariance_type: str = 'full',
                 reg_covar: float = 1e-3, max_iter: int = 200, n_init: int = 1, tol: float = 1e-3,
                 random_state: int | None = 0) -> None:
        self.n_components = n_components
        self.threshold = threshold
        self.covariance_type = covariance_type
        self.reg_covar = reg_covar
        self.max_iter = max_iter
        self.n_init = n_init
        self.tol = tol
        self.random_state = random_state

    # ------------------------------------------------------------------ fitting
    def fit(self, X: np.ndarray, y: np.ndarray) -> PatchGestureClassifier:
        """Fit one mixture per class to the frames of that class.

        Args:
            X: (n, d) float features, finite (NaN is rejected with ValueError).
            y: (n,) class labels (str or int), at least two classes.
        """
        if int(self.n_components) != self.n_components or self.n_components < 1:
            raise ValueError(f'n_components must be a positive int; got {self.n_components!r}')
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f'threshold must be a probability in (0, 1]; got {self.threshold!r}')
        if not self.reg_covar > 0:
            raise ValueError(f'reg_covar must be > 0 to keep covariances invertible; got {self.reg_covar!r}')
        X, y = check_X_y(X, y, dtype=np.float64, ensure_min_samples=1)
        classes = np.unique(y)
        if len(classes) < 2:
            raise ValueError(f'need frames of at least two classes to classify; got only {list(classes)}')
        self.n_features_in_ = X.shape[1]
        mean = X.mean(axis=0)
        scale = X.std(axis=0)
        scale[~(scale > 1e-12 * np.maximum(1.0, np.abs(mean)))] = 1.0  # constant feature: leave unscaled
        Z = (X - mean) / scale
        mixtures, n_comp, regs = [], [], []
        comp_class, weights, means, covs = [], [], [], []
        for ci, c in enumerate(classes):
            gm, reg = self._fit_class(Z[y == c])
            mixtures.append(gm)
            n_comp.append(gm.n_components)
            regs.append(reg)
            comp_class += [ci] * gm.n_components
            weights.append(gm.weights_)
            means.append(gm.means_)
            covs.append(full_covariances(gm))
        params = GaussianMixtureParams(
            classes=tuple(str(c) for c in classes), component_class=np.array(comp_class),
            weights=np.concatenate(weights), means=np.concatenate(means), covariances=np.concatenate(covs),
            feature_mean=mean, feature_scale=scale)
        self._install(params, n_components=np.array(n_comp), reg_covar=np.array(regs))
        self.classes_ = classes
        self.mixtures_ = mixtures
        return self

    def _fit_class(self, Z: np.ndarray) -> tuple[GaussianMixture, float]:
        if len(Z) == 1:  # EM needs two rows; a repeated row gives the same one-point Gaussian
            Z = np.repeat(Z, 2, axis=0)
        distinct = len(np.unique(Z, axis=0))
        n = max(1, min(int(self.n_components), distinct))
        reg = float(self.reg_covar)
        last_err: Exception | None = None
        for _ in range(4):
            gm = GaussianMixture(n_components=n, covariance_type=self.covariance_type, reg_covar=reg,
                                 max_iter=self.max_iter, n_init=self.n_init, tol=self.tol,
                                 random_state=self.random_state)
            try:
                with warnings.catch_warnings():
                    # Few distinct points or slow EM: the result is still usable; we report n_components_.
                    warnings.simplefilter('ignore', ConvergenceWarning)
                    gm.fit(Z)
                precision_cholesky(full_covariances(gm))
                return gm, reg
            except (ValueError, np.linalg.LinAlgError) as err:
                last_err = err
                reg *= 10.0
        raise ValueError(f'EM failed for a class of {len(Z)} frames even with reg_covar={reg / 10:g}: {last_err}; '
                         'use fewer components or a larger reg_covar') from last_err


def full_covariances(gm: GaussianMixture) -> np.ndarray:
    """(K, d, d) covariances of a fitted GaussianMixture of any covariance_type."""
    cov = gm.covariances_
    k, d = gm.means_.shape
    if gm.covariance_type == 'full':
        return np.array(cov, dtype=np.float64)
    if gm.covariance_type == 'tied':
        return np.repeat(cov[None], k, axis=0)
    if gm.covariance_type == 'diag':
        return np.einsum('kd,de->kde', cov, np.eye(d))
    return cov[:, None, None] * np.eye(d)[None]  # spherical
