"""Train and evaluate the bear's subtype model from recorded sessions (``collect bear`` bags).

A session's ``/bear/frame`` messages go once through :class:`~touch_gestures.bear.pipeline.BearRecogniser`;
a trial's *touched sensors* are the fitted sensors that reached the activation threshold during it (or
the scan after), and every cycle of the trial on them carries the trial's subtype. Scoring per trial
as :func:`touch_lab.bear.evaluate.score_subtypes`, leave-one-person-out behind the ``NoTouchGate``;
pooled over all trials of all people (never a median of per-person medians).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.sensor_level import ACTIVATION_THRESHOLD
from touch_gestures.bear.subtype import PaperRuleClassifier
from touch_gestures.bear.subtype_labels import SUBTYPES, subtype_index
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.collect.coverage import read_checked
from touch_lab.collect.session_bag import LabelRow, SessionError, SessionRecording
from touch_sim.bear.people import split_label

__all__ = ['BearTrials', 'bear_trials', 'leave_one_person_out', 'pool_scores', 'score_trials', 'train_rows']


@dataclass
class BearTrials:
    """One session through the recogniser's features.

    Attributes:
        session: the bag it came from.
        times: (n,) float64 cycle times, s from the bag's first frame.
        features: (n, 64, F) float32 feature tables.
        truth: (n, 64) int8 subtype codes (0 = none) per channel, from the labels.
        labels: the subtype trials scored (labels of other names are left out).
        touched: per label, the channels that reached the threshold during it.
        fitted: (64,) bool sensors the body map fits.
        active: (n, 64) bool sensors active each cycle, as the recogniser sees them (level >= threshold,
            fitted, not faulty).
        gestures: the symbolic-gesture trials (labels ``symbolic/<gesture>``), for :mod:`.suggest`.
    """

    session: SessionRecording
    times: np.ndarray
    features: np.ndarray
    truth: np.ndarray
    labels: list[LabelRow]
    touched: list[np.ndarray]
    fitted: np.ndarray
    active: np.ndarray
    gestures: list[LabelRow]


def bear_trials(session: SessionRecording, rate_hz: float, buffer_len: int,
                warn: Callable[[str], None] | None = None) -> BearTrials:
    """Features and per-cycle truth of one bear session (module doc).

    Raises:
        SessionError: the bag's rate differs from ``rate_hz`` by more than 5 % (features depend on it).
    """
    say = warn or (lambda _m: None)
    measured = session.rate_hz('/bear/frame')
    if abs(measured / rate_hz - 1) > 0.05:
        raise SessionError(f'{session.path}: frames come at {measured:.3g} Hz, not {rate_hz:g} Hz; give --rate '
                           f'{measured:.3g} (the model is tied to the scan rate its features were computed at)')
    rec = BearRecogniser(rate_hz, buffer_len, named_outputs=False, subtypes=False, symbolic=False, classify=True)
    times = session.stamps_s['/bear/frame']
    n = len(times)
    frames = session.frames['/bear/frame']
    levels = np.zeros((n, 64), dtype=np.float32)
    active = np.zeros((n, 64), dtype=bool)
    features = None
    for i, msg in enumerate(frames):
        levels[i] = np.asarray(msg.level, dtype=np.float32)
        out = rec.update(float(times[i]), levels[i], np.asarray(msg.faults) != 0)
        if features is None:
            features = np.zeros((n, *out.features.table.shape), dtype=np.float32)
        features[i] = out.features.table
        active[i] = out.active
    truth = np.zeros((n, 64), dtype=np.int8)
    labels, touched, gestures = [], [], []
    for lab in session.labels:
        if split_label(lab.gesture)[0] == 'symbolic':
            gestures.append(lab)
            continue
        if lab.gesture not in SUBTYPES or lab.gesture == 'none':
            say(f'{session.path} at {lab.start_s:.2f} s: {lab.gesture!r} is not a touch subtype; left out')
            continue
        # A scan completes (and is stamped) up to one period after the readings in it: a short tap
        # shows in the cycle after it ended.
        inside = (times >= lab.start_s) & (times <= lab.end_s + 1.0 / rate_hz)
        channels = np.flatnonzero((levels[inside] >= ACTIVATION_THRESHOLD).any(axis=0) & rec.fitted)
        if not channels.size:
            say(f'{session.path} at {lab.start_s:.2f} s: no sensor reached the threshold during '
                f'{lab.person}\'s {lab.gesture!r}; scored as a miss, not trained on')
        truth[np.ix_(inside, channels)] = subtype_index(lab.gesture)
        labels.append(lab)
        touched.append(channels)
    return BearTrials(session, times, features, truth, labels, touched, rec.fitted, active, gestures)


def train_rows(runs: list[BearTrials], idle_fraction: float = 0.02, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Feature rows and codes: every fitted sensor-cycle under a trial or with a touch in its buffer,
    plus ``idle_fraction`` of the idle ones (as :func:`touch_lab.bear.evaluate.collect_training_rows`)."""
    rng = np.random.default_rng(seed)
    X, y = [], []
    for run in runs:
        F = run.features[:, run.fitted]
        codes = run.truth[:, run.fitted]
        keep = (codes > 0) | (F[:, :, 0] >= ACTIVATION_THRESHOLD) | (rng.random(codes.shape) < idle_fraction)
        X.append(F[keep])
        y.append(codes[keep])
    return np.concatenate(X), np.concatenate(y)


def score_trials(runs: list[BearTrials], predictor) -> dict:
    """Per-trial accuracy, confusion and median latency of ``predictor`` (``predict_codes``) on ``runs``."""
    truth, pred, latencies = [], [], []
    for run in runs:
        rows = run.features.reshape(-1, run.features.shape[-1])
        codes = predictor.predict_codes(rows)[0].reshape(run.features.shape[:2])
        codes[:, ~run.fitted] = 0
        for lab, channels in zip(run.labels, run.touched, strict=True):
            window = (run.times >= lab.start_s) & (run.times < lab.end_s + 1.0 / _rate(run))
            seen = codes[np.ix_(window, channels)].ravel()
            counts = np.bincount(seen[seen > 0], minlength=len(SUBTYPES))
            truth.append(lab.gesture)
            pred.append(SUBTYPES[int(counts.argmax())] if counts.any() else 'none')
            hit = (codes[np.ix_(window, channels)] == subtype_index(lab.gesture)).any(axis=1)
            if hit.any():
                latencies.append(float(run.times[window][int(np.argmax(hit))] - lab.start_s))
    confusion = np.zeros((len(SUBTYPES), len(SUBTYPES)), dtype=np.int64)
    for a, b in zip(truth, pred, strict=True):
        confusion[subtype_index(a), subtype_index(b)] += 1
    return {'trials': len(truth), 'correct': int(sum(a == b for a, b in zip(truth, pred, strict=True))),
            'accuracy': float(np.mean([a == b for a, b in zip(truth, pred, strict=True)])) if truth else None,
            'confusion': confusion, 'median_latency_s': float(np.median(latencies)) if latencies else None,
            'p90_latency_s': float(np.percentile(latencies, 90)) if latencies else None,
            'latencies_s': latencies}


def _rate(run: BearTrials) -> float:
    return run.session.rate_hz('/bear/frame')


#: Fewest sensor-cycles of a class to learn it from (about three seconds of one touch at 3.4 Hz).
MIN_CLASS_ROWS = 10


def fit_model(runs: list[BearTrials], seed: int = 0, drop_thin: Callable[[str], None] | None = None
              ) -> SubtypeClassifier:
    """The subtype model trained on ``runs``.

    A class with fewer than :data:`MIN_CLASS_ROWS` sensor-cycles is a SessionError naming it, or,
    with ``drop_thin`` (leave-one-person-out folds), left out and said through ``drop_thin(text)``.
    """
    X, y = train_rows(runs, seed=seed)
    counts = np.bincount(y, minlength=len(SUBTYPES))
    thin = [SUBTYPES[c] for c in np.unique(y) if counts[c] < MIN_CLASS_ROWS]
    for name in thin:
        text = (f'class {name!r} has {counts[subtype_index(name)]} sensor-cycle(s) to learn from (fewer than '
                f'{MIN_CLASS_ROWS}); record more trials of it (collect --gestures {name})')
        if drop_thin is None:
            raise SessionError(text)
        drop_thin(f'{text}; left out of this model')
    keep = ~np.isin(y, [subtype_index(n) for n in thin])
    return SubtypeClassifier().fit(X[keep], y[keep])


def fold_models(runs: list[BearTrials], people: list[str], seed: int = 0,
                progress: Callable[[str], None] | None = None) -> dict[str, SubtypeClassifier]:
    """Person -> the subtype model trained on the sessions without that person (leave-one-person-out)."""
    say = progress or (lambda _m: None)
    models = {}
    for i, person in enumerate(people):
        say(f'person {person} ({i + 1}/{len(people)}): training on the {len(people) - 1} others')
        others = [r for r in runs if not any(lab.person == person for lab in (*r.labels, *r.gestures))]
        models[person] = fit_model(others, seed=seed, drop_thin=lambda m, p=person: say(f'warning: {p} held out: {m}'))
    return models


def leave_one_person_out(runs: list[BearTrials], seed: int = 0, progress: Callable[[str], None] | None = None,
                         models: dict[str, SubtypeClassifier] | None = None) -> dict:
    """Leave-one-person-out scores of the trained model and of the paper's rule (knight2009 V.D);
    ``models`` (:func:`fold_models`) when they are trained already."""
    say = progress or (lambda _m: None)
    people = sorted({lab.person for run in runs for lab in run.labels})
    if len(people) < 2:
        raise SessionError(f'leave-one-person-out needs sessions of at least two people; got {people}')
    by_person = {p: [r for r in runs if any(lab.person == p for lab in r.labels)] for p in people}
    models = models if models is not None else fold_models(runs, people, seed, say)
    results, rule = {}, {}
    for person in people:
        results[person] = score_trials(by_person[person], NoTouchGate(models[person]))
        rule[person] = score_trials(by_person[person], NoTouchGate(PaperRuleClassifier()))
    return {'people': people, 'model': pool_scores(results), 'rule': pool_scores(rule),
            'per_person': {p: results[p]['accuracy'] for p in people}}


def pool_scores(per_person: dict[str, dict]) -> dict:
    """:func:`score_trials` results of several people as one: every figure over all their trials."""
    trials = sum(r['trials'] for r in per_person.values())
    correct = sum(r['correct'] for r in per_person.values())
    latencies = [v for r in per_person.values() for v in r['latencies_s']]
    return {'trials': trials, 'correct': correct, 'accuracy': correct / trials if trials else None,
            'confusion': sum(r['confusion'] for r in per_person.values()),
            'median_latency_s': float(np.median(latencies)) if latencies else None,
            'p90_latency_s': float(np.percentile(latencies, 90)) if latencies else None}


# ----------------------------------------------------------------------------- commands
def load_runs(paths: list[str], rate_hz: float, buffer_len: int, progress: Callable[[str], None]) -> list[BearTrials]:
    """Read, check and run every session bag (warnings through ``progress``)."""
    sessions = read_checked(paths, 'bear', progress)
    runs = []
    for i, session in enumerate(sessions):
        progress(f'features of {session.path} ({i + 1}/{len(sessions)}, {len(session.labels)} trials)')
        runs.append(bear_trials(session, rate_hz, buffer_len, lambda m: progress(f'warning: {m}')))
    return runs
