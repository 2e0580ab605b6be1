"""The order-free cloud and the direction-aware trace, their opinions summed: :class:`FusedRecogniser`.

The cloud (:mod:`.clouds`) ignores stroke order and direction, which reads symbols people
write their own way; the trace (:mod:`.proposed`) follows the path in time, which tells
apart what the cloud cannot (an N from an H: the same bars, joined in another order; a
five-point star from strokes scattered over the same points). Each is wrong where the other
is mostly right, so both are asked on every touch and their per-class distances combined by
the **sum rule** of classifier combination (Kittler, Hatef, Duin and Matas, "On combining
classifiers", IEEE TPAMI 20(3), 1998): each recogniser's distances are divided by its own
nearest class's (so each speaks on one scale, whatever its units: 1 for its nearest class,
how many times farther for the others) and the two summed with equal weight; the class of the
smallest sum among those the codebook's evidence allows (:mod:`.evidence`) is named. Nothing
is fitted for it: no weight, no scale, no margin.

As with the referee (:mod:`.referee`), the combination names the class; it does not make a
command fire: distances, thresholds, margins, the end of a gesture and early candidates are
the cloud's (:attr:`~.referee.RefereedRecogniser.primary_`), so a class the cloud does not put
first is named but rejected (its margin over the cloud's nearest is negative), and what fires
is what the cloud alone fires (the random touches that fire a command do not change).

People write a symbol's strokes in their own order, so the trace holds each template of up to
``stroke_orders`` strokes in every order of its strokes (:mod:`.stroke_orders`, as $N does for its
unistrokes; each stroke keeps its direction): a person who draws the other bar of an X first is
near the X's templates read that way, not nearer a pitchfork.

Measured leave-one-person-out through the virtual skin (``social-touch eval skin --traces
<file> --json --recognisers fused``; docs/skin-multistroke.md), nearest class right over all
samples: Mixed Multistroke Gestures 97.09 % against ``refereed``'s 97.00 % and the cloud's
96.90 % (99.55 % of the samples cut into one gesture), unistroke file 99.33 % against
``trace``'s 99.17 % (one-stroke templates have one order). Commands: wrong ones 0.06 % of the
multi-stroke samples against the cloud's 0.12 %, correct ones 95.46 % against 95.51 % (a class
the sum names against the cloud's nearest is rejected), random touches firing the same (0.40 %).
While the virtual skin kept one point per logged time (a fifth of the median sample's ink lost,
:func:`touch_sim.skin.traces.spread_stamps`) the sum mattered more, 95.63 % against 94.70 %, and
holding the templates in every stroke order took an X named pitchfork from 18 to 1 (all by one
person, who draws the other bar first).
Cost: the cloud's and the trace's search. With the compiled features, class minima and sum
(:mod:`.cloud_accel`: the trace's features, its distances' class minima after numpy's matrix-vector product,
and :func:`relative_distances` of both, one C call each, the same numbers as numpy's) 61 CPU us per recognition
against the cloud's 54 on the synthetic bench (16 gestures x 30 one-stroke templates), 77 where every template
has three strokes (6 orders each, ``fused_3_strokes``; ``social-touch bench skin``, the run of
docs/skin-multistroke.md).
"""

from __future__ import annotations

import math

import numpy as np

from . import cloud_accel
from .base import TemplateRecogniser
from .clouds import CloudRecogniser
from .gesture import TouchGesture
from .proposed import TraceRecogniser, trace_features
from .referee import RefereedRecogniser
from .stroke_orders import every_order

__all__ = ['MAX_STROKE_ORDERS', 'FusedRecogniser', 'relative_distances', 'relative_sum']

#: The most strokes of a template the trace may hold in every order (4! = 24 readings of the template).
MAX_STROKE_ORDERS = 4


def relative_distances(per_class: np.ndarray) -> np.ndarray:
    """(n_classes,) distances -> (n_classes,) float64, each over the smallest finite one (the nearest
    class: 1; where that is an exact match, distance 0, over the smallest normal float instead).

    >>> relative_distances(np.array([2.0, 1.0, 4.0])).tolist()
    [2.0, 1.0, 4.0]
    """
    d = np.asarray(per_class, dtype=np.float64)
    finite = d[np.isfinite(d)]
    if not finite.size:
        return d.copy()
    nearest = float(finite.min())
    with np.errstate(over='ignore'):   # others of a (near) exact match: inf, still ordered after it
        return d / (nearest if nearest > 0 else np.finfo(np.float64).tiny)


def relative_sum(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """``relative_distances(first) + relative_distances(second)`` of two (n_classes,) opinions: the sum rule.

    >>> relative_sum(np.array([1.0, 2.0]), np.array([4.0, 2.0])).tolist()
    [3.0, 3.0]
    """
    if cloud_accel.relative_sum is not None:   # the same numbers in one C call (cloud_accel)
        return cloud_accel.relative_sum(first, second)
    return relative_distances(first) + relative_distances(second)


class FusedRecogniser(RefereedRecogniser):
    """The cloud and the trace, their relative distances summed to name the class (module doc).

    Args:
        n_points: points of the cloud (:class:`~.clouds.CloudRecogniser`).
        trace_points: points of the trace (:class:`~.proposed.TraceRecogniser`).
        stroke_orders: the trace holds each template of up to this many strokes in every order of its strokes
            (:mod:`.stroke_orders`; k! readings of k strokes, each class at its nearest); 1: only as traced.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base` (the cloud's distances).

    Attributes:
        primary_: the fitted cloud (its codebook: the templates' first part).
        referee_: the fitted trace, asked on every recognition. Its codebook is the templates' second part:
            ``stroke_orders``! trace features side by side, the order traced first, then the others (copies of
            the first where a template has fewer orders), less the copies.
    """

    name = 'fused'
    direction_aware = False

    def __init__(self, n_points: int = 32, trace_points: int = 32, stroke_orders: int = 3,
                 max_distance: float | str | None = 'auto', auto_scale: float = 2.0, auto_quantile: float = 0.9,
                 min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.trace_points = trace_points
        self.stroke_orders = stroke_orders
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def _check_params(self) -> None:
        super()._check_params()
        if isinstance(self.trace_points, bool) or not isinstance(self.trace_points, int | np.integer) \
                or self.trace_points < 2:
            raise ValueError(f'trace_points must be an integer >= 2 (a path), got {self.trace_points!r}')
        if isinstance(self.stroke_orders, bool) or not isinstance(self.stroke_orders, int | np.integer) \
                or not 1 <= self.stroke_orders <= MAX_STROKE_ORDERS:
            raise ValueError(f'stroke_orders must be an integer from 1 to {MAX_STROKE_ORDERS} (the most strokes '
                             f'of a template held in every order), got {self.stroke_orders!r}')

    def _parts(self) -> tuple[TemplateRecogniser, TemplateRecogniser]:
        """New, unfitted cloud and trace (no limits of their own: only their distances are read)."""
        return (CloudRecogniser(n_points=self.n_points, max_distance=None),
                TraceRecogniser(n_points=self.trace_points, max_distance=None))

    def _features(self, gesture: TouchGesture) -> np.ndarray | None:
        # A template's: the cloud's features, then the trace's of each order of its strokes in stroke_orders!
        # slots (copies of the order traced fill the rest, so every template has one width). A query's are the
        # cloud's alone (_query_features); the trace reads the query itself (_nearest).
        cloud, trace = self._parts()
        first = cloud._features(gesture)
        own = self._own_features(gesture)
        if first is None or own is None or not len(gesture.trajectory):
            return None
        orders = [trace_features(p, t, trace.n_points, trace.aspect_floor)
                  for p, t in every_order(gesture, self.stroke_orders)]
        orders += orders[:1] * (math.factorial(self.stroke_orders) - len(orders))
        return np.concatenate([first, *own, *orders]).astype(np.float32, copy=False)

    def _own_features(self, gesture: TouchGesture) -> list[np.ndarray] | None:
        """A subclass's part of a template, between the cloud's and the trace's (:meth:`_trace_start` says where
        the trace starts after it): none here; None: the gesture is unusable."""
        return []

    def _prepare_codebook(self) -> None:
        cloud, trace = self._parts()
        split = self._primary_width(cloud)
        start = self._trace_start(split)
        width = 2 * self.trace_points
        if self.templates_.shape[1] <= start or (self.templates_.shape[1] - start) % width:
            own = f', {start - split} values of its own' if start > split else ''
            raise ValueError(f'a {self.name} codebook holds the cloud ({split} values){own}, then the trace ({width} '
                             f'values) of one or more stroke orders; got templates of {self.templates_.shape[1]} (made '
                             'with other n_points or trace_points?)')
        slots = self.templates_[:, start:].reshape(len(self.templates_), -1, width)
        # Orders that read the same as the one traced (padding) would only cost rows of the search.
        distinct = np.ones(slots.shape[:2], dtype=bool)
        distinct[:, 1:] = (slots[:, 1:] != slots[:, :1]).any(axis=2)
        template, slot = np.nonzero(distinct)
        labels = self.classes_[self.template_labels_]
        unlimited = np.full(len(self.classes_), np.inf)   # thresholds are this recogniser's, not the parts'
        strokes, contacts = self.template_strokes_, self.template_contact_s_
        cloud.set_codebook(self.templates_[:, :split], labels, class_thresholds=unlimited,
                           template_strokes=strokes, template_contact_s=contacts)
        trace.set_codebook(slots[template, slot], labels[template], class_thresholds=unlimited,
                           template_strokes=None if strokes is None else strokes[template],
                           template_contact_s=None if contacts is None else contacts[template])
        self.primary_, self.referee_, self._split = cloud, trace, split
        self.referee_calls_ = 0

    def _trace_start(self, split: int) -> int:
        """Where a template's trace features start, given where the cloud's end (``split``): right after them
        (a subclass may hold a part of its own between, :class:`~.oriented.OrientedFusedRecogniser`)."""
        return split

    def _naming_opinion(self, gesture: TouchGesture, per_class: np.ndarray) -> np.ndarray | None:
        """The (n_classes,) distances summed with the trace's to name the class: the cloud's own here (a subclass
        may ask another, :class:`~.oriented.OrientedFusedRecogniser`); None: it cannot read the touch."""
        return per_class

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        second = self.referee_.class_distances(gesture)
        first = self._naming_opinion(gesture, per_class)
        if second is None or first is None:   # the trace (or the other opinion) cannot read it: the cloud alone
            return TemplateRecogniser._nearest(self, gesture, per_class, allowed)
        return TemplateRecogniser._nearest(self, gesture, relative_sum(first, second), allowed)
