"""The nodes' numpy evaluation of the shipped fitted models equals scikit-learn's, on random inputs.

The nodes evaluate fitted models with numpy alone (touch_gestures.patch.classifier,
touch_gestures.bear.subtype_model); scikit-learn fits them in the lab. Here scikit-learn's own
estimators are given the shipped parameters (config/*.npz) and evaluate the same inputs.

Tolerances come from the arithmetic, not from trials (Higham, Accuracy and Stability of
Numerical Algorithms, 3.1 and 3.5: a dot product of n terms carries an error of at most
``n * u * sum |terms|``, u the unit roundoff):

- patch (float64 throughout): each component's Mahalanobis term ``|y|^2``, ``y = U^T (z - mu)``,
  is computed by both sides from the same parameters in different orders (ours folds the
  standardisation into the matrix); each side's ``y`` is within ``(d + 2) u a`` of the exact one,
  ``a`` the sum of the absolute terms, and the precision factor ``U`` itself within ``d kappa u``
  relative (kappa: the covariance's condition number; numpy's solve against scipy's triangular
  solve). So ``|y|^2`` differs by at most ``4 (2 d + 2 + d kappa) u (|y| + a)^2``, the log
  likelihood by half of it plus a few u of its size, and a log posterior by twice that.
- bear (the node's weights are float32 on purpose, as the file stores them): a logit is a dot
  product of f + 1 float32 terms after folding the standardisation in, within
  ``(f + 4) u32 (|x| |w| + |coef| |mean / scale| + |intercept|)`` of scikit-learn's float64 one;
  a log probability differs by at most twice the largest logit error.

Predictions must be identical wherever the decision is not within those tolerances of a tie.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.linalg import cholesky, solve_triangular
from sklearn.linear_model import LogisticRegression
from sklearn.mixture import GaussianMixture

from touch_gestures.bear.features import FEATURE_NAMES as BEAR_FEATURES
from touch_gestures.bear.subtype_model import SubtypeModel, _transform
from touch_gestures.patch.classifier import decide
from touch_gestures.patch.model_io import load_model
from touch_graph.paths import share_file

U64 = np.finfo(np.float64).eps / 2
U32 = np.finfo(np.float32).eps / 2


# ---------------------------------------------------------------------------------------------------- patch
@pytest.fixture(scope='module')
def patch():
    model = load_model(share_file('config', 'patch_gestures.npz'))
    p = model.classifier.params_
    mixtures, factors = [], []
    for c in range(len(p.classes)):
        k = np.flatnonzero(p.component_class == c)
        gm = GaussianMixture(n_components=len(k), covariance_type='full')
        gm.weights_, gm.means_, gm.covariances_ = p.weights[k], p.means[k], p.covariances[k]
        # scikit-learn's precision factors, computed as scikit-learn computes them
        gm.precisions_cholesky_ = np.stack([solve_triangular(cholesky(s, lower=True), np.eye(len(s)), lower=True).T
                                            for s in p.covariances[k]])
        mixtures.append(gm)
        factors += list(gm.precisions_cholesky_)
    return model.classifier, mixtures, np.stack(factors)


def patch_inputs(params, rng) -> np.ndarray:
    """Feature rows around the training data (1 sd) out to far from it (100 sd), and exactly at the means."""
    d = len(params.feature_mean)
    spread = np.repeat([0.3, 1.0, 3.0, 10.0, 100.0], 400)[:, None]
    z = rng.standard_normal((len(spread), d)) * spread
    z = np.concatenate([z, params.means])
    return params.feature_mean + z * params.feature_scale


def patch_tolerance(params, factors, X) -> np.ndarray:
    """(n,) bound on |our log posterior - scikit-learn's| (module doc)."""
    d = X.shape[1]
    kappa = np.linalg.cond(params.covariances)                                   # (K,)
    W = factors / params.feature_scale[None, :, None]                            # (K, d, d): x -> y
    offset = np.einsum('kd,kde->ke', params.feature_mean / params.feature_scale + params.means, factors)
    y = np.einsum('nd,kde->nke', X, W) - offset[None]                            # (n, K, d)
    a = np.einsum('nd,kde->nke', np.abs(X), np.abs(W)) + np.abs(offset)[None]
    norm_y, norm_a = np.linalg.norm(y, axis=2), np.linalg.norm(a, axis=2)
    maha = 4 * (2 * d + 2 + d * kappa[None]) * U64 * (norm_y + norm_a) ** 2      # (n, K)
    size = 0.5 * norm_y.max(axis=1) ** 2 + np.abs(np.log(params.weights)).max() + d * np.log(
        params.feature_scale.max() + 1.0) + 10 * d
    return 2 * (0.5 * maha.max(axis=1) + 8 * d * U64 * size)


def test_patch_posteriors_equal_scikit_learn_on_the_shipped_model(patch):
    model, mixtures, factors = patch
    p = model.params_
    X = patch_inputs(p, np.random.default_rng(0))
    Z = (X - p.feature_mean) / p.feature_scale
    ll = np.stack([gm.score_samples(Z) for gm in mixtures], axis=1)              # log p(z | c)
    theirs = ll - np.logaddexp.reduce(ll, axis=1, keepdims=True)
    ours = model.predict_log_proba(X)
    one_by_one = np.stack([model.log_posterior(x) for x in X])                   # the node's per-frame path
    tol = patch_tolerance(p, factors, X)[:, None]
    finite = np.isfinite(theirs).all(axis=1)
    assert finite.mean() > 0.9
    assert (np.abs(ours - theirs)[finite] <= tol[finite]).all()
    assert (np.abs(one_by_one - theirs)[finite] <= tol[finite]).all()
    # Identical predictions wherever no tie lies within the tolerance.
    top2 = np.sort(theirs, axis=1)[:, -2:]
    clear = finite & (top2[:, 1] - top2[:, 0] > 2 * tol[:, 0])
    assert clear.mean() > 0.9
    np.testing.assert_array_equal(ours.argmax(axis=1)[clear], theirs.argmax(axis=1)[clear])
    away = clear & (np.abs(top2[:, 1] - np.log(model.threshold)) > 2 * tol[:, 0])
    np.testing.assert_array_equal(model.recognise(X)[away], decide(theirs, model.threshold)[away])


def test_patch_log_likelihood_equals_scikit_learn_in_feature_units(patch):
    model, mixtures, factors = patch
    p = model.params_
    X = patch_inputs(p, np.random.default_rng(1))
    Z = (X - p.feature_mean) / p.feature_scale
    theirs = np.stack([gm.score_samples(Z) for gm in mixtures], axis=1) - np.log(p.feature_scale).sum()
    tol = patch_tolerance(p, factors, X)[:, None]
    assert (np.abs(model.log_likelihood(X) - theirs) <= tol).all()


# ---------------------------------------------------------------------------------------------------- bear
@pytest.fixture(scope='module')
def bear():
    model = SubtypeModel.load(share_file('config', 'bear_subtype_model.npz'))
    reference = LogisticRegression()
    reference.classes_ = model.classes_
    reference.coef_ = model.coef_.astype(np.float64)
    reference.intercept_ = model.intercept_.astype(np.float64)
    return model, reference


def bear_inputs(rng) -> np.ndarray:
    """Non-negative feature rows over four orders of magnitude per column, an untouched sensor's zeros."""
    n, f = 3000, len(BEAR_FEATURES)
    X = rng.exponential(1.0, (n, f)) * 10.0 ** rng.uniform(-2, 2, (n, f))
    return np.concatenate([X, np.zeros((1, f))]).astype(np.float32)


def test_bear_probabilities_equal_scikit_learn_on_the_shipped_model(bear):
    model, reference = bear
    X = bear_inputs(np.random.default_rng(2))
    design = _transform(X, model.relative, model.design_).astype(np.float64)
    standard = (design - model.mean_) / model.scale_
    logits = reference.decision_function(standard)                              # scikit-learn's, float64
    theirs = logits - np.logaddexp.reduce(logits, axis=1, keepdims=True)         # log predict_proba, no underflow
    np.testing.assert_allclose(np.exp(theirs), reference.predict_proba(standard), rtol=1e-12, atol=1e-300)
    ours = model.predict_log_proba(X)
    w = np.abs(model.coef_ / model.scale_[None])                                 # (C, f)
    size = np.abs(design) @ w.T + np.abs(model.coef_) @ np.abs(model.mean_ / model.scale_) + np.abs(model.intercept_)
    logit_tol = (design.shape[1] + 4) * U32 * size.max(axis=1, keepdims=True)    # (n, 1)
    assert (np.abs(ours - theirs) <= 2 * logit_tol).all()
    top2 = np.sort(theirs, axis=1)[:, -2:]
    clear = top2[:, 1] - top2[:, 0] > 4 * logit_tol[:, 0]
    assert clear.mean() > 0.9
    np.testing.assert_array_equal(model.predict(X)[clear], reference.classes_[theirs.argmax(axis=1)][clear])
    codes, confidence = model.predict_codes(X)
    np.testing.assert_array_equal(codes[clear], model._codes[theirs.argmax(axis=1)][clear])
    np.testing.assert_allclose(confidence, np.exp(theirs.max(axis=1)), rtol=0, atol=float(4 * logit_tol.max()) + U32)
