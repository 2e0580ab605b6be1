"""Rejection a user tunes in one number: the wrong-command rate it may cost (issue 26, item 2).

Leave-one-person-out inside the codebook (:func:`held_out_opinions`) gives each held-out template its
deciding distance to every class and the class named. From those:

- each class's **scale**: the :data:`SCALE_QUANTILE` quantile of its held-out templates' distances to it;
- a touch's **score** (:func:`touch_gestures.skin.doubt.doubt`): the odds that it fires no right command,
  a logistic model (:func:`fit_weights`) on distances in scale units and, where the calibration adds them,
  the touch's context (:data:`~touch_gestures.skin.doubt.CONTEXT_FEATURES`: the second opinion's disagreement,
  how plausible its strokes, duration and size are for the named class), fit on held-out templates named right
  against those named wrong and synthetic touches that are no gesture;
- the **limit**: the largest score keeping held-out wrong commands at most ``max_wrong_rate`` and
  no-gesture touches firing at most :data:`MAX_RANDOM_FIRING` (:func:`null_touches`).

Scales, weights and limit go into the recogniser (``acceptance_``) and the codebook file. Editing a
codebook or setting the old rejection parameters drops the calibration (``codebook calibrate`` again).
The held-out estimate reads templates: stroke evidence applies, duration and order checks do not. The
no-gesture touches (:func:`touch_sim.skin.stray.stray_touches`) are of another kind than the
evaluation's random touches (:func:`touch_sim.skin.synthetic.random_touches`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from types import SimpleNamespace

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser, nearest_allowed
from touch_gestures.skin.doubt import (
    CONTEXT_FEATURES,
    DOUBT_FEATURES,
    PRODUCT_WEIGHTS,
    ClassHabits,
    context_features,
    doubt_features,
    scores_of,
    touch_size_mm,
)
from touch_gestures.skin.fused import FusedRecogniser, sum_rule_nearest
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.screening import screen_gesture
from touch_gestures.skin.segmentation import default_gap_s
from touch_graph.cli.options import number
from touch_lab.skin.ending_eval import PIECE_GAP_S, join_pieces
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples
from touch_sim.skin.stray import stray_touches
from touch_sim.skin.traces import TraceSample

__all__ = ['MAX_RANDOM_FIRING', 'SCALE_QUANTILE', 'SCORE_CONTEXT', 'HeldOut', 'calibrate', 'calibrate_acceptance',
           'class_scales', 'cross_person_outcomes', 'fit_weights', 'habits_of', 'held_out_opinions', 'max_score',
           'null_touches', 'scores', 'skin_touches', 'touch_opinions', 'wrong_rate']

#: A class's scale is this quantile of its held-out templates' distances to it.
SCALE_QUANTILE = 0.9
#: The argparse type of ``--max-wrong-rate``: a share in [0, 0.5].
wrong_rate = number(low=0, high=0.5)
#: The share of random touches (:func:`null_touches`) the limit lets fire, counted as the evaluation counts (over
#: all touches; a screened one fires nothing): the issue's goal. A design constant chosen on the unistroke file.
MAX_RANDOM_FIRING = 0.03


@dataclass(frozen=True)
class HeldOut:
    """Opinions of a codebook on touches (N touches, C classes).

    Attributes:
        distances: (N, C) the deciding distance of each touch to each class (inf: a class the codebook that
            read it does not have).
        named: (N,) the class the recogniser names (its naming rule and stroke evidence).
        true: (N,) the touch's class (-1: a touch that is no gesture).
        people: (N,) who drew it ('' for random touches).
        context: (N, K) each touch's :data:`~touch_gestures.skin.doubt.CONTEXT_FEATURES` for its named class
            (None: all 0, no evidence).
    """

    distances: np.ndarray
    named: np.ndarray
    true: np.ndarray
    people: np.ndarray
    context: np.ndarray | None = None

    def subset(self, mask: np.ndarray) -> HeldOut:
        return HeldOut(self.distances[mask], self.named[mask], self.true[mask], self.people[mask],
                       None if self.context is None else self.context[mask])

    def context_of(self, names: Sequence[str]) -> np.ndarray:
        """(N, len(names)) the context features ``names`` (of :data:`~touch_gestures.skin.doubt.CONTEXT_FEATURES`)."""
        columns = [CONTEXT_FEATURES.index(n) for n in names]
        if self.context is None:
            return np.zeros((len(self.named), len(columns)))
        return self.context[:, columns]


def held_out_opinions(recogniser: TemplateRecogniser, per_class: int | None = None) -> HeldOut:
    """Each person's templates read by a codebook of everyone else's (module doc).

    Args:
        recogniser: a fitted recogniser whose codebook names at least two people (``template_people_``).
        per_class: read at most this many templates per class and person (evenly spaced; None: all), which
            bounds the cost of a big codebook.

    Raises:
        ValueError: the codebook does not say who drew its templates, or names fewer than two people.
    """
    people = getattr(recogniser, 'template_people_', None)
    known = sorted(set(people.tolist()) - {''}) if people is not None else []
    if len(known) < 2:
        raise ValueError('calibrating acceptance needs a codebook that names at least two people (record with '
                         f'--person); this one names {len(known)}')
    classes = recogniser.classes_
    labels = recogniser.template_labels_
    strokes = recogniser.template_strokes_
    contacts = getattr(recogniser, 'template_contact_s_', None)
    sizes = getattr(recogniser, 'template_sizes_mm_', None)
    rows, named, true, who, context = [], [], [], [], []
    for person in known:
        out = people == person
        keep = ~out
        sub = type(recogniser)(**recogniser.get_params())
        sub.set_codebook(recogniser.templates_[keep], classes[labels[keep]],
                         class_thresholds=np.full(len(np.unique(labels[keep])), np.inf),
                         template_strokes=None if strokes is None else strokes[keep],
                         template_contact_s=None if contacts is None else contacts[keep],
                         template_sizes_mm=None if sizes is None else sizes[keep])
        index = np.searchsorted(classes, sub.classes_)   # the sub-codebook's classes among all
        habits = habits_of(sub)
        for i in _spread(np.flatnonzero(out), labels, per_class):
            row = recogniser.templates_[i]
            d_sub = sub.query_class_distances(row)
            allowed = None if strokes is None else _allowed(sub, int(strokes[i]))
            d = np.full(len(classes), np.inf)
            d[index] = d_sub
            rows.append(d)
            second = _second_opinion(sub, row)
            best = _named(sub, d_sub, second, allowed)
            named.append(index[best])
            true.append(labels[i])
            who.append(person)
            context.append(context_features(habits, best, np.nan if strokes is None else int(strokes[i]),
                                            np.nan if contacts is None else float(contacts[i]), second,
                                            np.nan if sizes is None else float(sizes[i])))
    return HeldOut(np.array(rows), np.array(named), np.array(true), np.array(who),
                   np.array(context).reshape(-1, len(CONTEXT_FEATURES)))


def touch_opinions(recogniser: TemplateRecogniser, touches: Sequence[TouchGesture]) -> HeldOut:
    """The whole codebook's opinions of ``touches`` that are no gesture (screened ones left out: the skin
    node never reads them)."""
    rows, named, context = [], [], []
    habits = habits_of(recogniser)
    for touch in touches:
        if screen_gesture(touch) is not None:
            continue
        query = recogniser._query_features(touch)
        if query is None:
            continue
        per_class = recogniser.query_class_distances(query)
        evidence = getattr(recogniser, 'codebook_evidence_', None)
        allowed = None if evidence is None else _usable_mask(evidence.allowed(touch))
        rows.append(per_class)
        best = recogniser._nearest(touch, per_class, allowed)
        named.append(best)
        context.append(context_features(habits, best, touch.strokes, touch.contact_s,
                                        recogniser.opinions(touch, per_class)[1], touch_size_mm(touch.trajectory)))
    n_classes = len(recogniser.classes_)
    return HeldOut(np.array(rows).reshape(-1, n_classes), np.array(named, dtype=np.intp),
                   np.full(len(named), -1), np.full(len(named), ''),
                   np.array(context).reshape(-1, len(CONTEXT_FEATURES)))


def habits_of(recogniser: TemplateRecogniser) -> ClassHabits:
    """The :class:`~touch_gestures.skin.doubt.ClassHabits` of ``recogniser``'s codebook."""
    return ClassHabits(recogniser.template_labels_, len(recogniser.classes_), recogniser.template_strokes_,
                       getattr(recogniser, 'template_contact_s_', None),
                       getattr(recogniser, 'template_sizes_mm_', None))


def _allowed(sub: TemplateRecogniser, strokes: int) -> np.ndarray | None:
    evidence = sub.codebook_evidence_
    return _usable_mask(evidence.allowed(SimpleNamespace(strokes=strokes)))


def _usable_mask(allowed: np.ndarray | None) -> np.ndarray | None:
    """As :meth:`TemplateRecogniser.predict`: a mask that allows every class or none is no mask."""
    return None if allowed is None or allowed.all() or not allowed.any() else allowed


def _spread(indices: np.ndarray, labels: np.ndarray, per_class: int | None) -> list[int]:
    if per_class is None:
        return indices.tolist()
    out = []
    for c in np.unique(labels[indices]):
        own = indices[labels[indices] == c]
        out += own[np.unique(np.linspace(0, len(own) - 1, min(len(own), per_class)).astype(np.intp))].tolist()
    return out


def _second_opinion(sub: TemplateRecogniser, row: np.ndarray) -> np.ndarray | None:
    """``sub``'s second opinion (:meth:`~touch_gestures.skin.base.TemplateRecogniser.opinions`) of a template's
    features ``row``: the fused recogniser's trace of the order traced; None for a recogniser of one opinion."""
    if isinstance(sub, FusedRecogniser):
        start = sub.cloud_width
        return sub.trace_.query_class_distances(row[start:start + 2 * sub.trace_points])
    return None


def _named(sub: TemplateRecogniser, per_class: np.ndarray, second: np.ndarray | None,
           allowed: np.ndarray | None) -> int:
    """The class ``sub`` names for a template (its ``_nearest`` without the gesture)."""
    if isinstance(sub, FusedRecogniser):
        return sum_rule_nearest(per_class, second, allowed)
    return nearest_allowed(per_class, allowed)


def class_scales(held: HeldOut, n_classes: int) -> np.ndarray:
    """(n_classes,) each class's :data:`SCALE_QUANTILE` quantile of its held-out templates' distances to it; the
    median of the others where a class has none (1 where no class has any)."""
    out = np.full(n_classes, np.nan)
    gestures = held.true >= 0
    own = held.distances[np.flatnonzero(gestures), held.true[gestures]]
    for c in range(n_classes):
        scores = own[(held.true[gestures] == c) & np.isfinite(own)]
        if scores.size:
            out[c] = np.quantile(scores, SCALE_QUANTILE)
    if np.isnan(out).all():
        return np.ones(n_classes)
    out[np.isnan(out)] = np.median(out[~np.isnan(out)])
    return np.maximum(out, np.finfo(np.float64).tiny)


def scores(held: HeldOut, scales: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """(N,) :func:`~touch_gestures.skin.doubt.doubt` of each touch with ``weights`` (default
    :data:`~touch_gestures.skin.doubt.PRODUCT_WEIGHTS`; longer ones go on with the context features); inf where the
    named class is not the nearest (a negative margin is rejected whatever the score)."""
    w = np.asarray(PRODUCT_WEIGHTS if weights is None else weights, dtype=np.float64)
    features, usable = _features(held, scales, CONTEXT_FEATURES[:len(w) - len(PRODUCT_WEIGHTS)])
    return scores_of(features, usable, w)


def _features(held: HeldOut, scales: np.ndarray, context: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~touch_gestures.skin.doubt.doubt_features` of ``held``, then its ``context`` features (an exact match
    stays all -inf)."""
    features, usable = doubt_features(held.distances, held.named, scales)
    if not context:
        return features, usable
    extra = held.context_of(context)
    exact = np.isneginf(features).all(axis=1)
    extra = np.where(exact[:, None], -np.inf, extra)
    return np.hstack([features, extra]), usable


#: The context features a calibration adds to the distance features (:func:`fit_weights`): those that helped
#: both ways across the development vocabularies with the weights fit on the codebook itself, as every
#: calibration fits them (docs/skin-rejection.md, "Across vocabularies"; the stroke count and the duration did
#: not). The size's weights do not carry from one vocabulary to another, which no calibration asks of them.
SCORE_CONTEXT: tuple[str, ...] = ('disagreement', 'size')
#: The L2 penalty of :func:`fit_weights` (on the weights of the features, not the intercept).
L2_PENALTY = 1e-2


def fit_weights(held: HeldOut, randoms: HeldOut, scales: np.ndarray, iterations: int = 30,
                context: Sequence[str] = ()) -> np.ndarray:
    """The score's logistic weights, intercept first (:data:`~touch_gestures.skin.doubt.DOUBT_FEATURES`, then
    with ``context`` (names of :data:`~touch_gestures.skin.doubt.CONTEXT_FEATURES`) all context features, those not
    named weighing 0): (5,) or (5 + K,). The odds of no right command, the held-out templates named right (0) against
    those named wrong and ``randoms`` (1), each side weighing half (Newton's method, :data:`L2_PENALTY`). The
    product's weights (:data:`~touch_gestures.skin.doubt.PRODUCT_WEIGHTS`, padded with 0) when either side has no
    touch that can be accepted."""
    unknown = set(context) - set(CONTEXT_FEATURES)
    if unknown:
        raise ValueError(f'unknown context features {sorted(unknown)}; known: {list(CONTEXT_FEATURES)}')
    used = [n for n in CONTEXT_FEATURES if n in context]
    columns = list(range(len(DOUBT_FEATURES))) + [len(DOUBT_FEATURES) + CONTEXT_FEATURES.index(n) for n in used]
    width = len(PRODUCT_WEIGHTS) + (len(CONTEXT_FEATURES) if context else 0)
    beta = _fit(held, randoms, scales, iterations, used)
    out = np.zeros(width)
    out[0] = beta[0]
    out[1 + np.array(columns)] = beta[1:]
    return out


def _fit(held: HeldOut, randoms: HeldOut, scales: np.ndarray, iterations: int, context: Sequence[str]) -> np.ndarray:
    """:func:`fit_weights` of the distance features and the ``context`` ones, in that order."""
    fh, uh = _features(held, scales, context)
    fr, ur = _features(randoms, scales, context)
    right = uh & (held.named == held.true)
    bad = np.r_[uh & ~right, ur]
    x = np.vstack([fh[right], np.vstack([fh, fr])[bad]])
    y = np.r_[np.zeros(right.sum()), np.ones(bad.sum())]
    finite = np.isfinite(x).all(axis=1)
    x, y = x[finite], y[finite]
    if not (y == 0).any() or not (y == 1).any():
        return np.r_[PRODUCT_WEIGHTS, np.zeros(len(context))]
    w = np.where(y == 0, 0.5 / np.sum(y == 0), 0.5 / np.sum(y == 1))
    design = np.column_stack([np.ones(len(x)), x])
    penalty = np.diag([0.0] + [L2_PENALTY] * x.shape[1])
    beta = np.zeros(design.shape[1])
    for _ in range(iterations):
        p = 1.0 / (1.0 + np.exp(-np.clip(design @ beta, -500, 500)))
        gradient = design.T @ (w * (p - y)) + penalty @ beta
        hessian = (design * (w * p * (1 - p))[:, None]).T @ design + penalty + 1e-9 * np.eye(len(beta))
        step = np.linalg.solve(hessian, gradient)
        beta -= step
        if np.abs(step).max() < 1e-8:
            break
    return beta


def _limit(values: np.ndarray, allowed: int) -> float:
    """The largest limit that lets at most ``allowed`` of ``values`` (the scores of touches that must not fire)
    pass: just below the (allowed+1)-th smallest; inf when there are no more."""
    values = np.sort(values[np.isfinite(values)])
    return math.inf if allowed >= values.size else float(np.nextafter(values[allowed], -np.inf))


def max_score(held: HeldOut, randoms: HeldOut, scales: np.ndarray, max_wrong_rate: float,
              random_touches: int | None = None, weights: np.ndarray | None = None) -> float:
    """The limit of the score (module doc, with ``weights`` as :func:`scores`): the wrong commands of ``held`` at
    most ``max_wrong_rate`` of its templates, the random touches ``randoms`` firing at most
    :data:`MAX_RANDOM_FIRING` of ``random_touches`` (all that were made, screened ones included; default:
    ``randoms``' count)."""
    s = scores(held, scales, weights)
    wrong = s[held.named != held.true]
    limit = _limit(wrong, math.floor(max_wrong_rate * len(held.true)))
    if len(randoms.named):
        total = len(randoms.named) if random_touches is None else random_touches
        limit = min(limit, _limit(scores(randoms, scales, weights), math.floor(MAX_RANDOM_FIRING * total)))
    return limit


def cross_person_outcomes(held: HeldOut, randoms: HeldOut, max_wrong_rate: float,
                          random_touches: int | None = None, model: bool = True,
                          context: Sequence[str] = ()) -> np.ndarray:
    """(N,) what each held-out template gets, judged by scales, weights (``model``, with the ``context`` features
    of :func:`fit_weights`; else the product's) and a limit set from everyone else's: 1 the right command, -1 a
    wrong one, 0 rejected."""
    n_classes = held.distances.shape[1]
    accepted = np.zeros(len(held.true), dtype=bool)
    for person in np.unique(held.people):
        mine = held.people == person
        rest = held.subset(~mine)
        scales = class_scales(rest, n_classes)
        weights = fit_weights(rest, randoms, scales, context=context) if model else None
        accepted[mine] = scores(held.subset(mine), scales, weights) <= max_score(
            rest, randoms, scales, max_wrong_rate, random_touches, weights)
    return np.where(accepted, np.where(held.named == held.true, 1, -1), 0)


def null_touches(count: int = 300, seed: int = 7, gap_s: float = 0.15) -> list[TouchGesture]:
    """``count`` synthetic touches that are no gesture (:func:`touch_sim.skin.stray.stray_touches`, not the
    evaluation's generator) through the virtual skin, cut where a lift lasts ``gap_s``."""
    return skin_touches(stray_touches(count, seed=seed), seed + 10**6, gap_s)


def skin_touches(samples: Sequence[TraceSample], render_seed: int, gap_s: float) -> list[TouchGesture]:
    """Synthetic touches (traces in mm on the skin) through the virtual skin with sensor noise seed
    ``render_seed``, cut where a lift lasts ``gap_s``; a touch cut short by the trace's end is left out."""
    rendered = render_samples(samples, RenderSettings(
        mode='sensor', placement='mm', seed=render_seed, gap_s=PIECE_GAP_S, min_frames=1), default_cache_dir())
    return [g for r in rendered for g in join_pieces(r.gestures, gap_s)[0] if not g.truncated]


def calibrate_acceptance(recogniser: TemplateRecogniser, max_wrong_rate: float,
                         randoms: Sequence[TouchGesture] = (), per_class: int | None = None,
                         held: HeldOut | None = None, model: bool = True,
                         context: Sequence[str] = SCORE_CONTEXT) -> TemplateRecogniser:
    """Set ``recogniser``'s acceptance for at most ``max_wrong_rate`` wrong commands (module doc); returns it.

    Args:
        recogniser: fitted, its codebook naming at least two people.
        max_wrong_rate: the share of gestures of new people that may fire a wrong command, in [0, 1).
        randoms: touches that are no gesture (:func:`null_touches`), kept at :data:`MAX_RANDOM_FIRING`; none: only
            the wrong commands set the limit.
        per_class: as :func:`held_out_opinions`.
        held: opinions already computed for this codebook (skips :func:`held_out_opinions`).
        model: fit the score's weights (:func:`fit_weights`); False: the product score (distance over scale
            times the ratio to the runner-up), as codebooks calibrated before the model.
        context: the context features the model adds (:func:`fit_weights`; () the four distance features alone).

    Raises:
        ValueError: a rate out of range, or a codebook without two people.
    """
    if isinstance(max_wrong_rate, bool) or not (isinstance(max_wrong_rate, (int, float)) and 0 <= max_wrong_rate < 1):
        raise ValueError(f'max_wrong_rate must be a share in [0, 1), e.g. 0.005; got {max_wrong_rate!r}')
    # A recogniser that keeps another's codebook (the lab's auto) decides with that one's thresholds.
    target = getattr(recogniser, 'chosen_', recogniser)
    if held is None:
        held = held_out_opinions(target, per_class)
    null = touch_opinions(target, randoms)
    scales = class_scales(held, len(target.classes_))
    weights = fit_weights(held, null, scales, context=context) if model else None
    if weights is not None:
        # Context features that weigh nothing (not asked for, or one opinion's disagreement) are left off the
        # record, so the robot does not compute them.
        weighing = np.flatnonzero(weights[len(PRODUCT_WEIGHTS):])
        weights = weights[:len(PRODUCT_WEIGHTS) + (weighing[-1] + 1 if weighing.size else 0)]
    limit = max_score(held, null, scales, max_wrong_rate, len(randoms), weights)
    outcome = cross_person_outcomes(held, null, max_wrong_rate, len(randoms), model, context)
    fired = float(np.sum(scores(null, scales, weights) <= limit) / len(randoms)) if len(randoms) else None
    record = {'max_wrong_rate': float(max_wrong_rate), 'max_score': limit if math.isfinite(limit) else None,
              'class_scales': scales.tolist(), 'scale_quantile': SCALE_QUANTILE,
              **({} if weights is None else {'score': 'odds of no right command (logistic)',
                                             'score_features': list(DOUBT_FEATURES) + list(
                                                 CONTEXT_FEATURES[:len(weights) - len(PRODUCT_WEIGHTS)]),
                                             'score_weights': weights.tolist()}),
              'max_random_firing': MAX_RANDOM_FIRING, 'random_touches': len(randoms), 'random_fired': fired,
              'held_out': len(held.true), 'people': len(np.unique(held.people)),
              'right': float(np.mean(outcome == 1)), 'wrong': float(np.mean(outcome == -1)),
              'rejected': float(np.mean(outcome == 0))}
    target.set_acceptance(record)
    if target is not recogniser:   # auto mirrors its choice
        recogniser.acceptance_ = target.acceptance_
    return recogniser


def calibrate(model: TemplateRecogniser, max_wrong_rate: float, gap_s: float | None = None,
              say: Callable[[str], None] | None = None) -> TemplateRecogniser:
    """What the codebook tools run: :func:`calibrate_acceptance` of ``model`` with :func:`null_touches` cut at
    ``gap_s`` (default: the vocabulary's gap), saying what it found."""
    gap = default_gap_s(int(getattr(model, 'max_strokes_', 1))) if gap_s is None else gap_s
    calibrate_acceptance(model, max_wrong_rate, null_touches(gap_s=gap))
    if say is not None:
        r = model.acceptance_
        say(f'acceptance calibrated for {max_wrong_rate:.2%} wrong commands, leave-one-person-out over {r["people"]} '
            f'people: {r["right"]:.2%} right, {r["wrong"]:.2%} wrong, {r["rejected"]:.2%} rejected; random touches '
            f'firing {r["random_fired"]:.2%} of {r["random_touches"]} (synthetic)')
    return model
