"""Training the bear's eight-subtype model (knight2009 Table I) with scikit-learn.

:class:`SubtypeClassifier` is :class:`touch_gestures.bear.subtype_model.SubtypeModel` (the
fitted model the node evaluates with numpy) with ``fit`` and scikit-learn's estimator API:
multinomial logistic regression (scikit-learn's ``LogisticRegression``, balanced class weights)
on the standardised design of :func:`~touch_gestures.bear.subtype_model.design_names`. It lives
in the lab so that the node's process never loads scikit-learn.

>>> from touch_gestures.bear.features import FEATURE_NAMES
>>> rng = np.random.default_rng(0)
>>> X = rng.random((60, len(FEATURE_NAMES)), dtype=np.float32)
>>> y = np.where(X[:, 0] < 0.5, 'none', 'hold')
>>> model = SubtypeClassifier().fit(X, y)
>>> float(np.mean(model.predict(X) == y)) > 0.9
True
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator, ClassifierMixin
from sklearn.linear_model import LogisticRegression

from touch_gestures.bear.subtype import check_feature_table
from touch_gestures.bear.subtype_labels import SUBTYPES, subtype_index
from touch_gestures.bear.subtype_model import SubtypeModel, _Design

__all__ = ['SubtypeClassifier']


class SubtypeClassifier(ClassifierMixin, BaseEstimator, SubtypeModel):
    """A :class:`~touch_gestures.bear.subtype_model.SubtypeModel` that trains (same arguments)."""

    def fit(self, X, y) -> SubtypeClassifier:
        """Train on ``X`` ((n, len(FEATURE_NAMES)) feature rows) and ``y`` (subtype names or codes)."""
        X = check_feature_table(X)
        y = np.asarray(y)
        if y.shape != (X.shape[0],):
            raise ValueError(f'y must have shape ({X.shape[0]},); got {y.shape}')
        names = np.array([SUBTYPES[int(v)] if not isinstance(v, str) else SUBTYPES[subtype_index(v)] for v in y])
        classes = [s for s in SUBTYPES if s in set(names)]
        if len(classes) < 2:
            raise ValueError(f'need at least two subtypes to train; got only {classes}')
        Z = _Design(self.design_).transform(X)
        mean = Z.mean(axis=0)
        scale = Z.std(axis=0)
        scale = np.where(scale > 1e-6, scale, 1.0)   # a constant feature: leave it unscaled, not divided by 0
        lr = LogisticRegression(C=self.C, class_weight=self.class_weight, max_iter=self.max_iter)
        lr.fit((Z - mean) / scale, names)
        coef, intercept = lr.coef_, lr.intercept_
        if len(classes) == 2:   # scikit-learn stores one row for two classes: the logit of the second
            coef = np.stack([-0.5 * coef[0], 0.5 * coef[0]])
            intercept = np.array([-0.5 * intercept[0], 0.5 * intercept[0]])
        order = [list(lr.classes_).index(c) for c in classes]
        coef, intercept = coef[order], intercept[order]
        self._set(classes, mean, scale, coef, intercept)
        return self
