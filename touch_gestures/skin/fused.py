"""The order-free cloud and the direction-aware trace, their opinions summed: :class:`FusedRecogniser`.

The cloud (:mod:`.clouds`) ignores stroke order and direction; the trace (:mod:`.proposed`) follows
the path in time, which tells apart what the cloud cannot (an N from an H). Both are asked on every
touch and combined by the **sum rule** (Kittler, Hatef, Duin and Matas, IEEE TPAMI 20(3), 1998):
each one's distances divided by its nearest class's (:func:`relative_distances`), summed with equal
weight; the smallest sum among the classes the codebook's evidence allows (:mod:`.evidence`) is
named. Nothing is fitted for it.

The combination names the class only: distances, thresholds, margins, the end of a gesture and
early candidates are the cloud's (:attr:`FusedRecogniser.cloud_`,
:meth:`FusedRecogniser.deciding_recogniser`), so a class the cloud does not put first is named but
rejected (negative margin): the **disagreement rule**. With ``disagreement='confused'`` (the
default; ``'always'``: everywhere) it holds only where the two classes are a pair the codebook
confuses (:attr:`FusedRecogniser.confused_`: a template whose nearest other template, by the cloud
or by the trace, is of the other class); elsewhere the class named is decided against the classes
other than the cloud's first.

The trace holds each template of up to ``stroke_orders`` strokes in every order of its strokes
(:mod:`.stroke_orders`; each stroke keeps its direction). A template's features are the cloud's
(``2 n_points`` values), then the trace's of each order in ``stroke_orders!`` slots of
``2 trace_points`` (copies of the order traced fill the slots a template of fewer strokes leaves).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import Match, TemplateRecogniser, nearest_allowed
from .clouds import CloudRecogniser
from .gesture import TouchGesture
from .proposed import TraceRecogniser, trace_features
from .stroke_orders import every_order

__all__ = ['DISAGREEMENT_RULES', 'MAX_STROKE_ORDERS', 'FusedRecogniser', 'confused_pairs', 'relative_distances',
           'relative_sum', 'sum_rule_nearest']

#: The most strokes of a template the trace may hold in every order (4! = 24 readings of the template).
MAX_STROKE_ORDERS = 4

#: Where the cloud's first class, other than the class named, rejects the touch (module doc).
DISAGREEMENT_RULES = ('always', 'confused')


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
    return relative_distances(first) + relative_distances(second)


@dataclass(eq=False)
class FusedRecogniser(TemplateRecogniser):
    """The cloud and the trace, their relative distances summed to name the class (module doc).

    Args:
        n_points: points of the cloud (:class:`~.clouds.CloudRecogniser`).
        trace_points: points of the trace (:class:`~.proposed.TraceRecogniser`).
        stroke_orders: the trace holds each template of up to this many strokes in every order of its strokes
            (:mod:`.stroke_orders`; k! readings of k strokes, each class at its nearest); 1: only as traced.
        disagreement: where the cloud putting another class first rejects the class named (:data:`DISAGREEMENT_RULES`,
            module doc).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base` (the cloud's distances).

    Attributes:
        cloud_: the fitted cloud (its codebook: the templates' first ``2 n_points`` values), whose distances
            decide.
        trace_: the fitted trace, asked on every recognition to name the class. Its codebook: the templates'
            trace slots, the order traced first, then the others, less the copies.
        confused_: (n_classes, n_classes) bool, symmetric: pairs of classes the codebook confuses
            (:func:`confused_pairs`; with ``disagreement='confused'``, else None).
    """

    name = 'fused'
    direction_aware = False

    n_points: int = 32
    trace_points: int = 32
    stroke_orders: int = 3
    disagreement: str = 'confused'

    def _check_params(self) -> None:
        super()._check_params()
        if isinstance(self.trace_points, bool) or not isinstance(self.trace_points, int | np.integer) \
                or self.trace_points < 2:
            raise ValueError(f'trace_points must be an integer >= 2 (a path), got {self.trace_points!r}')
        if isinstance(self.stroke_orders, bool) or not isinstance(self.stroke_orders, int | np.integer) \
                or not 1 <= self.stroke_orders <= MAX_STROKE_ORDERS:
            raise ValueError(f'stroke_orders must be an integer from 1 to {MAX_STROKE_ORDERS} (the most strokes '
                             f'of a template held in every order), got {self.stroke_orders!r}')
        if self.disagreement not in DISAGREEMENT_RULES:
            raise ValueError(f'disagreement must be one of {DISAGREEMENT_RULES}, got {self.disagreement!r}')
        for part in self.parts():
            part._check_params()

    def parts(self) -> tuple[CloudRecogniser, TraceRecogniser]:
        """New, unfitted cloud and trace of these parameters (no limits of their own: only their distances
        are read)."""
        return (CloudRecogniser(n_points=self.n_points, max_distance=None),
                TraceRecogniser(n_points=self.trace_points, max_distance=None))

    @property
    def cloud_width(self) -> int:
        """How many of a template's first values are the cloud's."""
        return 2 * self.n_points

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        # A template's (module doc). A query's are the cloud's alone (_query_features); the trace reads the
        # query itself (_nearest).
        cloud, trace = self.parts()
        first = cloud.features(gesture)
        if first is None or not len(gesture.trajectory):
            return None
        return np.concatenate([first, *self.trace_orders(gesture, trace)]).astype(np.float32, copy=False)

    def trace_orders(self, gesture: TouchGesture, trace: TraceRecogniser) -> list[np.ndarray]:
        """``stroke_orders!`` trace features of ``gesture`` (a template): each order of its strokes, the order
        traced first, copies of it for the orders a gesture of fewer strokes does not have."""
        orders = [trace_features(p, t, trace.n_points, trace.aspect_floor)
                  for p, t in every_order(gesture, self.stroke_orders)]
        return orders + orders[:1] * (math.factorial(self.stroke_orders) - len(orders))

    def _prepare_codebook(self) -> None:
        cloud, trace = self.parts()
        split = self.cloud_width
        width = 2 * self.trace_points
        if self.templates_.shape[1] <= split or (self.templates_.shape[1] - split) % width:
            raise ValueError(f'a {self.name} codebook holds the cloud ({split} values), then the trace ({width} '
                             f'values) of one or more stroke orders; got templates of {self.templates_.shape[1]} (made '
                             'with other n_points or trace_points?)')
        slots = self.templates_[:, split:].reshape(len(self.templates_), -1, width)
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
        self.cloud_, self.trace_ = cloud, trace
        self.confused_ = None
        if self.disagreement == 'confused':
            rows_of = np.arange(len(self.templates_))
            self.confused_ = confused_pairs(
                self.template_labels_, len(self.classes_),
                [(cloud, self.templates_[:, :split], rows_of), (trace, slots[:, 0], template)])

    def deciding_recogniser(self) -> TemplateRecogniser:
        return self.cloud_

    def _query_features(self, gesture: TouchGesture) -> np.ndarray | None:
        return self.cloud_.features(gesture)   # the trace reads the touch itself, in _nearest

    def one_stroke_path_of(self, gesture: TouchGesture, query: np.ndarray) -> np.ndarray | None:
        return self.cloud_.one_stroke_path_of(gesture, query[:self.cloud_width])

    def distances(self, query: np.ndarray) -> np.ndarray:
        return self.cloud_.distances(query[:self.cloud_width])   # a template's or a query's: the cloud comes first

    def opinions(self, gesture: TouchGesture, deciding: np.ndarray | None = None
                 ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(n_classes,) distances of ``gesture`` to each class by the order-free cloud (``deciding`` when already
        known) and by the ordered trace (None where either cannot read it)."""
        cloud = self.cloud_.class_distances(gesture) if deciding is None else deciding
        return cloud, self.trace_.class_distances(gesture)

    def _named(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None
               ) -> tuple[int, np.ndarray | None]:
        trace = self.trace_.class_distances(gesture)   # one search of the trace: it names, then it is the context
        return sum_rule_nearest(per_class, trace, allowed), trace

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        return self._named(gesture, per_class, allowed)[0]

    def _decide(self, per_class: np.ndarray, best: int | None = None, allowed: np.ndarray | None = None,
                gesture: TouchGesture | None = None, second: np.ndarray | None = None) -> tuple[Match, int]:
        match, best = super()._decide(per_class, best, allowed, gesture, second)
        confused = getattr(self, 'confused_', None)
        if confused is None or match.label is not None or not match.margin < 0:
            return match, best
        first = int(np.argmin(per_class))
        if first == best or confused[best, first]:
            return match, best
        # A pair the codebook never confuses: the cloud's first is no rival; the others decide.
        others = per_class.copy()
        others[first] = np.inf
        return super()._decide(others, best, allowed, gesture, second)[0], best


def confused_pairs(template_labels: np.ndarray, n_classes: int,
                   readings: list[tuple[TemplateRecogniser, np.ndarray, np.ndarray]]) -> np.ndarray:
    """(n_classes, n_classes) bool, symmetric: classes ``a``, ``b`` where a template of ``a`` has its nearest
    other template in ``b`` by one of the ``readings``.

    Args:
        template_labels: (T,) class index of each template.
        readings: per reading, a fitted recogniser, (T, d) each template's query features for it, and (R,) the
            template each row of its codebook holds (rows of the template itself are left out).
    """
    labels = np.asarray(template_labels)
    out = np.zeros((n_classes, n_classes), dtype=bool)
    for recogniser, queries, row_template in readings:
        row_labels = labels[row_template]
        for i, query in enumerate(queries):
            d = np.asarray(recogniser.distances(query), dtype=np.float64)
            d[row_template == i] = np.inf
            if not np.isfinite(d).any():
                continue
            other = int(row_labels[int(np.argmin(d))])
            out[labels[i], other] = out[other, labels[i]] = True
    np.fill_diagonal(out, False)
    return out


def sum_rule_nearest(first: np.ndarray | None, second: np.ndarray | None, allowed: np.ndarray | None) -> int:
    """The class named by two (n_classes,) opinions: the smallest :func:`relative_sum` among the classes
    ``allowed`` ((n_classes,) bool; None: all); where ``second`` cannot read the touch (None), ``first``'s nearest
    (``first`` must be given)."""
    if second is None:
        return nearest_allowed(first, allowed)
    return nearest_allowed(relative_sum(first, second), allowed)
