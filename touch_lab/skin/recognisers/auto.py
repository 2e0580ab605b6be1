"""The recogniser a vocabulary needs, decided from its own codebook: :class:`AutoRecogniser`.

An order-free point cloud (:class:`~touch_gestures.skin.clouds.CloudRecogniser`) reads symbols people write
with their strokes in any order and direction; a direction-aware trace
(:class:`~touch_gestures.skin.proposed.TraceRecogniser`) is needed where the direction is the meaning (the
skin's ``line_left`` and ``line_right`` are one cloud). The codebook decides which:

- **people known** (two or more: ``codebook record --person``, or a trace file's subjects): leave one
  person out for each candidate; the higher mean per-class accuracy wins; within ``tie``, fewer wrong
  commands, then the ordered one (it is cheaper).
- **otherwise**: both recognise every template from the others (leave one template out, nearest
  neighbour, at most ``per_class`` a class). 1. If the order-free one confuses a class (accuracy below
  ``confused``) that the ordered one reads (``separated`` better), the ordered one. 2. Else a vocabulary
  with multi-stroke gestures gets the order-free ``fused`` (:mod:`touch_gestures.skin.fused`): a codebook
  cannot show how differently people order their strokes, leave-one-person-out does
  (docs/skin-multistroke.md). 3. Else the higher mean per-class accuracy, the ordered one within ``tie``.

Cost at fit time: ``n_classes x per_class`` recognitions per candidate.
"""

from __future__ import annotations

import itertools
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from touch_gestures.skin.base import Match, TemplateRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.registry import DEFAULT_RECOGNISER, MULTISTROKE_RECOGNISER, recogniser_from

from .registry import CANDIDATES

__all__ = ['AutoRecogniser', 'codebook_accuracy', 'person_out_accuracy']


def codebook_accuracy(recogniser: TemplateRecogniser, per_class: int = 20) -> np.ndarray:
    """(n_classes,) leave-one-template-out nearest-neighbour accuracy of a fitted recogniser.

    Each of at most ``per_class`` evenly spaced templates per class is matched against all the
    others; a class with a single template has nothing to be recognised from: NaN."""
    T = len(recogniser.templates_)
    bounds = np.r_[recogniser.class_starts_, T]
    out = np.full(len(recogniser.classes_), np.nan)
    for c, (lo, hi) in enumerate(itertools.pairwise(bounds)):
        if hi - lo < 2:
            continue
        picks = np.unique(np.linspace(lo, hi - 1, min(hi - lo, per_class)).astype(np.intp))
        hits = 0
        for i in picks:
            d = np.asarray(recogniser.distances(recogniser.templates_[i]), dtype=np.float64).copy()
            d[i] = np.inf
            hits += recogniser.template_labels_[int(np.argmin(d))] == c
        out[c] = hits / len(picks)
    return out


def person_out_accuracy(make: Callable[[], TemplateRecogniser], gestures: Sequence[TouchGesture],
                        labels: Sequence[Any], people: Sequence[str]) -> tuple[np.ndarray, np.ndarray, float]:
    """Leave-one-person-out: each person's gestures recognised by a codebook of everyone else's.

    Args:
        make: a new, unfitted recogniser (with its rejection).
        gestures, labels, people: the codebook's gestures, their names and who drew each.

    Returns:
        classes (n,) sorted; per-class accuracy (n,), right answers over the class's held-out gestures (NaN
        for a class only one person drew: nothing to hold out); wrong commands (accepted and not the
        gesture drawn) over all held-out gestures.
    """
    labels = np.asarray([str(x) for x in labels])
    people = np.asarray([str(p) for p in people])
    classes = np.unique(labels)
    right = np.zeros(len(classes))
    tried = np.zeros(len(classes))
    wrong = 0
    for person in np.unique(people):
        held = people == person
        others = ~held
        known = set(labels[others])
        if not others.any():
            continue
        model = make().fit([g for g, o in zip(gestures, others, strict=True) if o], labels[others])
        for gesture, label in zip((g for g, h in zip(gestures, held, strict=True) if h), labels[held], strict=True):
            if label not in known:
                continue                            # only this person drew it
            c = int(np.searchsorted(classes, label))
            answer = model.predict(gesture).label
            tried[c] += 1
            right[c] += answer == label
            wrong += answer is not None and answer != label
    with np.errstate(invalid='ignore', divide='ignore'):
        accuracy = np.where(tried > 0, right / np.maximum(tried, 1), np.nan)
    return classes, accuracy, wrong / max(tried.sum(), 1.0)


class AutoRecogniser(TemplateRecogniser):
    """Fits the ordered and the order-free recogniser and keeps the one the rule picks (module doc).

    Args:
        ordered, order_free: registry names of the direction-aware and the order-free recogniser.
        per_class: templates per class the rule tries.
        confused: an order-free accuracy below this confuses the class...
        separated: ...when the ordered one does at least this much better.
        tie: in a single-stroke vocabulary, accuracy difference below which the ordered one is kept.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, handed to the chosen one.

    Attributes (after fit):
        chosen_: the fitted recogniser in use; ``choice_`` its name; ``reason_``: which rule
        decided; ``method_``: ``'leave-one-person-out'`` or ``'leave-one-template-out'``;
        ``evidence_``: per candidate the per-class accuracies (class -> accuracy) the method measured,
        and ``wrong_``: per candidate its wrong commands on held-out people (leave-one-person-out only).
    """

    name = 'auto'

    def __init__(self, ordered: str = DEFAULT_RECOGNISER, order_free: str = MULTISTROKE_RECOGNISER,
                 per_class: int = 20,
                 confused: float = 0.75, separated: float = 0.25, tie: float = 0.005,
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.ordered = ordered
        self.order_free = order_free
        self.per_class = per_class
        self.confused = confused
        self.separated = separated
        self.tie = tie
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def fit(self, gestures: Sequence[TouchGesture], labels: Sequence[Any],
            people: Sequence[str] | None = None) -> AutoRecogniser:
        """Fit both candidates and keep one (module doc); ``people``: who drew each gesture, '' not known."""
        self._check_params()
        rejection = {k: getattr(self, k) for k in ('max_distance', 'auto_scale', 'auto_quantile', 'min_margin')}
        makers = {name: (lambda name=name: recogniser_from(CANDIDATES, name, rejection))
                  for name in (self.ordered, self.order_free)}
        ordered = makers[self.ordered]().fit(gestures, labels, people)
        free = makers[self.order_free]().fit(gestures, labels, people)
        known = [] if people is None else [str(p) for p in people]
        self.wrong_ = {}
        if len({p for p in known if p}) >= 2 and all(known):
            self.method_ = 'leave-one-person-out'
            measured = {name: person_out_accuracy(make, gestures, labels, known) for name, make in makers.items()}
            self.evidence_ = {name: dict(zip(m[0].tolist(), m[1].tolist(), strict=True))
                              for name, m in measured.items()}
            self.wrong_ = {name: m[2] for name, m in measured.items()}
            mean = {name: float(np.nanmean(m[1])) if np.isfinite(m[1]).any() else 0.0
                    for name, m in measured.items()}
            o, f = self.ordered, self.order_free
            if mean[f] > mean[o] + self.tie or (mean[f] >= mean[o] - self.tie and self.wrong_[f] < self.wrong_[o]):
                best = free
            else:
                best = ordered
            reason = (f'leave-one-person-out over {len(set(known))} people: {o} {mean[o]:.3f} right, '
                      f'{self.wrong_[o]:.3f} wrong; {f} {mean[f]:.3f} right, {self.wrong_[f]:.3f} wrong')
            self._keep(best, reason)
            return self
        self.method_ = 'leave-one-template-out'
        acc_o, acc_f = codebook_accuracy(ordered, self.per_class), codebook_accuracy(free, self.per_class)
        with np.errstate(invalid='ignore'):
            confused = (acc_f < self.confused) & (acc_o >= acc_f + self.separated)
        if confused.any():
            best, reason = ordered, 'direction: ' + ', '.join(map(str, ordered.classes_[confused]))
        elif ordered.max_strokes_ > 1:
            best, reason = free, 'multi-stroke vocabulary'
        else:
            mean_o = float(np.nanmean(acc_o)) if np.isfinite(acc_o).any() else 0.0
            mean_f = float(np.nanmean(acc_f)) if np.isfinite(acc_f).any() else 0.0
            best = free if mean_f > mean_o + self.tie else ordered
            reason = 'single-stroke vocabulary, codebook accuracy'
        self.evidence_ = {m.name: dict(zip(map(str, m.classes_), acc.tolist(), strict=True))
                          for m, acc in ((ordered, acc_o), (free, acc_f))}
        self._keep(best, reason)
        return self

    def _keep(self, best: TemplateRecogniser, reason: str) -> None:
        """Use ``best``: its codebook becomes this recogniser's."""
        self.chosen_, self.choice_, self.reason_ = best, best.name, reason
        for attr in ('classes_', 'templates_', 'template_labels_', 'class_starts_', 'n_features_in_',
                     'class_thresholds_', 'n_dropped_', 'max_strokes_', 'template_strokes_',
                     'template_contact_s_', 'codebook_evidence_', 'template_paths_', 'order_evidence_',
                     'template_people_'):
            setattr(self, attr, getattr(best, attr))
        self.direction_aware = best.direction_aware

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        return self.chosen_.features(gesture)

    def distances(self, query: np.ndarray) -> np.ndarray:
        return self.chosen_.distances(query)

    def predict(self, gesture: TouchGesture) -> Match:
        self._check_fitted()
        return self.chosen_.predict(gesture)

    def deciding_recogniser(self) -> TemplateRecogniser:
        return self.chosen_.deciding_recogniser()
