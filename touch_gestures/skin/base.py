"""The interface every skin recogniser shares: a codebook of templates and a rejection rule.

A recogniser follows scikit-learn's estimator conventions (:mod:`touch_gestures.estimator`).
``fit(gestures, labels)`` turns n gestures x m repetitions into a codebook of feature vectors
(cirillo2017 Fig. 5); ``predict(gesture)`` returns a :class:`Match`: the nearest class, its
distance and its margin over the runner-up. Subclasses supply ``features(gesture) -> (d,)
float32 | None`` and ``distances(query) -> (T,) float`` against the whole codebook (public, so a
recogniser made of others can ask them), and ``_prepare_codebook()`` for what the codebook
alone determines.

**Rejection** (not in the paper, which always answers). The rule that decides, in order: the
nearest class among those written with the touch's number of strokes
(:meth:`.evidence.CodebookEvidence.allowed`; all classes when none is or the strokes are not
known), its margin taken over the nearest other class of all; no command when

- the distance exceeds the class's threshold (``'distance'``). With ``max_distance='auto'``
  each class's threshold is ``auto_scale`` times the ``auto_quantile`` quantile of its
  templates' leave-one-out distances to the nearest other template of the class; a number is
  one threshold for every class; None disables the rule;
- the margin is below ``min_margin`` times the distance (``'margin'``); a class ruled out by
  its strokes yet nearer leaves a negative margin, rejected as ``'strokes'``;
- for a codebook with a calibrated acceptance (``acceptance_``, :meth:`TemplateRecogniser.set_acceptance`,
  made by :func:`touch_lab.skin.acceptance.calibrate_acceptance`), the two rules above are one:
  the score (:func:`.doubt.doubt` with the record's ``score_weights``, else :func:`acceptance_score`)
  exceeds ``acceptance_['max_score']`` (``'score'``) or the margin is negative;
- the stroke count is more than ``stroke_tolerance`` strokes from every count the class allows
  (``'strokes'``) or the time in contact is out of its range (``'duration'``; it rejects but does not
  name: people trace at their own pace) (:mod:`.evidence`);
- for an order-free recogniser (``direction_aware`` False) with distance limits, a one-stroke
  touch whose path in tracing order is far from every one-stroke path of the class
  (``'order'``, :mod:`.order_evidence`).

Degenerate codebooks: a class with one template takes the median scale of the other classes;
if no class has two templates, every scale is half the smallest distance between templates of
different classes; a single template in all gets no distance limit. A codebook with one class
has no runner-up: the margin is ``inf`` and only the distance rule applies.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..estimator import NotFittedError, Params
from .doubt import CONTEXT_FEATURES, PRODUCT_WEIGHTS, ClassHabits, context_features, doubt, touch_size_mm
from .evidence import CodebookEvidence
from .gesture import TouchGesture
from .order_evidence import PATH_POINTS, OrderEvidence, one_stroke_path

__all__ = ['PREDICT_STEPS', 'Match', 'TemplateRecogniser', 'acceptance_score', 'nearest_allowed']

#: The steps of :meth:`TemplateRecogniser.predict`, in its order (the evidence comes before the decision,
#: the classes the strokes allow, and after it, the named class's strokes and duration).
PREDICT_STEPS = ('features', 'search', 'minima', 'evidence', 'decision', 'order')
#: Index of the ``size`` feature's weight in a score's weights (a record this short does not read the touch's size).
_SIZE_WEIGHT = len(PRODUCT_WEIGHTS) + CONTEXT_FEATURES.index('size')


@dataclass(frozen=True, slots=True)
class Match:
    """The answer of a recogniser for one gesture.

    Attributes:
        label: the recognised gesture, or None when rejected.
        distance: distance to the nearest template (recogniser units; inf if unusable).
        margin: distance of the nearest template of another class minus ``distance``
            (inf when the codebook has one class).
        nearest: the nearest class even when rejected (None if the gesture was unusable).
        rejected: why there is no label: ``'distance'``, ``'margin'``, ``'score'``, ``'strokes'``, ``'duration'``
            (:mod:`.evidence`), ``'order'`` (:mod:`.order_evidence`), ``'unusable'`` (no feature could be
            computed, e.g. an empty map), or
            None when accepted.
    """

    label: str | None
    distance: float
    margin: float
    nearest: str | None = None
    rejected: str | None = None


@dataclass(eq=False, kw_only=True)
class TemplateRecogniser(Params):
    """Base class: nearest-template matching over a codebook, with rejection (see module doc).

    A subclass is a dataclass of its own parameters; the rejection parameters ``max_distance``,
    ``auto_scale``, ``auto_quantile`` and ``min_margin`` (keyword-only) are the module docstring's.
    """

    #: registry name, e.g. ``'centroid'``
    name = 'template'
    #: True when the features follow the direction of the trace
    direction_aware = False

    max_distance: float | str | None = 'auto'
    auto_scale: float = 2.0
    auto_quantile: float = 0.9
    min_margin: float = 0.1

    # ----------------------------------------------------------------- subclass API
    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        """(d,) float32 feature vector of ``gesture``, or None if it has none (empty map...)."""
        raise NotImplementedError

    def distances(self, query: np.ndarray) -> np.ndarray:
        """(T,) distances from ``query`` (d,) to every row of ``self.templates_`` (T, d)."""
        raise NotImplementedError

    def _prepare_codebook(self) -> None:
        """Precompute per-template quantities after ``templates_`` is set (norms, ...)."""

    # ----------------------------------------------------------------- estimator API
    def fit(self, gestures: Sequence[TouchGesture], labels: Sequence[Any],
            people: Sequence[str] | None = None) -> TemplateRecogniser:
        """Build the codebook: one template per usable gesture.

        Args:
            gestures: the recorded repetitions (n gestures x m repetitions, any order).
            labels: the gesture name of each, same length.
            people: who drew each, same length (kept as ``template_people_``, so a codebook can be
                judged leave-one-person-out); None: not known.

        Raises:
            ValueError: lengths differ, no usable gesture, or bad rejection parameters.
        """
        self._check_params()
        if len(gestures) != len(labels) or (people is not None and len(people) != len(labels)):
            raise ValueError(f'fit needs one label (and person, if given) per gesture; got {len(gestures)} gestures, '
                             f'{len(labels)} labels{"" if people is None else f", {len(people)} people"}')
        feats, names, who, strokes, contacts, sizes, paths, dropped = [], [], [], [], [], [], [], 0
        for i, (gesture, label) in enumerate(zip(gestures, labels, strict=True)):
            f = self.features(gesture)
            if f is None:
                dropped += 1
                continue
            feats.append(f)
            names.append(str(label))
            who.append('' if people is None else str(people[i]))
            strokes.append(int(getattr(gesture, 'strokes', 1)))
            contacts.append(float(getattr(gesture, 'contact_s', np.nan)))
            sizes.append(touch_size_mm(gesture.trajectory))
            if not self.direction_aware:
                path = one_stroke_path(gesture)
                paths.append(np.full((PATH_POINTS, 2), np.nan) if path is None else path)
        if not feats:
            raise ValueError(f'none of the {len(gestures)} gestures gives a usable template (empty maps or '
                             'trajectories?); record the codebook again')
        self.set_codebook(np.stack(feats), names, template_strokes=strokes, template_contact_s=contacts,
                          template_paths=np.stack(paths) if paths else None,
                          template_people=None if people is None else who, template_sizes_mm=sizes)
        self.n_dropped_ = dropped
        # Most strokes of a gesture of the codebook: a multi-stroke vocabulary needs the longer gap.
        self.max_strokes_ = max(int(getattr(g, 'strokes', 1)) for g in gestures)
        return self

    def set_codebook(self, templates: np.ndarray, labels: Sequence[str],
                     class_thresholds: np.ndarray | None = None, template_strokes: Sequence[int] | None = None,
                     template_contact_s: Sequence[float] | None = None,
                     template_paths: np.ndarray | None = None,
                     template_people: Sequence[str] | None = None,
                     acceptance: dict | None = None, template_sizes_mm: Sequence[float] | None = None) -> None:
        """Install precomputed templates (T, d) and labels (from a codebook file or ``fit``);
        ``class_thresholds`` (n_classes,), in sorted class order, skips the calibration;
        ``template_strokes`` (T,) and ``template_contact_s`` (T,) s give each template's strokes and
        time in contact (``template_strokes_``, ``template_contact_s_``, else None; :mod:`.evidence`);
        ``template_paths`` (T, n, 2), NaN for templates of several strokes, each template's path
        (:func:`~.order_evidence.one_stroke_path`; ``template_paths_`` and ``order_evidence_`` for an
        order-free recogniser with distance limits, else None: no order check); ``template_people``
        (T,), who drew each template ('' unknown: ``template_people_``, else None); ``acceptance``: a calibrated
        acceptance for this codebook (:meth:`set_acceptance`; None: the thresholds and ``min_margin`` decide);
        ``template_sizes_mm`` (T,) mm, each template's size (:func:`~.doubt.touch_size_mm`, NaN not known:
        ``template_sizes_mm_``, else None; the acceptance score's ``size`` feature)."""
        self._check_params()
        templates = np.asarray(templates, dtype=np.float32)
        labels = np.asarray([str(x) for x in labels])
        if templates.ndim != 2 or len(templates) != len(labels) or len(labels) == 0:
            raise ValueError(f'templates must be (T, d) with one label each; got {templates.shape} and '
                             f'{len(labels)} labels')
        if not np.all(np.isfinite(templates)):
            raise ValueError('templates contain NaN or infinite values')
        classes, codes = np.unique(labels, return_inverse=True)
        order = np.argsort(codes, kind='stable')  # templates grouped by class for reduceat
        self.classes_ = classes
        self.templates_ = templates[order]
        self.template_labels_ = codes[order]
        self.class_starts_ = np.searchsorted(self.template_labels_, np.arange(len(classes)))
        self.n_features_in_ = templates.shape[1]
        n = len(labels)
        self.template_strokes_ = _per_template(template_strokes, np.int64, order, n, 'template_strokes',
                                               '>= 1 strokes', lambda a: (a >= 1).all())
        self.template_contact_s_ = _per_template(template_contact_s, np.float64, order, n, 'template_contact_s',
                                                 'a time')
        self.template_sizes_mm_ = _per_template(template_sizes_mm, np.float64, order, n, 'template_sizes_mm',
                                                'a size >= 0 mm (NaN: not known)', lambda a: not (a < 0).any())
        self.template_people_ = None if template_people is None else _per_template(
            [str(p) for p in template_people], str, order, n, 'template_people', 'who drew it')
        self.codebook_evidence_ = CodebookEvidence(self.template_labels_, len(classes), self.template_strokes_,
                                          self.template_contact_s_)
        self.template_paths_ = self.order_evidence_ = None
        if template_paths is not None and not self.direction_aware and self.max_distance is not None:
            paths = np.asarray(template_paths, dtype=np.float64)
            if paths.ndim != 3 or len(paths) != len(labels):
                raise ValueError(f'template_paths must give each of the {len(labels)} templates an (n, 2) path; '
                                 f'got {paths.shape}')
            self.template_paths_ = paths[order]
            self.order_evidence_ = OrderEvidence(self.template_paths_, self.template_labels_, len(classes),
                                                 self.auto_scale, self.auto_quantile)
        self._prepare_codebook()
        self.acceptance_ = self._acceptance_scales = None
        self._acceptance_limit = math.inf
        if class_thresholds is None:
            self.class_thresholds_ = self._rejection_thresholds()
        else:
            thresholds = np.asarray(class_thresholds, dtype=np.float64).reshape(-1)
            if thresholds.shape != classes.shape or np.isnan(thresholds).any():
                raise ValueError(f'class_thresholds must hold one number per class ({len(classes)}); got '
                                 f'{thresholds.shape}')
            self.class_thresholds_ = thresholds
        if acceptance is not None:
            self.set_acceptance(acceptance)

    def set_acceptance(self, record: dict) -> None:
        """Decide by a calibrated score (module doc): ``record`` holds ``'class_scales'`` (n_classes floats > 0, in
        sorted class order) and ``'max_score'`` (>= 0, None: no limit but a negative margin), and whatever else
        the calibration says of itself (kept as ``acceptance_``).

        Raises:
            ValueError: no codebook yet, or scales or limit out of range.
        """
        self._check_fitted()
        scales = np.asarray(record.get('class_scales', ()), dtype=np.float64).reshape(-1)
        limit = record.get('max_score')
        if scales.shape != self.classes_.shape or not (np.all(np.isfinite(scales)) and np.all(scales > 0)):
            raise ValueError(f'an acceptance needs one class scale > 0 per class ({len(self.classes_)}); got '
                             f'{record.get("class_scales")!r}')
        if limit is not None and (isinstance(limit, bool) or not isinstance(limit, (int, float))
                                  or not 0 <= limit < math.inf):
            raise ValueError(f'an acceptance needs a max_score >= 0 (or None); got {limit!r}')
        weights = np.asarray(record.get('score_weights', PRODUCT_WEIGHTS), dtype=np.float64).reshape(-1)
        # The distance features' weights, then those of the first K context features (a codebook calibrated
        # before a feature existed has fewer).
        sizes = (len(PRODUCT_WEIGHTS), len(PRODUCT_WEIGHTS) + len(CONTEXT_FEATURES))
        if not sizes[0] <= len(weights) <= sizes[1] or not np.all(np.isfinite(weights)):
            raise ValueError(f'an acceptance needs {sizes[0]} to {sizes[1]} finite score_weights (.doubt); got '
                             f'{record.get("score_weights")!r}')
        self.acceptance_ = dict(record)
        self._acceptance_scales = scales.tolist()
        self._acceptance_weights = None if 'score_weights' not in record else weights.tolist()
        self._acceptance_limit = math.inf if limit is None else float(limit)
        self._acceptance_habits = None if len(weights) == sizes[0] else ClassHabits(
            self.template_labels_, len(self.classes_), self.template_strokes_, self.template_contact_s_,
            getattr(self, 'template_sizes_mm_', None))

    def opinions(self, gesture: TouchGesture, deciding: np.ndarray | None = None
                 ) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(n_classes,) distances of ``gesture`` to each class by each opinion this recogniser asks: the deciding
        one's (``deciding`` when already known) and a second one's (None here; the fused recogniser's trace)."""
        return (self.class_distances(gesture) if deciding is None else deciding), None

    def class_distances(self, gesture: TouchGesture) -> np.ndarray | None:
        """(n_classes,) float64 distance to the nearest template of each class, or None if unusable."""
        self._check_fitted()
        query = self.features(gesture)
        if query is None:
            return None
        return self.query_class_distances(query)

    def query_class_distances(self, query: np.ndarray) -> np.ndarray:
        """(n_classes,) float64 distance to the nearest template of each class for a query's features
        (``features``' output): one query against recognisers that differ in codebook only."""
        return np.minimum.reduceat(self.distances(query), self.class_starts_).astype(np.float64, copy=False)

    def predict(self, gesture: TouchGesture) -> Match:
        """The nearest class of ``gesture`` with its distance and margin, or a rejection."""
        return self._predict(gesture, _no_step)

    def _predict(self, gesture: TouchGesture, step: Callable[[str], None]) -> Match:
        """:meth:`predict`, calling ``step(name)`` after each of its steps (:data:`PREDICT_STEPS`; a step
        may end twice, a step not reached never): what ``social-touch bench skin`` times."""
        self._check_fitted()
        query = self._query_features(gesture)
        step('features')
        if query is None:
            return Match(None, float('inf'), 0.0, None, 'unusable')
        distances = self.distances(query)
        step('search')
        per_class = np.minimum.reduceat(distances, self.class_starts_).astype(np.float64, copy=False)
        step('minima')
        evidence = getattr(self, 'codebook_evidence_', None)
        allowed = evidence.allowed(gesture) if evidence is not None else None
        if allowed is not None and (allowed.all() or not allowed.any()):
            allowed = None   # every class fits, or none does (the evidence check below rejects it)
        step('evidence')
        named, second = self._named(gesture, per_class, allowed)
        match, best = self._decide(per_class, named, allowed, gesture, second)
        step('decision')
        if match.label is None:
            return match
        reason = evidence.check(gesture, best) if evidence is not None else None
        step('evidence')
        order = getattr(self, 'order_evidence_', None)
        if reason is None and order is not None:
            reason = order.check(gesture, best, self.one_stroke_path_of(gesture, query))
            step('order')
        if reason is not None:
            return Match(None, match.distance, match.margin, match.nearest, reason)
        return match

    def one_stroke_path_of(self, gesture: TouchGesture, query: np.ndarray) -> np.ndarray | None:
        """The order check's path of ``gesture`` (:func:`~.order_evidence.one_stroke_path`) when the
        features ``query`` already hold it, else None (the check computes it)."""
        return None

    def decide(self, per_class: np.ndarray) -> Match:
        """Apply the rejection rule to per-class distances (n_classes,)."""
        return self._decide(per_class)[0]

    def _query_features(self, gesture: TouchGesture) -> np.ndarray | None:
        """The features :meth:`predict` hands to ``distances`` (default: all of ``features``)."""
        return self.features(gesture)

    def _named(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None
               ) -> tuple[int, np.ndarray | None]:
        """:meth:`_nearest`, and the second opinion's (n_classes,) distances of ``gesture`` (``opinions()[1]``)
        for the score's context: a recogniser whose naming reads the second opinion hands it on rather than
        search the codebook for it again (:mod:`.fused`)."""
        return self._nearest(gesture, per_class, allowed), self.opinions(gesture, per_class)[1]

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        """Index of the class :meth:`predict` names: the nearest of those ``allowed`` ((n_classes,) bool,
        at least one; None: all). A subclass may ask other opinions (:mod:`.fused`)."""
        return nearest_allowed(per_class, allowed)

    def deciding_recogniser(self) -> TemplateRecogniser:
        """The fitted recogniser whose distances and codebook this one's decisions rest on: itself; for a
        recogniser made of others, the part whose distances decide (the fused recogniser's cloud). Early
        candidates and the end of a gesture match prefixes of its templates (:mod:`.early`, :mod:`.ending`)."""
        return self

    def _decide(self, per_class: np.ndarray, best: int | None = None, allowed: np.ndarray | None = None,
                gesture: TouchGesture | None = None, second: np.ndarray | None = None) -> tuple[Match, int]:
        """:meth:`decide` of the class ``best`` (default: the nearest), with its index (for the evidence
        checks of :meth:`predict`). The margin is over the nearest other class of all: negative when
        ``best`` is not the nearest, which the margin rule then rejects; as ``'strokes'`` where the nearest
        is a class ``allowed`` ((n_classes,) bool) rules out (the touch is nearer a symbol written with
        another number of strokes). A score with context features reads them off ``gesture`` (none: 0) and
        ``second``, the second opinion's distances of it (:meth:`_named`; None: there is none)."""
        if best is None:
            best = int(np.argmin(per_class))
        distances = per_class.tolist()
        d1 = distances[best]
        # The runner-up is the smallest of the others (NaN only where d1 is NaN too: argmin takes a NaN
        # first, and the margin is NaN whatever the runner-up).
        margin = min(distances[:best] + distances[best + 1:]) - d1 if len(distances) > 1 else float('inf')
        nearest = str(self.classes_[best])
        scales = getattr(self, '_acceptance_scales', None)
        if scales is not None:
            weights = getattr(self, '_acceptance_weights', None)
            habits = getattr(self, '_acceptance_habits', None)
            context = () if habits is None else [0.0] * len(CONTEXT_FEATURES) if gesture is None else \
                context_features(habits, best, gesture.strokes, gesture.contact_s, second,
                                 touch_size_mm(gesture.trajectory) if len(weights) > _SIZE_WEIGHT else math.nan)
            score = (acceptance_score(d1, margin, scales[best]) if weights is None
                     else doubt(distances, best, scales, weights, context))
            if margin >= 0 and not score > self._acceptance_limit:
                return Match(nearest, d1, margin, nearest, None), best
            ruled_out = margin < 0 and allowed is not None and not allowed[int(np.argmin(per_class))]
            return Match(None, d1, margin, nearest, 'strokes' if ruled_out else
                         'margin' if margin < 0 else 'score'), best
        if not d1 <= self.class_thresholds_[best]:
            return Match(None, d1, margin, nearest, 'distance'), best
        if margin < self.min_margin * d1:
            ruled_out = margin < 0 and allowed is not None and not allowed[int(np.argmin(per_class))]
            return Match(None, d1, margin, nearest, 'strokes' if ruled_out else 'margin'), best
        return Match(nearest, d1, margin, nearest, None), best

    def predict_many(self, gestures: Sequence[TouchGesture]) -> list[Match]:
        return [self.predict(g) for g in gestures]

    def score(self, gestures: Sequence[TouchGesture], labels: Sequence[Any]) -> float:
        """Fraction recognised correctly (a rejection counts as wrong)."""
        if len(gestures) == 0:
            raise ValueError('score needs at least one gesture')
        hits = sum(m.label == str(y) for m, y in zip(self.predict_many(gestures), labels, strict=True))
        return hits / len(gestures)

    # ----------------------------------------------------------------- helpers
    def _check_fitted(self) -> None:
        if not hasattr(self, 'templates_'):
            raise NotFittedError(f'this {type(self).__name__} has no codebook yet; call fit(gestures, labels) '
                                 'or load a codebook first')

    def _check_params(self) -> None:
        md = self.max_distance
        if not (md is None or md == 'auto' or (isinstance(md, (int, float)) and md >= 0)):
            raise ValueError(f"max_distance must be 'auto', None (no limit) or a distance >= 0; got {md!r}")
        if not (np.isfinite(self.auto_scale) and self.auto_scale > 0):
            raise ValueError(f'auto_scale must be > 0, got {self.auto_scale!r}')
        if not 0 <= self.auto_quantile <= 1:
            raise ValueError(f'auto_quantile must be in [0, 1], got {self.auto_quantile!r}')
        if not (np.isfinite(self.min_margin) and self.min_margin >= 0):
            raise ValueError(f'min_margin must be >= 0, got {self.min_margin!r}')

    def _rejection_thresholds(self) -> np.ndarray:
        """(n_classes,) distance thresholds for the current codebook (module doc)."""
        n = len(self.classes_)
        md = self.max_distance
        if md is None:
            return np.full(n, np.inf)
        if md != 'auto':
            return np.full(n, float(md))
        within, between = self._loo_distances()
        scales = np.full(n, np.nan)
        for c in range(n):
            own = within[self.template_labels_ == c]
            own = own[np.isfinite(own)]  # NaN: not sampled; inf: the class's only template
            if own.size:
                scales[c] = np.quantile(own, self.auto_quantile)
        if np.isnan(scales).all():
            finite = between[np.isfinite(between)]  # drops NaN and inf
            if not finite.size:
                return np.full(n, np.inf)  # one template in all: nothing to calibrate against
            return np.full(n, 0.5 * finite.min())
        scales[np.isnan(scales)] = np.median(scales[~np.isnan(scales)])
        return self.auto_scale * scales

    def _loo_distances(self, per_class: int = 40) -> tuple[np.ndarray, np.ndarray]:
        """(T,) each template's distance to the nearest other template of its class and (T,) to
        the nearest template of another class; NaN for templates not sampled (at most
        ``per_class`` evenly spaced templates per class are, which bounds the cost of a big
        codebook to n_classes x per_class recognitions), inf where there is no such template."""
        T = len(self.templates_)
        within, between = np.full(T, np.nan), np.full(T, np.nan)
        bounds = np.r_[self.class_starts_, T]
        for lo, hi in itertools.pairwise(bounds):
            for i in np.unique(np.linspace(lo, hi - 1, min(hi - lo, per_class)).astype(np.intp)):
                d = np.asarray(self.distances(self.templates_[i]), dtype=np.float64)
                same = self.template_labels_ == self.template_labels_[i]
                other = ~same
                same[i] = False
                within[i] = d[same].min() if same.any() else np.inf
                between[i] = d[other].min() if other.any() else np.inf
        return within, between


def _per_template(values: Sequence[Any] | None, dtype: Any, order: np.ndarray, n: int, name: str, what: str,
                  valid: Callable[[np.ndarray], bool] = lambda a: True) -> np.ndarray | None:
    """``values`` (n,) of one per template, in the codebook's ``order``; None for None; ValueError naming
    ``name`` and ``what`` each template must have when the shape is wrong or ``valid`` fails."""
    if values is None:
        return None
    column = np.asarray(values, dtype=dtype).reshape(-1)
    if column.shape != (n,) or not valid(column):
        raise ValueError(f'{name} must give each of the {n} templates {what}; got {column.shape}')
    return column[order]


def nearest_allowed(per_class: np.ndarray, allowed: np.ndarray | None) -> int:
    """Index of the smallest of (n_classes,) ``per_class`` among those ``allowed`` ((n_classes,) bool, at least
    one; None: all)."""
    return int(np.argmin(per_class if allowed is None else np.where(allowed, per_class, np.inf)))


def acceptance_score(distance: float, margin: float, scale: float) -> float:
    """How doubtful a touch is for its named class: ``distance / scale`` (how far from the class, in the class's
    own scale) times ``distance / (distance + margin)`` (its distance over the runner-up's: 1 when two classes
    are equally close). 0 for an exact match; inf where the runner-up is no farther or a value is NaN (never accepted).

    >>> acceptance_score(1.0, 1.0, 2.0)
    0.25
    """
    runner_up = distance + margin
    if distance == 0:
        return 0.0
    return (distance / scale) * (distance / runner_up) if runner_up > 0 else math.inf


def _no_step(name: str) -> None:
    """:meth:`TemplateRecogniser.predict`'s steps, untimed."""
