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

A calibration may add evidence the shape match throws away (:data:`CONTEXT_FEATURES`, :func:`context_features`),
each in the codebook's own units so that it holds for people and vocabularies the codebook never saw:

- ``disagreement``: log of the second opinion's distance to the named class over its distance to its own nearest
  class (0 when it names the same class; the fused recogniser's trace, :meth:`.base.TemplateRecogniser.opinions`;
  0 for a recogniser of one opinion);
- ``strokes``: how rare the touch's stroke count is among the named class's templates, ``-log((k + 1/2) / (n + 1))``
  (k of the class's n templates show it);
- ``duration``: how far the log of the time in contact lies from the median of the named class's templates', in
  robust spreads of theirs (1.4826 x the median absolute deviation, at least :data:`DURATION_SPREAD_FLOOR`);
- ``size``: the same of the touch's size (:func:`touch_size_mm`, the diagonal of its bounding box, mm; spread at
  least :data:`SIZE_SPREAD_FLOOR`). The shape match normalises scale away, so a small rub or wiggle and a symbol
  look alike to it; their size does not.

A value the codebook or the touch does not know (no strokes, times or sizes recorded, a NaN, a touch of no
extent) is 0: no evidence either way. A calibration's weights go on with the first K context features (a
codebook calibrated before ``size`` existed has 3 and decides as it did).

``odds = exp(w0 + w . features)``. A codebook calibrated before the model existed has no weights: its score
is :data:`PRODUCT_WEIGHTS`, the distance over the scale times the ratio to the runner-up. The score is 0 for
an exact match and inf where the runner-up is nearer than the named class or a value is NaN (never accepted).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ['CONTEXT_FEATURES', 'DOUBT_FEATURES', 'DURATION_SPREAD_FLOOR', 'MIN_CONTACT_S', 'PRODUCT_WEIGHTS',
           'SIZE_SPREAD_FLOOR', 'ClassHabits', 'context_features', 'disagreement', 'doubt', 'doubt_features',
           'scores_of', 'touch_size_mm']

#: The features of :func:`doubt_features`, in column order (module doc).
DOUBT_FEATURES = ('distance', 'runner_up', 'runner_up_distance', 'crowd')
#: The further features of :func:`context_features`, in column order after :data:`DOUBT_FEATURES` (module doc).
CONTEXT_FEATURES = ('disagreement', 'strokes', 'duration', 'size')
#: The least robust spread of a class's log contact times (a class whose templates all last the same would
#: otherwise call any other duration impossible).
DURATION_SPREAD_FLOOR = 0.05
#: The least robust spread of a class's log sizes (a class whose templates are all the same size would otherwise
#: call any other size impossible).
SIZE_SPREAD_FLOOR = 0.05
#: The time in contact, s, a touch of one frame counts as (the log of none is no number).
MIN_CONTACT_S = 1e-3
#: A class with fewer timed (sized) templates than this takes the median spread of the others.
_MIN_TIMED = 3
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
          weights: Sequence[float] | np.ndarray, context: Sequence[float] = ()) -> float:
    """The score of one touch: ``distances`` (C,) to each class, ``best`` the named class, ``scales`` (C,),
    ``weights`` (5 + K,) intercept first, ``context`` the touch's :data:`CONTEXT_FEATURES`, of which the first K
    go with the weights (module doc). Plain Python over the C numbers: one call per touch on the
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
    for weight, value in zip(w[5:], context[:len(w) - 5], strict=True):
        z += weight * _clip(value)
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


class ClassHabits:
    """Per class, the stroke counts, log contact times and log sizes of its templates: the ``strokes``,
    ``duration`` and ``size`` features of :func:`context_features` (module doc).

    Args:
        template_labels: (T,) class index of each template.
        n_classes: C.
        strokes: (T,) strokes of each template, or None (not recorded: the feature is 0).
        contact_s: (T,) s, each template's time in contact (NaN where not recorded), or None.
        sizes_mm: (T,) mm, each template's :func:`touch_size_mm` (NaN where not recorded), or None.
    """

    def __init__(self, template_labels: np.ndarray, n_classes: int, strokes: np.ndarray | None = None,
                 contact_s: np.ndarray | None = None, sizes_mm: np.ndarray | None = None) -> None:
        labels = np.asarray(template_labels, dtype=np.intp)
        self.n_templates = np.bincount(labels, minlength=n_classes)
        self.stroke_counts: list[dict[int, int]] | None = None
        if strokes is not None:
            strokes = np.asarray(strokes, dtype=np.int64)
            self.stroke_counts = [dict(zip(*(v.tolist() for v in np.unique(strokes[labels == c], return_counts=True)),
                                           strict=True)) for c in range(n_classes)]
        self.log_contact_median, self.log_contact_spread = _log_habit(labels, n_classes, contact_s,
                                                                      DURATION_SPREAD_FLOOR)
        self.log_size_median, self.log_size_spread = _log_habit(labels, n_classes, sizes_mm, SIZE_SPREAD_FLOOR)

    def strokes_feature(self, named: int, strokes: float) -> float:
        """``-log((k + 1/2) / (n + 1))`` of a touch of ``strokes`` named ``named`` (module doc); 0 when unknown."""
        if self.stroke_counts is None or strokes != strokes:
            return 0.0
        k = self.stroke_counts[named].get(int(strokes), 0)
        return -math.log((k + 0.5) / (int(self.n_templates[named]) + 1))

    def duration_feature(self, named: int, contact_s: float) -> float:
        """``|log contact_s - median| / spread`` of the named class (module doc); 0 when unknown. A touch of no
        time in contact (one frame) counts as :data:`MIN_CONTACT_S`."""
        if contact_s != contact_s:
            return 0.0
        return _robust_distance(self.log_contact_median, self.log_contact_spread, named,
                                max(float(contact_s), MIN_CONTACT_S))

    def size_feature(self, named: int, size_mm: float) -> float:
        """``|log size_mm - median| / spread`` of the named class (module doc); 0 when unknown, NaN or no size
        (a touch of one point, or all its points in one place)."""
        if not size_mm > 0:   # NaN too
            return 0.0
        return _robust_distance(self.log_size_median, self.log_size_spread, named, float(size_mm))


def _log_habit(labels: np.ndarray, n_classes: int, values: np.ndarray | None, floor: float
               ) -> tuple[np.ndarray | None, np.ndarray | None]:
    """(C,) the median of each class's log ``values`` (T,) (finite, > 0; NaN where a class has none) and (C,) their
    robust spread (1.4826 x the median absolute deviation, at least ``floor``; the median of the other classes'
    where a class has fewer than :data:`_MIN_TIMED`); (None, None) without ``values``."""
    if values is None:
        return None, None
    values = np.asarray(values, dtype=np.float64)
    median, spread = np.full(n_classes, np.nan), np.full(n_classes, np.nan)
    for c in range(n_classes):
        own = values[(labels == c) & np.isfinite(values) & (values > 0)]
        if own.size:
            logs = np.log(own)
            median[c] = np.median(logs)
            if own.size >= _MIN_TIMED:
                spread[c] = 1.4826 * np.median(np.abs(logs - median[c]))
    known = spread[np.isfinite(spread)]
    spread[np.isnan(spread)] = np.median(known) if known.size else floor
    return median, np.maximum(spread, floor)


def _robust_distance(median: np.ndarray | None, spread: np.ndarray | None, named: int, value: float) -> float:
    """``|log value - median| / spread`` of class ``named`` (``value`` > 0); 0 where the class's median is unknown."""
    if median is None:
        return 0.0
    centre = float(median[named])
    if centre != centre:
        return 0.0
    return abs(math.log(value) - centre) / float(spread[named])


def touch_size_mm(trajectory: np.ndarray) -> float:
    """The size of a touch, mm: the diagonal of the bounding box of its (n, 2) ``trajectory`` (mm), its NaN points
    left out; NaN without a finite point.

    The diagonal rather than the path's length: a path grows with the sensor's jitter and frame rate and with how
    often a rub goes back and forth, while the box says how much of the skin the gesture covers, which the shape
    match normalises away.

    >>> touch_size_mm(np.array([[0.0, 0.0], [30.0, 40.0]]))
    50.0
    """
    points = np.asarray(trajectory, dtype=np.float64).reshape(-1, 2)
    points = points[np.isfinite(points).all(axis=1)]
    if not len(points):
        return math.nan
    return float(np.hypot(*np.ptp(points, axis=0)))


def disagreement(second: np.ndarray | None, named: int) -> float:
    """The ``disagreement`` feature (module doc): log of ``second`` (C,)'s distance to ``named`` over its smallest;
    0 without a second opinion, :data:`FEATURE_BOUND` where it cannot be read (NaN, or an exact match elsewhere)."""
    if second is None:
        return 0.0
    d = np.asarray(second, dtype=np.float64)
    if np.isnan(d).any():
        return FEATURE_BOUND
    nearest, own = float(d.min()), float(d[named])
    if own == nearest:
        return 0.0
    if nearest <= 0 or not math.isfinite(own):
        return FEATURE_BOUND
    return _clip(math.log(own / nearest))


def context_features(habits: ClassHabits, named: int, strokes: float, contact_s: float,
                     second: np.ndarray | None = None, size_mm: float = math.nan) -> list[float]:
    """The :data:`CONTEXT_FEATURES` of one touch named ``named`` (module doc): its ``strokes``, ``contact_s``
    (s), the second opinion's (C,) distances (None: a recogniser of one opinion) and its ``size_mm``
    (:func:`touch_size_mm`; NaN: not known)."""
    return [disagreement(second, named), _clip(habits.strokes_feature(named, strokes)),
            _clip(habits.duration_feature(named, contact_s)), _clip(habits.size_feature(named, size_mm))]
