"""Rejection a user tunes in one number: the wrong-command rate it may cost (issue 26, item 2).

Leave-one-person-out inside the codebook (:func:`held_out_opinions`) gives each held-out template its
deciding distance to every class and the class named. From those:

- each class's **scale**: the :data:`SCALE_QUANTILE` quantile of its held-out templates' distances to it;
- a touch's **score** (:func:`touch_gestures.skin.doubt.doubt`): the odds that it fires no right command,
  a logistic model (:func:`fit_weights`) on distances in scale units, fit on held-out templates named
  right against those named wrong and synthetic touches that are no gesture;
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
from touch_gestures.skin.doubt import DOUBT_FEATURES, PRODUCT_WEIGHTS, doubt_features, scores_of
from touch_gestures.skin.fused import FusedRecogniser, sum_rule_nearest
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.screening import screen_gesture
from touch_gestures.skin.segmentation import default_gap_s
from touch_graph.cli.options import number
from touch_lab.skin.ending_eval import PIECE_GAP_S, join_pieces
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples
from touch_sim.skin.stray import stray_touches
from touch_sim.skin.traces import TraceSample

__all__ = ['MAX_RANDOM_FIRING', 'SCALE_QUANTILE', 'HeldOut', 'calibrate', 'calibrate_acceptance', 'class_scales',
           'cross_person_outcomes', 'fit_weights', 'held_out_opinions', 'max_score', 'null_touches', 'scores',
           'skin_touches', 'touch_opinions', 'wrong_rate']

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
    """

    distances: np.ndarray
    named: np.ndarray
    true: np.ndarray
    people: np.ndarray

    def subset(self, mask: np.ndarray) -> HeldOut:
        return HeldOut(self.distances[mask], self.named[mask], self.true[mask], self.people[mask])


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
    rows, named, true, who = [], [], [], []
    for person in known:
        out = people == person
        keep = ~out
        sub = type(recogniser)(**recogniser.get_params())
        sub.set_codebook(recogniser.templates_[keep], classes[labels[keep]],
                         class_thresholds=np.full(len(np.unique(labels[keep])), np.inf),
                         template_strokes=None if strokes is None else strokes[keep])
        index = np.searchsorted(classes, sub.classes_)   # the sub-codebook's classes among all
        for i in _spread(np.flatnonzero(out), labels, per_class):
            row = recogniser.templates_[i]
            d_sub = sub.query_class_distances(row)
            allowed = None if strokes is None else _allowed(sub, int(strokes[i]))
            d = np.full(len(classes), np.inf)
            d[index] = d_sub
            rows.append(d)
            named.append(index[_named(sub, row, d_sub, allowed)])
            true.append(labels[i])
            who.append(person)
    return HeldOut(np.array(rows), np.array(named), np.array(true), np.array(who))


def touch_opinions(recogniser: TemplateRecogniser, touches: Sequence[TouchGesture]) -> HeldOut:
    """The whole codebook's opinions of ``touches`` that are no gesture (screened ones left out: the skin
    node never reads them)."""
    rows, named = [], []
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
        named.append(recogniser._nearest(touch, per_class, allowed))
    n_classes = len(recogniser.classes_)
    return HeldOut(np.array(rows).reshape(-1, n_classes), np.array(named, dtype=np.intp),
                   np.full(len(named), -1), np.full(len(named), ''))


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


def _named(sub: TemplateRecogniser, row: np.ndarray, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
    """The class ``sub`` names for a template's features ``row`` (its ``_nearest`` without the gesture)."""
    if isinstance(sub, FusedRecogniser):
        start = sub.cloud_width
        trace = sub.trace_.query_class_distances(row[start:start + 2 * sub.trace_points])
        return sum_rule_nearest(per_class, trace, allowed)
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
    :data:`~touch_gestures.skin.doubt.PRODUCT_WEIGHTS`); inf where the named class is not the nearest (a negative
    margin is rejected whatever the score)."""
    features, usable = doubt_features(held.distances, held.named, scales)
    return scores_of(features, usable, PRODUCT_WEIGHTS if weights is None else weights)


#: The L2 penalty of :func:`fit_weights` (on the weights of the features, not the intercept).
L2_PENALTY = 1e-2


def fit_weights(held: HeldOut, randoms: HeldOut, scales: np.ndarray, iterations: int = 30) -> np.ndarray:
    """(5,) the score's logistic weights, intercept first (:data:`~touch_gestures.skin.doubt.DOUBT_FEATURES`): the
    odds of no right command, the held-out templates named right (0) against those named wrong and ``randoms``
    (1), each side weighing half (Newton's method, :data:`L2_PENALTY`). The product's weights
    (:data:`~touch_gestures.skin.doubt.PRODUCT_WEIGHTS`) when either side has no touch that can be accepted."""
    fh, uh = doubt_features(held.distances, held.named, scales)
    fr, ur = doubt_features(randoms.distances, randoms.named, scales)
    right = uh & (held.named == held.true)
    bad = np.r_[uh & ~right, ur]
    x = np.vstack([fh[right], np.vstack([fh, fr])[bad]])
    y = np.r_[np.zeros(right.sum()), np.ones(bad.sum())]
    finite = np.isfinite(x).all(axis=1)
    x, y = x[finite], y[finite]
    if not (y == 0).any() or not (y == 1).any():
        return np.asarray(PRODUCT_WEIGHTS, dtype=np.float64)
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
                          random_touches: int | None = None, model: bool = True) -> np.ndarray:
    """(N,) what each held-out template gets, judged by scales, weights (``model``; else the product's) and a
    limit set from everyone else's: 1 the right command, -1 a wrong one, 0 rejected."""
    n_classes = held.distances.shape[1]
    accepted = np.zeros(len(held.true), dtype=bool)
    for person in np.unique(held.people):
        mine = held.people == person
        rest = held.subset(~mine)
        scales = class_scales(rest, n_classes)
        weights = fit_weights(rest, randoms, scales) if model else None
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
                         held: HeldOut | None = None, model: bool = True) -> TemplateRecogniser:
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
    weights = fit_weights(held, null, scales) if model else None
    limit = max_score(held, null, scales, max_wrong_rate, len(randoms), weights)
    outcome = cross_person_outcomes(held, null, max_wrong_rate, len(randoms), model)
    fired = float(np.sum(scores(null, scales, weights) <= limit) / len(randoms)) if len(randoms) else None
    record = {'max_wrong_rate': float(max_wrong_rate), 'max_score': limit if math.isfinite(limit) else None,
              'class_scales': scales.tolist(), 'scale_quantile': SCALE_QUANTILE,
              **({} if weights is None else {'score': 'odds of no right command (logistic)',
                                             'score_features': list(DOUBT_FEATURES),
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
