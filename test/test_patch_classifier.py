"""One Gaussian mixture per class, direct log-domain posterior, and the event rule (sympartner2018 6.2)."""

import math
import warnings

import numpy as np
import pytest
from doctest_testing import check_doctests
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import logsumexp
from sklearn.base import clone

from touch_gestures.estimator import NotFittedError
from touch_gestures.patch import classifier as classifier_module
from touch_gestures.patch.classifier import NOT_RECOGNISED, EventDetector, decide
from touch_lab.patch.training import PatchGestureClassifier


def blobs(seed=0, n=300, d=12, classes=('push', 'slap', 'stroke', 'tickle')):
    rng = np.random.default_rng(seed)
    X = np.concatenate([rng.normal(i * 1.5, 1.0 + 0.3 * i, (n, d)) for i in range(len(classes))])
    y = np.repeat(classes, n)
    return X, y


@pytest.fixture(scope='module')
def fitted():
    X, y = blobs()
    return PatchGestureClassifier(n_components=3).fit(X, y), X, y


def sklearn_log_posterior(clf, X):
    Z = (X - clf.params_.feature_mean) / clf.params_.feature_scale
    ll = np.stack([gm.score_samples(Z) for gm in clf.mixtures_], axis=1)
    return ll - logsumexp(ll, axis=1, keepdims=True)


def test_direct_evaluation_equals_sklearn(fitted):
    clf, X, _ = fitted
    ref = sklearn_log_posterior(clf, X[::7])
    np.testing.assert_allclose(clf.predict_log_proba(X[::7]), ref, atol=1e-9)
    one = np.array([clf.log_posterior(x) for x in X[::7]])
    np.testing.assert_allclose(one, ref, atol=1e-9)


@pytest.mark.parametrize('covariance_type', ['full', 'diag', 'tied', 'spherical'])
def test_every_covariance_type_matches_sklearn(covariance_type):
    X, y = blobs(seed=1, n=150)
    clf = PatchGestureClassifier(n_components=2, covariance_type=covariance_type).fit(X, y)
    np.testing.assert_allclose(clf.predict_log_proba(X[::5]), sklearn_log_posterior(clf, X[::5]), atol=1e-9)


def test_log_likelihood_in_feature_units(fitted):
    clf, X, _ = fitted
    Z = (X[:20] - clf.params_.feature_mean) / clf.params_.feature_scale
    ref = clf.mixtures_[0].score_samples(Z) - np.log(clf.params_.feature_scale).sum()
    np.testing.assert_allclose(clf.log_likelihood(X[:20])[:, 0], ref, atol=1e-9)


def test_posteriors_are_normalised_and_predict_works(fitted):
    clf, X, y = fitted
    proba = clf.predict_proba(X)
    np.testing.assert_allclose(proba.sum(axis=1), 1.0, atol=1e-12)
    assert (clf.predict(X) == y).mean() > 0.8
    rec = clf.recognise(X)
    assert set(np.unique(rec)) <= {NOT_RECOGNISED, 0, 1, 2, 3}


def test_a_class_with_fewer_frames_than_components():
    X, y = blobs(n=200, classes=('push', 'slap'))
    X = np.concatenate([X, np.full((2, 12), 9.0), np.full((1, 12), 9.5)])
    y = np.concatenate([y, ['tickle'] * 3])
    clf = PatchGestureClassifier(n_components=5).fit(X, y)
    assert clf.n_components_.tolist() == [5, 5, 2]  # two distinct frames -> two components
    assert np.all(np.isfinite(clf.predict_log_proba(X)))
    one = PatchGestureClassifier(n_components=5).fit(np.concatenate([X[:50], X[-1:]]), ['a'] * 50 + ['b'])
    assert one.n_components_.tolist() == [5, 1]


def test_constant_and_collinear_features_give_singular_covariances_that_are_regularised():
    rng = np.random.default_rng(0)
    base = rng.normal(size=(400, 1))
    X = np.hstack([base, 2 * base, np.zeros((400, 1)), np.full((400, 1), 7.0), rng.normal(size=(400, 8))])
    y = np.repeat(['a', 'b'], 200)
    X[200:, 4:] += 3.0
    # silence: many identical rows in both classes, as the paper's training data has
    X[:100] = X[0]
    X[200:300] = X[0]
    with warnings.catch_warnings():
        warnings.simplefilter('error')  # no ConvergenceWarning leaks to the user
        clf = PatchGestureClassifier(n_components=5).fit(X, y)
    lp = clf.predict_log_proba(X)
    assert np.all(np.isfinite(lp))
    # identical silence rows in both classes: the posterior is balanced, not a confident class
    assert np.exp(lp[0]).max() < 0.9


def test_far_away_features_do_not_underflow(fitted):
    clf, X, _ = fitted
    for scale in (1e3, 1e8, 1e150):
        x = X[0] + scale
        lp = clf.log_posterior(x)
        assert np.all(np.isfinite(lp)) and logsumexp(lp) == pytest.approx(0.0, abs=1e-9)
        assert np.all(np.isfinite(clf.predict_log_proba(x[None])))


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1e6, 1e6), min_size=12, max_size=12))
def test_posterior_is_a_distribution_for_any_finite_input(values):
    clf = test_posterior_is_a_distribution_for_any_finite_input.clf
    lp = clf.log_posterior(np.array(values))
    assert np.all(np.isfinite(lp)) and np.all(lp <= 1e-12)
    assert math.isclose(np.exp(lp).sum(), 1.0, rel_tol=1e-9)


test_posterior_is_a_distribution_for_any_finite_input.clf = PatchGestureClassifier(n_components=2).fit(
    *blobs(seed=4, n=100))


def test_nan_features_give_the_uniform_posterior(fitted):
    clf, X, _ = fitted
    x = X[0].copy()
    x[3] = np.nan
    np.testing.assert_allclose(clf.log_posterior(x), np.log(np.full(4, 0.25)))
    np.testing.assert_allclose(clf.predict_proba(x[None]), np.full((1, 4), 0.25))


def test_fit_rejects_bad_input():
    X, y = blobs(n=20)
    with pytest.raises(ValueError, match='two classes'):
        PatchGestureClassifier().fit(X[:20], y[:20])
    Xn = X.copy()
    Xn[0, 0] = np.nan
    with pytest.raises(ValueError, match='NaN'):
        PatchGestureClassifier().fit(Xn, y)
    with pytest.raises(ValueError, match='n_components'):
        PatchGestureClassifier(n_components=0).fit(X, y)
    with pytest.raises(ValueError, match='threshold'):
        PatchGestureClassifier(threshold=1.5).fit(X, y)
    with pytest.raises(ValueError, match='reg_covar'):
        PatchGestureClassifier(reg_covar=0).fit(X, y)


def test_not_fitted_and_wrong_width(fitted):
    with pytest.raises(NotFittedError):
        PatchGestureClassifier().predict(np.zeros((1, 12)))
    with pytest.raises(NotFittedError):
        PatchGestureClassifier().log_posterior(np.zeros(12))
    clf, _, _ = fitted
    with pytest.raises(ValueError, match='11 features'):
        clf.predict(np.zeros((1, 11)))


def test_sklearn_estimator_api(fitted):
    clf, _, _ = fitted
    params = clf.get_params()
    assert params['n_components'] == 3 and params['threshold'] == 0.99
    fresh = clone(clf)
    assert not hasattr(fresh, 'params_')


def test_decide_thresholds_posteriors():
    lp = np.log([[0.995, 0.005], [0.6, 0.4], [0.001, 0.999]])
    assert decide(lp, 0.99).tolist() == [0, NOT_RECOGNISED, 1]


# ---------------------------------------------------------------------- event rule
def post(*p):
    return np.log(np.array(p, dtype=np.float64))


def test_event_when_threshold_passed_and_class_changes():
    det = EventDetector(['a', 'b'], threshold=0.99, release=0.9, rate_hz=20.0)
    assert det.update(post(0.5, 0.5), onset_age=0) is None
    hit = det.update(post(0.995, 0.005), onset_age=4)
    assert hit.gesture == 'a' and hit.index == 0 and hit.latency_s == pytest.approx(0.2)
    assert hit.probability == pytest.approx(0.995) and hit.frame == 1
    assert det.update(post(0.999, 0.001), onset_age=5) is None      # same class: no new event
    assert det.update(post(0.95, 0.05), onset_age=6) is None        # above release: still current
    assert det.update(post(0.995, 0.005), onset_age=7) is None
    assert det.update(post(0.001, 0.999), onset_age=8).gesture == 'b'  # class changed


def test_release_and_idle_window_allow_the_same_class_again():
    det = EventDetector(['a', 'b'], threshold=0.99, release=0.9)
    assert det.update(post(0.995, 0.005), 0) is not None
    assert det.update(post(0.6, 0.4), 1) is None                     # below release: forgotten
    assert det.update(post(0.995, 0.005), 2) is not None
    assert det.update(post(0.995, 0.005), None) is None              # nothing in the window: no event
    assert det.update(post(0.995, 0.005), 0) is not None             # a new touch: reported again


def test_dwell_needs_consecutive_frames():
    det = EventDetector(['a', 'b'], threshold=0.99, dwell=3)
    assert det.update(post(0.995, 0.005), 0) is None
    assert det.update(post(0.005, 0.995), 1) is None   # another class resets the run
    assert det.update(post(0.005, 0.995), 2) is None
    assert det.update(post(0.005, 0.995), 3).gesture == 'b'


def test_event_detector_rejects_bad_settings():
    with pytest.raises(ValueError, match='threshold'):
        EventDetector(['a'], threshold=0)
    with pytest.raises(ValueError, match='release'):
        EventDetector(['a'], threshold=0.9, release=0.95)
    with pytest.raises(ValueError, match='dwell'):
        EventDetector(['a'], dwell=0)


def test_doctests():
    check_doctests(classifier_module)
