"""Leave-one-subject-out evaluation of the patch gesture classifier (sympartner2018 6.3, Fig. 6).

Per subject: train on every frame of the others' sessions, run the held-out sessions frame by frame
as on the robot, compare detections with the ground-truth events (given, or :func:`segment_events`).

- A detection at ``t`` (s) belongs to event ``i`` when ``onset_i - early_s <= t <= offset_i + late_s``
  (the latest onset if several); else it is a false detection *in silence*.
- **event confusion** ``[truth, detected]``; **event_correct**: events with a detection of their class;
  **false_detections**: wrong class plus in silence; **misses**: events without detection. Rates divide
  by the number of events, as the paper does. **detection latency**: first correct detection - onset, s.
- **per-sample confusion** ``[predicted, truth]``: predicted = class whose posterior reaches the
  threshold, else "not recognised"; truth = the event's class, else "silence". ``tpr_all_samples``
  counts silence as "not recognised" correct (the paper's 0.32); ``tpr_detected_samples`` is the
  accuracy over samples within events where some class was recognised (the paper's 0.95).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from touch_gestures.patch.classifier import NOT_RECOGNISED, EventDetector, decide
from touch_gestures.patch.features import ACTIVE_MARGIN, WindowFeatures, window_features
from touch_lab.patch.datasets import Session
from touch_lab.patch.session_bags import common_rate
from touch_lab.patch.training import PatchGestureClassifier

__all__ = ['EvaluationResult', 'GridPoint', 'Metrics', 'leave_one_subject_out', 'onset_ages', 'run_detector',
           'score', 'segment_events', 'session_truth']


def segment_events(activations: np.ndarray, rate_hz: float, k: float = 0.08, min_cells: int = 1,
                   merge_gap_s: float = 1.0, min_duration_s: float = 0.0) -> list[tuple[float, float]]:
    """Ground-truth events by an activity threshold (sympartner2018 6.3).

    A frame is active when at least ``min_cells`` cells exceed the floor ``k`` (the
    baseline-subtracted, scaled pressure of eq. 2); runs of active frames closer than
    ``merge_gap_s`` are one event (a tickle or a repeated stroke lifts the hand briefly).

    Returns:
        [(onset_s, offset_s)], times of the first and last active frame.

    >>> a = np.full((10, 1, 1), 0.08, np.float32); a[2:4] = 0.5; a[5] = 0.5
    >>> segment_events(a, rate_hz=10.0, merge_gap_s=0.15)
    [(0.2, 0.5)]
    """
    a = np.asarray(activations, dtype=np.float64)
    if a.size == 0:
        return []
    a = np.where(np.isfinite(a), a, 0.0)
    active = (a.reshape(a.shape[0], -1) > k + ACTIVE_MARGIN).sum(axis=1) >= min_cells
    idx = np.flatnonzero(active)
    if len(idx) == 0:
        return []
    gap = max(1, round(merge_gap_s * rate_hz))
    breaks = np.flatnonzero(np.diff(idx) > gap)
    starts = np.concatenate([[idx[0]], idx[breaks + 1]])
    ends = np.concatenate([idx[breaks], [idx[-1]]])
    return [(float(s / rate_hz), float(e / rate_hz)) for s, e in zip(starts, ends, strict=True)
            if (e - s) / rate_hz >= min_duration_s]


def session_truth(session: Session, **segment_kwargs) -> list[tuple[float, float]]:
    """The session's ground-truth events: given ones, else segmented."""
    if session.events is not None:
        return list(session.events)
    return segment_events(session.activations, session.rate_hz, **segment_kwargs)


def onset_ages(activations: np.ndarray, window: int, k: float = 0.08) -> np.ndarray:
    """(T,) frames from the first active frame in each window to its last frame; -1 if none.

    Equals ``WindowFeatures.onset_age`` frame by frame.
    """
    a = np.asarray(activations, dtype=np.float64)
    n = a.shape[0]
    if a.size == 0:
        return np.full(n, -1)
    a = np.where(np.isfinite(a), a, 0.0)
    active = (a.reshape(n, -1) > k + ACTIVE_MARGIN).any(axis=1)
    big = np.iinfo(np.int64).max
    nxt = np.where(active, np.arange(n), big)
    nxt = np.minimum.accumulate(nxt[::-1])[::-1]          # first active frame at or after i
    t = np.arange(n)
    first = nxt[np.maximum(t - window + 1, 0)]
    return np.where(first <= t, t - first, -1)


def run_detector(log_post: np.ndarray, ages: np.ndarray, classes: Sequence[str], threshold: float,
                 release: float, rate_hz: float, dwell: int = 1) -> list:
    """Detections of the event rule over precomputed (T, C) log posteriors and (T,) onset ages."""
    det = EventDetector(classes, threshold=threshold, release=min(release, threshold), rate_hz=rate_hz, dwell=dwell)
    out = []
    for lp, age in zip(log_post, ages, strict=True):
        hit = det.update(lp, None if age < 0 else int(age))
        if hit is not None:
            out.append(hit)
    return out


@dataclass
class Metrics:
    """Event- and sample-level results (see the module docstring for the definitions)."""

    classes: tuple[str, ...]
    n_events: int = 0
    event_correct: int = 0
    false_detections: int = 0
    false_in_silence: int = 0
    misses: int = 0
    event_confusion: np.ndarray = None          # (C, C) truth x detected
    sample_confusion: np.ndarray = None         # (C+1, C+1) predicted (+ not recognised) x truth (+ silence)
    latencies_s: list[float] = field(default_factory=list)
    n_frames: int = 0

    def __post_init__(self) -> None:
        c = len(self.classes)
        if self.event_confusion is None:
            self.event_confusion = np.zeros((c, c), dtype=np.int64)
        if self.sample_confusion is None:
            self.sample_confusion = np.zeros((c + 1, c + 1), dtype=np.int64)

    def add(self, other: Metrics) -> None:
        for name in ('n_events', 'event_correct', 'false_detections', 'false_in_silence', 'misses', 'n_frames'):
            setattr(self, name, getattr(self, name) + getattr(other, name))
        self.event_confusion += other.event_confusion
        self.sample_confusion += other.sample_confusion
        self.latencies_s += other.latencies_s

    def _rate(self, count: int) -> float:
        return count / self.n_events if self.n_events else math.nan

    def as_dict(self) -> dict:
        c = len(self.classes)
        sc = self.sample_confusion
        diag = int(np.trace(sc[:c, :c]))
        detected = int(sc[:c, :c].sum())
        lat = np.array(self.latencies_s)
        labels_pred = [*self.classes, 'not recognised']
        labels_true = [*self.classes, 'silence']
        return {
            'n_events': self.n_events, 'event_correct': self.event_correct,
            'false_detections': self.false_detections, 'false_in_silence': self.false_in_silence,
            'misses': self.misses, 'event_correct_rate': self._rate(self.event_correct),
            'false_detection_rate': self._rate(self.false_detections), 'miss_rate': self._rate(self.misses),
            'median_detection_latency_s': float(np.median(lat)) if len(lat) else math.nan,
            'p90_detection_latency_s': float(np.percentile(lat, 90)) if len(lat) else math.nan,
            'tpr_all_samples': (diag + int(sc[c, c])) / sc.sum() if sc.sum() else math.nan,
            'tpr_detected_samples': diag / detected if detected else math.nan,
            'n_frames': self.n_frames,
            'event_confusion': {t: {d: int(self.event_confusion[i, j]) for j, d in enumerate(self.classes)}
                                for i, t in enumerate(self.classes)},
            'sample_confusion': {p: {t: int(sc[i, j]) for j, t in enumerate(labels_true)}
                                 for i, p in enumerate(labels_pred)},
        }


def score(detections: list, truth: list[tuple[float, float]], label: str, decisions: np.ndarray,
          classes: Sequence[str], rate_hz: float, early_s: float = 0.25, late_s: float = 3.0) -> Metrics:
    """Metrics of one session: its detections, truth events (all of class ``label``) and
    (T,) per-frame decisions (class index or NOT_RECOGNISED)."""
    classes = tuple(classes)
    m = Metrics(classes)
    ci = classes.index(label) if label in classes else None
    m.n_events = len(truth)
    onsets = np.array([on for on, _ in truth])
    found = [False] * len(truth)
    correct_seen = [False] * len(truth)
    for d in detections:
        t = d.frame / rate_hz
        cands = [i for i, (on, off) in enumerate(truth) if on - early_s <= t <= off + late_s]
        if not cands:
            m.false_detections += 1
            m.false_in_silence += 1
            continue
        i = max(cands, key=lambda j: onsets[j])
        found[i] = True
        if ci is not None:
            m.event_confusion[ci, d.index] += 1
        if d.index == ci:
            if not correct_seen[i]:
                correct_seen[i] = True
                m.event_correct += 1
                m.latencies_s.append(max(t - truth[i][0], 0.0))
        else:
            m.false_detections += 1
    m.misses = found.count(False)
    # per-sample confusion
    n = len(decisions)
    m.n_frames = n
    c = len(classes)
    truth_idx = np.full(n, c)  # silence
    for on, off in truth:
        lo, hi = math.ceil(on * rate_hz - 1e-9), math.floor(off * rate_hz + 1e-9)
        if ci is not None:
            truth_idx[max(lo, 0):min(hi + 1, n)] = ci
    pred_idx = np.where(decisions == NOT_RECOGNISED, c, decisions)
    np.add.at(m.sample_confusion, (pred_idx, truth_idx), 1)
    return m


@dataclass
class GridPoint:
    """Metrics of one (n_components, threshold, dwell) setting over all folds."""

    n_components: int
    threshold: float
    dwell: int
    metrics: Metrics
    us_per_frame: float = math.nan

    def summary(self) -> dict:
        d = self.metrics.as_dict()
        keys = ('event_correct', 'false_detections', 'misses', 'n_events', 'event_correct_rate',
                'false_detection_rate', 'miss_rate', 'median_detection_latency_s')
        return {'n_components': self.n_components, 'threshold': self.threshold, 'dwell_frames': self.dwell,
                **{k: d[k] for k in keys}, 'us_per_frame': self.us_per_frame}


@dataclass
class EvaluationResult:
    """Leave-one-subject-out results over a grid; ``best`` maximises correct - false rate."""

    grid: list[GridPoint]
    best: GridPoint
    window: int
    rate_hz: float
    subjects: list[str]
    synthetic: bool
    release: float = 0.9

    def as_dict(self) -> dict:
        best = self.best.metrics.as_dict()
        return {
            'synthetic': self.synthetic, 'subjects': self.subjects, 'window_frames': self.window,
            'window_s': self.window / self.rate_hz, 'rate_hz': self.rate_hz,
            'n_components': self.best.n_components, 'threshold': self.best.threshold,
            'dwell_frames': self.best.dwell, 'release': self.release,
            **{k: best[k] for k in ('event_correct', 'false_detections', 'misses', 'n_events',
                                    'event_correct_rate', 'false_detection_rate', 'miss_rate',
                                    'median_detection_latency_s', 'p90_detection_latency_s',
                                    'tpr_all_samples', 'tpr_detected_samples', 'false_in_silence')},
            'us_per_frame': self.best.us_per_frame,
            'event_confusion': best['event_confusion'], 'sample_confusion': best['sample_confusion'],
            'grid': [g.summary() for g in self.grid],
        }


def _stream_cost(clf: PatchGestureClassifier, sessions: list[Session], window: int, k: float,
                 max_frames: int = 2000, repeats: int = 5) -> float:
    """Median microseconds per frame of the per-frame path (features + posterior + event rule)."""
    frames = np.concatenate([s.activations for s in sessions])[:max_frames]
    if len(frames) == 0:
        return math.nan
    runs = []
    for _ in range(repeats):
        wf = WindowFeatures(window, k=k, grid=frames.shape[1:])
        det = EventDetector(tuple(clf.classes_), threshold=clf.threshold)
        start = time.perf_counter()
        for frame in frames:
            x = wf.update(frame)
            det.update(clf.log_posterior(x), wf.onset_age)
        runs.append((time.perf_counter() - start) / len(frames) * 1e6)
    return float(np.median(runs))


def leave_one_subject_out(sessions: list[Session], n_components: Sequence[int] = (5,),
                          thresholds: Sequence[float] = (0.99,), dwells_s: Sequence[float] = (0.4,),
                          window_s: float = 3.0, k: float = 0.08, release: float = 0.9,
                          covariance_type: str = 'full', reg_covar: float = 1e-3,
                          random_state: int = 0, late_s: float | None = None, measure_cost: bool = True,
                          progress: Callable[[str], None] | None = None) -> EvaluationResult:
    """Leave-one-subject-out over a grid of components and thresholds.

    Args:
        sessions: labelled sessions of at least two subjects, all at the same frame rate.
        n_components, thresholds: the grid (paper's best: 5 and 0.99).
        dwells_s: the event rule's dwell times, s (frames = max(1, round(dwell_s * rate)); one
            frame is the paper's rule).
        window_s: window length, s (paper: 3 s); frames = round(window_s * rate).
        release: the event rule's release posterior (see EventDetector).
        late_s: how long after an event's end a detection still belongs to it (default window_s).
        measure_cost: time the per-frame path (us_per_frame) for each n_components.
        progress: called with a line of progress text (e.g. print to stderr).

    Raises:
        ValueError: with fewer than two subjects or two classes, or mixed frame rates.
    """
    say = progress or (lambda _msg: None)
    if not sessions:
        raise ValueError('no sessions to evaluate')
    # Drivers' clocks differ by a fraction of a percent: one rate within RATE_TOLERANCE.
    rate = common_rate([s.rate_hz for s in sessions], [s.source or s.subject for s in sessions])
    window = max(1, round(window_s * rate))
    late_s = window / rate if late_s is None else late_s
    subjects = sorted({s.subject for s in sessions})
    if len(subjects) < 2:
        raise ValueError(f'leave-one-subject-out needs at least two subjects; got {subjects}')
    classes = tuple(sorted({s.gesture for s in sessions}))
    if len(classes) < 2:
        raise ValueError(f'need sessions of at least two gesture classes; got {list(classes)}')
    say(f'features: {len(sessions)} sessions, window {window} frames')
    feats = [window_features(s.activations, window, k) for s in sessions]
    ages = [onset_ages(s.activations, window, k) for s in sessions]
    truths = [session_truth(s, k=k) for s in sessions]
    dwells = sorted({max(1, round(h * rate)) for h in dwells_s})
    grid = {(n, t, h): GridPoint(n, t, h, Metrics(classes))
            for n in n_components for t in thresholds for h in dwells}
    for n in n_components:
        cost = []
        for subject in subjects:
            train = [i for i, s in enumerate(sessions) if s.subject != subject]
            test = [i for i, s in enumerate(sessions) if s.subject == subject]
            X = np.concatenate([feats[i] for i in train])
            y = np.concatenate([[sessions[i].gesture] * len(feats[i]) for i in train])
            say(f'n_components={n}: held-out {subject}: training on {len(X)} frames')
            clf = PatchGestureClassifier(n_components=n, covariance_type=covariance_type, reg_covar=reg_covar,
                                         random_state=random_state).fit(X, y)
            if tuple(str(c) for c in clf.classes_) != classes:
                raise ValueError(f'without subject {subject} the training data lack some of the classes '
                                 f'{list(classes)}; every class needs sessions from at least two subjects')
            if measure_cost and not cost:
                cost.append(_stream_cost(clf, [sessions[i] for i in test], window, k))
            for i in test:
                lp = clf.predict_log_proba(feats[i])
                for thr in thresholds:
                    decisions = decide(lp, thr)
                    for h in dwells:
                        dets = run_detector(lp, ages[i], classes, thr, release, rate, dwell=h)
                        grid[(n, thr, h)].metrics.add(score(dets, truths[i], sessions[i].gesture, decisions,
                                                            classes, rate, late_s=late_s))
        for key, point in grid.items():
            if key[0] == n:
                point.us_per_frame = cost[0] if cost else math.nan
    points = list(grid.values())

    def merit(p: GridPoint) -> tuple[float, float]:
        d = p.metrics.as_dict()
        lat = d['median_detection_latency_s']
        return (d['event_correct_rate'] - d['false_detection_rate'], -(lat if math.isfinite(lat) else 1e9))

    best = max(points, key=merit)
    return EvaluationResult(points, best, window, rate, subjects, any(s.synthetic for s in sessions), release)


def score_model(sessions: list[Session], model, late_s: float | None = None) -> dict:
    """A trained model file (``PatchModel``: classifier, window, threshold, release, hold) scored as it is on
    every session, without retraining (``eval patch --bags ... --model FILE``). Same scores as one grid point
    of :func:`leave_one_subject_out`; figures pooled over all sessions of all subjects."""
    if not sessions:
        raise ValueError('no sessions to evaluate')
    rate = common_rate([s.rate_hz for s in sessions], [s.source or s.subject for s in sessions])
    if abs(rate / model.rate_hz - 1) > 0.05:
        raise ValueError(f'the model was trained at {model.rate_hz:g} Hz; these sessions run at {rate:.3g} Hz')
    clf, classes = model.classifier, tuple(str(c) for c in model.classifier.classes_)
    late_s = model.window / rate if late_s is None else late_s
    metrics = Metrics(classes)
    for s in sessions:
        lp = clf.predict_log_proba(window_features(s.activations, model.window, model.k))
        dets = run_detector(lp, onset_ages(s.activations, model.window, model.k), classes, clf.threshold,
                            model.release, rate, hold=model.hold)
        metrics.add(score(dets, session_truth(s, k=model.k), s.gesture, decide(lp, clf.threshold), classes, rate,
                          late_s=late_s))
    return {'synthetic': any(s.synthetic for s in sessions), 'subjects': sorted({s.subject for s in sessions}),
            'method': 'the given model, not retrained, on every session', 'rate_hz': rate,
            'threshold': clf.threshold, 'hold_frames': model.hold, 'release': model.release, **metrics.as_dict()}
