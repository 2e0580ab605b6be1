"""How doubtful a touch is for the class a recogniser names: the one score a calibrated acceptance limits.

The score is the **odds that the touch fires no right command** (it is a touch that is no gesture, or a
gesture of another class), by a logistic model on evidence the decision already has, the (C,) distances of
the touch to each class and the classes' scales (how far a new person's gesture of a class lies, from the
codebook's own leave-one-person-out reading; :mod:`touch_lab.skin.acceptance` fits the model and its limit):

- ``distance``: log of the distance to the named class over that class's scale (far from the class);
- ``runner_up``: log of the distance over the runner-up class's (1 when two classes are equally close);
- ``runner_up_distance``: log of the runner-up's distance over the runner-up's scale (near a second class
  too: a shape between classes);
- ``crowd``: log of the distance over the median distance to the other classes (named class hardly nearer
  than any other: a shape like none of them).

``odds = exp(w0 + w . features)``. A codebook calibrated before the model existed has no weights: its score
is :data:`PRODUCT_WEIGHTS`, the distance over the scale times the ratio to the runner-up. The score is 0 for
an exact match and inf where the runner-up is nearer than the named class or a value is NaN (never accepted).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ['DOUBT_FEATURES', 'PRODUCT_WEIGHTS', 'doubt', 'doubt_features', 'scores_of']

#: The features of :func:`doubt_features`, in column order (module doc).
DOUBT_FEATURES = ('distance', 'runner_up', 'runner_up_distance', 'crowd')
#: The weights (intercept first) of the score of a calibration without a model: distance / scale x distance /
#: runner-up's distance.
PRODUCT_WEIGHTS = (0.0, 1.0, 1.0, 0.0, 0.0)
_TINY = float(np.finfo(np.float64).tiny)
#: Features are clipped to +-this (a log ratio: e^50 is farther than any distance means).
FEATURE_BOUND = 50.0


def doubt_features(distances: np.ndarray, named: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The features of N touches (module doc).

    Args:
        distances: (N, C) each touch's distance to each class (inf: a class the codebook lacks).
        named: (N,) int, the class named for each touch.
        scales: (C,) float > 0, each class's scale.

    Returns:
        (N, 4) float64 features (:data:`DOUBT_FEATURES`), and (N,) bool: the touch can be accepted at all (the
        runner-up is no nearer, no distance is NaN). Rows with a zero distance are all -inf (an exact match);
        the others are clipped to +-:data:`FEATURE_BOUND`.
    """
    d = np.asarray(distances, dtype=np.float64)
    d = d.reshape(len(named), d.shape[-1] if d.ndim else 0)
    named = np.asarray(named, dtype=np.intp)
    scales = np.asarray(scales, dtype=np.float64)
    idx = np.arange(len(named))
    d1 = d[idx, named]
    others = d.copy()
    others[idx, named] = np.inf
    if d.shape[1] > 1:
        runner = np.argmin(others, axis=1)
        d2 = others[idx, runner]
        crowd = np.median(_others(d, named), axis=1)
    else:
        runner = np.zeros(len(named), dtype=np.intp)
        d2 = crowd = np.full(len(named), np.inf)
    usable = ~np.isnan(d).any(axis=1) & (d2 >= d1)
    with np.errstate(divide='ignore', invalid='ignore'):
        log_d1 = np.log(np.maximum(d1, _TINY))
        log_d2 = np.log(np.maximum(d2, _TINY))
        out = np.column_stack([log_d1 - np.log(scales[named]), log_d1 - log_d2, log_d2 - np.log(scales[runner]),
                               log_d1 - np.log(np.maximum(crowd, _TINY))])
    out = np.clip(out, -FEATURE_BOUND, FEATURE_BOUND)   # no runner-up (inf): as far as a feature goes
    out[d1 == 0] = -np.inf
    return out, usable


def _others(d: np.ndarray, named: np.ndarray) -> np.ndarray:
    """(N, C-1) each row of ``d`` without its named column."""
    keep = np.ones(d.shape, dtype=bool)
    keep[np.arange(len(named)), named] = False
    return d[keep].reshape(len(named), d.shape[1] - 1)


def doubt(distances: Sequence[float] | np.ndarray, best: int, scales: Sequence[float] | np.ndarray,
          weights: Sequence[float] | np.ndarray) -> float:
    """The score of one touch: ``distances`` (C,) to each class, ``best`` the named class, ``scales`` (C,),
    ``weights`` (5,) intercept first (module doc). Plain Python over the C numbers: one call per touch on the
    robot, where numpy's per-call overhead would cost more than the arithmetic (the same as :func:`scores_of`
    of :func:`doubt_features`)."""
    d = distances.tolist() if isinstance(distances, np.ndarray) else [float(v) for v in distances]
    if any(v != v for v in d):   # NaN
        return math.inf
    d1 = d[best]
    others = d[:best] + d[best + 1:]
    if others:
        d2 = min(others)
        runner = others.index(d2)
        runner += runner >= best   # back to an index of d
        ranked = sorted(others)
        half = len(ranked) // 2
        crowd = ranked[half] if len(ranked) % 2 else 0.5 * (ranked[half - 1] + ranked[half])
    else:
        d2 = crowd = math.inf
        runner = 0
    if not d2 >= d1:
        return math.inf
    if d1 == 0:
        return 0.0
    w = weights
    log_d1 = math.log(d1)
    log_d2 = math.log(max(d2, _TINY))
    z = (w[0] + w[1] * _clip(log_d1 - math.log(float(scales[best]))) + w[2] * _clip(log_d1 - log_d2)
         + w[3] * _clip(log_d2 - math.log(float(scales[runner])))
         + w[4] * _clip(log_d1 - math.log(max(crowd, _TINY))))
    if math.isnan(z):
        return math.inf
    return math.exp(z) if z < 709.0 else math.inf


def _clip(x: float) -> float:
    return x if math.isnan(x) else max(-FEATURE_BOUND, min(FEATURE_BOUND, x))


def scores_of(features: np.ndarray, usable: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(N,) the score of each row of :func:`doubt_features`' output: ``exp(w0 + w . features)``; inf where not
    ``usable``, 0 for an exact match."""
    w = np.asarray(weights, dtype=np.float64)
    with np.errstate(invalid='ignore', over='ignore'):
        exact = np.isneginf(features).all(axis=1)
        z = w[0] + np.where(exact[:, None], 0.0, features) @ w[1:]
        out = np.exp(z)
    out[exact] = 0.0
    out[~usable | np.isnan(out)] = math.inf
    return out
