"""Leave-one-subject-out evaluation of the skin recognisers (issue 6, item 5).

Per held-out subject, each recogniser gets a codebook of the others' gestures (all, or
``templates_per_gesture`` per gesture). Reported per recogniser:

- **accuracy**: the nearest class is right (a sample not cut into exactly one gesture is wrong);
- with rejection: **accuracy_with_rejection**, **rejection rate**, **error rate** (a wrong command);
- the **confusion matrix** (with a ``<segmentation>`` column);
- **per-performer** rates R_{i,h}, per gesture their mean mu_h (cirillo2017 eq. 9) and population
  standard deviation sigma_h (eq. 8);
- **us per recognition**: median wall time of one ``predict``;
- **random-touch acceptance**: random touches that fire a command, over all folds (screened touches,
  :func:`~touch_gestures.skin.screening.screen_gesture`, fire nothing);
- with ``segment`` (:mod:`.ending_eval`): the samples cut per fold and recogniser, and each whole
  one's **latency**;
- **losses**: the genuine gestures that fired no right command, counted by the first reason
  (:data:`LOSS_REASONS`, :func:`loss_reason`), so that they add up to ``samples - accepted_correct``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from touch_gestures.skin.base import Match, TemplateRecogniser
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.screening import screen_gesture
from touch_sim.skin.render import RenderedSample

__all__ = ['LOSS_REASONS', 'REJECTED', 'SEGMENTATION', 'RecogniserResult', 'choose_codebook', 'format_losses',
           'leave_one_subject_out', 'loss_reason']

REJECTED = '<rejected>'
SEGMENTATION = '<segmentation>'

#: Why a genuine gesture fired no right command, the first that applies, in this order:
#: ``split``: the segmenter cut the sample into more than one gesture; ``no_gesture``: into none (each
#: sample is cut on its own, so a sample merged with the next cannot happen here);
#: ``named_wrong``: the nearest class (the one named) is not the sample's, rejected or not;
#: ``disagreement``: named right but rejected because the deciding distances put another class first
#: (a negative margin; for ``fused``, the cloud disagrees with the sum rule);
#: ``strokes``, ``duration``, ``order``: rejected by that evidence check (:mod:`touch_gestures.skin.evidence`,
#: :mod:`touch_gestures.skin.order_evidence`); ``threshold``: by the distance, margin or calibrated score
#: limits; ``screened``: the node screens the touch out (a dab, two fingers); ``unusable``: no features.
LOSS_REASONS = ('split', 'no_gesture', 'named_wrong', 'disagreement', 'strokes', 'duration', 'order', 'threshold',
                'screened', 'unusable')

_THRESHOLD_REASONS = frozenset({'distance', 'margin', 'score'})


@dataclass
class RecogniserResult:
    """What :func:`leave_one_subject_out` measured for one recogniser (see the module doc)."""

    name: str
    samples: int = 0
    correct: int = 0
    accepted_correct: int = 0
    rejected: int = 0
    segmentation_failures: int = 0
    us_per_recognition: float = float('nan')
    us_p90: float = float('nan')
    codebook_size: float = 0.0
    confusion: dict[str, dict[str, int]] = field(default_factory=dict)
    per_performer: dict[str, dict[str, float]] = field(default_factory=dict)
    random_touches: int = 0
    random_accepted: int = 0
    choices: dict[str, int] = field(default_factory=dict)   # 'auto': the recogniser its rule chose, per fold
    screened: int = 0                                       # held-out samples screened out (counted as rejected)
    latencies_s: list[float] = field(default_factory=list)  # with ``segment``: per whole sample, s
    acceptance: list[dict] = field(default_factory=list)    # with ``calibrate``: each fold's calibration record
    losses: dict[str, int] = field(default_factory=lambda: dict.fromkeys(LOSS_REASONS, 0))

    @property
    def accuracy(self) -> float:
        return self.correct / self.samples if self.samples else float('nan')

    @property
    def accuracy_with_rejection(self) -> float:
        return self.accepted_correct / self.samples if self.samples else float('nan')

    @property
    def rejection_rate(self) -> float:
        return self.rejected / self.samples if self.samples else float('nan')

    @property
    def error_rate(self) -> float:
        wrong = self.samples - self.accepted_correct - self.rejected - self.segmentation_failures
        return wrong / self.samples if self.samples else float('nan')

    @property
    def random_acceptance(self) -> float | None:
        return self.random_accepted / self.random_touches if self.random_touches else None

    def gesture_stats(self) -> dict[str, dict[str, float]]:
        """Per gesture h: ``mu`` (eq. 9) and ``sigma`` (eq. 8) of the performers' rates R_{i,h}."""
        gestures = sorted({g for rates in self.per_performer.values() for g in rates})
        out = {}
        for g in gestures:
            rates = np.array([r[g] for r in self.per_performer.values() if g in r], dtype=np.float64)
            mu = float(rates.mean())
            out[g] = {'mu': mu, 'sigma': float(np.sqrt(np.mean((rates - mu) ** 2)))}
        return out

    def to_dict(self) -> dict:
        return {
            'accuracy': self.accuracy, 'accuracy_with_rejection': self.accuracy_with_rejection,
            'rejection_rate': self.rejection_rate, 'error_rate': self.error_rate,
            'us_per_recognition': self.us_per_recognition, 'us_p90': self.us_p90,
            'codebook_size': self.codebook_size, 'samples': self.samples, 'correct': self.correct,
            'rejected': self.rejected, 'segmentation_failures': self.segmentation_failures,
            'random_touch_acceptance': self.random_acceptance, 'random_touches': self.random_touches,
            'per_gesture': self.gesture_stats(),
            'per_performer': {s: float(np.mean(list(r.values()))) for s, r in self.per_performer.items()},
            'confusion': self.confusion, **({'choices': self.choices} if self.choices else {}),
            'screened': self.screened, 'losses': dict(self.losses),
            'gestures_per_sample': dict(sorted(self.gestures_per_sample.items())),
            **({'latency_s': _summary(self.latencies_s)} if self.latencies_s else {}),
            **({'acceptance': [{k: a.get(k) for k in _ACCEPTANCE_KEYS} for a in self.acceptance]}
               if self.acceptance else {}),
        }

    gestures_per_sample: dict[str, int] = field(default_factory=dict)


#: What the JSON keeps of each fold's calibration record (:mod:`.acceptance`).
_ACCEPTANCE_KEYS = ('max_wrong_rate', 'max_score', 'right', 'wrong', 'rejected', 'random_fired', 'people', 'score',
                    'score_weights')


def loss_reason(label: str, cut: int, match: Match | None = None, screened: bool = False) -> str | None:
    """Why a genuine gesture of class ``label`` fired no right command (one of :data:`LOSS_REASONS`), or None
    when it did: the sample was cut into ``cut`` gestures; ``match`` is the recogniser's answer for the one
    gesture (None unless ``cut`` is 1); ``screened``: the node screened that gesture out.

    >>> loss_reason('x', 2)
    'split'
    >>> loss_reason('x', 1, Match(None, 0.5, -0.1, 'x', 'margin'))
    'disagreement'
    """
    if cut > 1:
        return 'split'
    if cut < 1 or match is None:
        return 'no_gesture'
    if match.rejected == 'unusable':
        return 'unusable'
    if match.nearest != label:
        return 'named_wrong'
    if screened:
        return 'screened'
    if match.label is not None:
        return None
    if match.rejected == 'margin' and match.margin < 0:
        return 'disagreement'
    if match.rejected in _THRESHOLD_REASONS:
        return 'threshold'
    return match.rejected if match.rejected in LOSS_REASONS else 'threshold'


def format_losses(losses: Mapping[str, int], samples: int) -> str:
    """One line of the counts of :data:`LOSS_REASONS` (those above 0) over ``samples`` genuine gestures.

    >>> format_losses({'split': 2, 'strokes': 0, 'duration': 1}, 300)
    'right commands lost: 3 of 300 (split 2, duration 1)'
    """
    shown = [f'{k} {n}' for k, n in losses.items() if n]
    return f'right commands lost: {sum(losses.values())} of {samples}' + (f' ({", ".join(shown)})' if shown else '')


def _summary(values: Sequence[float]) -> dict[str, float]:
    v = np.asarray(values, dtype=np.float64)
    return {'mean': float(v.mean()), 'median': float(np.median(v)), 'p90': float(np.percentile(v, 90))}


def _usable(r: RenderedSample) -> bool:
    return len(r.gestures) == 1 and not r.gestures[0].multi_contact and not r.gestures[0].truncated


def choose_codebook(train: Sequence[RenderedSample], per_gesture: int | None, rng: np.random.Generator
                    ) -> list[RenderedSample]:
    """The usable training samples, or ``per_gesture`` of each gesture spread evenly over the
    (subject, variant) groups (round robin over shuffled groups), so no person dominates."""
    usable = [r for r in train if _usable(r)]
    if per_gesture is None:
        return usable
    chosen = []
    for label in sorted({r.label for r in usable}):
        groups: dict[tuple[str, str], list[RenderedSample]] = {}
        for r in usable:
            if r.label == label:
                groups.setdefault((r.subject, r.variant), []).append(r)
        queues = [list(rng.permutation(len(g))) for g in groups.values()]
        members = list(groups.values())
        order = rng.permutation(len(members))
        picked = []
        while len(picked) < per_gesture and any(queues):
            for k in order:
                if queues[k] and len(picked) < per_gesture:
                    picked.append(members[k][queues[k].pop()])
        chosen += picked
    return chosen


def leave_one_subject_out(rendered: Sequence[RenderedSample],
                          factories: Mapping[str, Callable[[], TemplateRecogniser]],
                          templates_per_gesture: int | None = None, seed: int = 0,
                          random_rendered: Sequence[RenderedSample] = (),
                          progress: Callable[[str], None] | None = None,
                          segment: Callable[[RenderedSample, TemplateRecogniser],
                                            tuple[list[TouchGesture], list[float]]] | None = None,
                          calibrate: Callable[[TemplateRecogniser], object] | None = None,
                          ) -> dict[str, RecogniserResult]:
    """Evaluate every recogniser of ``factories`` (name -> a new unfitted recogniser).

    Args:
        rendered: samples through the skin (:func:`~touch_sim.skin.render.render_samples`).
        templates_per_gesture: codebook size per gesture per fold (None: every training sample).
        seed: seeds the choice of templates.
        random_rendered: touches that are no gesture, for the random-touch acceptance.
        progress: called with a line of text per fold and recogniser.
        segment: ``segment(sample, fitted_recogniser) -> (gestures, latencies_s)`` cuts a held-out
            sample again with the fold's recogniser (the end of a gesture, :mod:`.ending_eval`);
            None: the sample's own gestures (the codebook always uses those).
        calibrate: called with each fold's fitted recogniser before it reads the held-out subject (e.g. the
            acceptance calibration of :mod:`.acceptance`, from the fold's codebook alone).

    Raises:
        ValueError: fewer than two subjects (nothing to leave out), or no recogniser.
    """
    subjects = sorted({r.subject for r in rendered})
    if len(subjects) < 2:
        raise ValueError(f'leave-one-subject-out needs at least 2 subjects; got {subjects}')
    if not factories:
        raise ValueError('no recogniser to evaluate')
    labels = sorted({r.label for r in rendered})
    results = {name: RecogniserResult(name) for name in factories}
    for res in results.values():
        res.confusion = {lab: {} for lab in labels}
    times: dict[str, list[float]] = {name: [] for name in factories}
    sizes: dict[str, list[int]] = {name: [] for name in factories}
    random_gestures = [g for r in random_rendered for g in r.gestures if not g.truncated]
    for fold, subject in enumerate(subjects):
        train = [r for r in rendered if r.subject != subject]
        test = [r for r in rendered if r.subject == subject]
        codebook = choose_codebook(train, templates_per_gesture, np.random.default_rng([seed, fold]))
        if not codebook:
            raise ValueError(f'fold {subject}: no usable training gesture for the codebook')
        gestures = [r.gestures[0] for r in codebook]
        names = [r.label for r in codebook]
        for name, make in factories.items():
            res = results[name]
            start = time.perf_counter()
            recogniser = make().fit(gestures, names, [r.subject for r in codebook])
            sizes[name].append(len(recogniser.templates_))
            if calibrate is not None:
                calibrate(recogniser)
                res.acceptance.append(dict(getattr(recogniser, 'acceptance_', None) or {}))
            if hasattr(recogniser, 'choice_'):
                res.choices[recogniser.choice_] = res.choices.get(recogniser.choice_, 0) + 1
            hits: dict[str, list[bool]] = {}
            for r in test:
                res.samples += 1
                cut, latencies = segment(r, recogniser) if segment is not None else (r.gestures, [])
                n = str(len(cut))
                res.gestures_per_sample[n] = res.gestures_per_sample.get(n, 0) + 1
                match, screened = None, False
                if len(cut) != 1:
                    predicted = SEGMENTATION
                    res.segmentation_failures += 1
                else:
                    res.latencies_s += latencies
                    t0 = time.perf_counter()
                    match = recogniser.predict(cut[0])
                    times[name].append(time.perf_counter() - t0)
                    predicted = REJECTED if match.nearest is None else match.nearest
                    screened = screen_gesture(cut[0]) is not None
                    res.screened += screened
                    res.rejected += match.label is None or screened
                    res.accepted_correct += match.label == r.label and not screened
                reason = loss_reason(r.label, len(cut), match, screened)
                if reason is not None:
                    res.losses[reason] += 1
                ok = predicted == r.label
                res.correct += ok
                row = res.confusion[r.label]
                row[predicted] = row.get(predicted, 0) + 1
                hits.setdefault(r.label, []).append(ok)
            res.per_performer[subject] = {lab: float(np.mean(v)) for lab, v in sorted(hits.items())}
            for g in random_gestures:
                res.random_touches += 1
                res.random_accepted += screen_gesture(g) is None and recogniser.predict(g).label is not None
            if progress is not None:
                acc = np.mean([v for vs in hits.values() for v in vs]) if hits else float('nan')
                progress(f'fold {fold + 1}/{len(subjects)} (subject {subject}) {name}: accuracy {acc:.4f}, '
                         f'{time.perf_counter() - start:.1f} s')
    for name, res in results.items():
        if times[name]:
            us = np.asarray(times[name]) * 1e6
            res.us_per_recognition, res.us_p90 = float(np.median(us)), float(np.percentile(us, 90))
        res.codebook_size = float(np.mean(sizes[name]))
    return results
