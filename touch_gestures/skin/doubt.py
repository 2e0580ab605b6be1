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

import numpy as np

__all__ = ['DOUBT_FEATURES', 'PRODUCT_WEIGHTS', 'doubt', 'doubt_features', 'scores_of']

#: The features of :func:`doubt_features`, in column order (module doc).
DOUBT_FEATURES = ('distance', 'runner_up', 'runner_up_distance', 'crowd')
#: The weights (intercept first) of the score of a calibration without a model: distance / scale x distance /
#: runner-up's distance.
PRODUCT_WEIGHTS = (0.0, 1.0, 1.0, 0.0, 0.0)
_TINY = float(np.finfo(np.float64).tiny)


def doubt_features(distances: np.ndarray, named: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The features of N touches (module doc).

    Args:
        distances: (N, C) each touch's distance to each class (inf: a class the codebook lacks).
        named: (N,) int, the class named for each touch.
        scales: (C,) float > 0, each class's scale.

    Returns:
        (N, 4) float64 features (:data:`DOUBT_FEATURES`), and (N,) bool: the touch can be accepted at all (the
        runner-up is no nearer, the distance is a number). Rows with a zero distance are all -inf (an exact match).
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
    usable = ~np.isnan(d1) & (d2 >= d1)
    with np.errstate(divide='ignore', invalid='ignore'):
        log_d1 = np.log(np.maximum(d1, 0.0))
        out = np.column_stack([log_d1 - np.log(scales[named]), log_d1 - np.log(np.maximum(d2, _TINY)),
                               np.log(np.maximum(d2, _TINY)) - np.log(scales[runner]),
                               log_d1 - np.log(np.maximum(crowd, _TINY))])
    out[d1 == 0] = -np.inf
    return out, usable


def _others(d: np.ndarray, named: np.ndarray) -> np.ndarray:
    """(N, C-1) each row of ``d`` without its named column."""
    keep = np.ones(d.shape, dtype=bool)
    keep[np.arange(len(named)), named] = False
    return d[keep].reshape(len(named), d.shape[1] - 1)


def doubt(distances: np.ndarray, best: int, scales: np.ndarray, weights: np.ndarray) -> float:
    """The score of one touch: ``distances`` (C,) to each class, ``best`` the named class, ``scales`` (C,),
    ``weights`` (5,) intercept first (module doc)."""
    f, usable = doubt_features(np.asarray(distances, dtype=np.float64)[None, :], np.array([best]), scales)
    return float(scores_of(f, usable, weights)[0])


def scores_of(features: np.ndarray, usable: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """(N,) the score of each row of :func:`doubt_features`' output: ``exp(w0 + w . features)``; inf where not
    ``usable``, 0 for an exact match."""
    w = np.asarray(weights, dtype=np.float64)
    with np.errstate(invalid='ignore', over='ignore'):
        exact = np.isneginf(features).all(axis=1)
        z = w[0] + np.where(np.isneginf(features), 0.0, features) @ w[1:]
        out = np.exp(z)
    out[exact] = 0.0
    out[~usable | np.isnan(out)] = math.inf
    return out
