"""Figures of docs/patch-evaluation.md (``social-touch report patch``): synthetic people on a virtual patch.

Besides the confusion matrices and the speed-against-error curves, :func:`posterior_timeline`
replays one held-out person through a classifier trained on the others, frame by frame as the
node does (window features, log posterior, event rule), for the shape of sympartner2018 Fig. 7.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from touch_gestures.patch.features import window_features
from touch_lab.figures.markdown import figure_md
from touch_lab.figures.plots import (
    SpeedErrorPanel,
    confusion_figure,
    matrix_from_nested,
    posteriors_figure,
    speed_error_figure,
)
from touch_lab.figures.png import FigureInputError
from touch_lab.patch.datasets import Session
from touch_lab.patch.evaluate import onset_ages, run_detector, session_truth
from touch_lab.patch.training import PatchGestureClassifier

__all__ = ['SYNTHETIC', 'Timeline', 'patch_figures', 'posterior_timeline']

SYNTHETIC = 'simulated people on a virtual patch read by the patch_driver node'


@dataclass
class Timeline:
    """One person's sessions played back to back through a classifier trained without them.

    Attributes:
        subject: the held-out person. classes: class names, the columns of ``log_posteriors``.
        times_s: (T,) s. log_posteriors: (T, C) natural log.
        truth: (onset_s, offset_s, class) of the performed gestures.
        detections: (time_s, class) of the events the rule sent.
    """

    subject: str
    classes: tuple[str, ...]
    times_s: np.ndarray
    log_posteriors: np.ndarray
    truth: list[tuple[float, float, str]]
    detections: list[tuple[float, str]]


def posterior_timeline(sessions: Sequence[Session], n_components: int, threshold: float, dwell_frames: int,
                       window_s: float = 3.0, release: float = 0.9, k: float = 0.08, events_per_session: int = 2,
                       subject: str | None = None, random_state: int = 0) -> Timeline:
    """Train on every person but ``subject`` (default: the last by name), replay ``subject``'s sessions.

    Each session is cut after its ``events_per_session``-th event (plus one window), so every
    class shows a few gestures in a figure of readable length; the sessions follow each other
    in class order, as if performed in one go.

    Raises:
        FigureInputError: fewer than two people, or a person without any frame.
    """
    subjects = sorted({s.subject for s in sessions})
    if len(subjects) < 2:
        raise FigureInputError(f'posteriors over time need two people (train on one, show the other); got {subjects}')
    subject = subject or subjects[-1]
    rate = sessions[0].rate_hz
    window = max(1, round(window_s * rate))
    train = [s for s in sessions if s.subject != subject]
    feats = [window_features(s.activations, window, k) for s in train]
    clf = PatchGestureClassifier(n_components=n_components, random_state=random_state).fit(
        np.concatenate(feats), np.concatenate([[s.gesture] * len(f) for s, f in zip(train, feats, strict=True)]))
    classes = tuple(str(c) for c in clf.classes_)
    parts, truth, start = [], [], 0.0
    for s in sorted((s for s in sessions if s.subject == subject), key=lambda s: s.gesture):
        events = session_truth(s, k=k)[:events_per_session]
        end = s.n_frames if not events else min(s.n_frames, round((events[-1][1] + window_s) * rate))
        parts.append(s.activations[:end])
        truth += [(start + on, start + off, s.gesture) for on, off in events]
        start += end / rate
    if not parts or sum(len(p) for p in parts) == 0:
        raise FigureInputError(f'{subject} has no frames to replay (empty window)')
    frames = np.concatenate(parts)
    lp = clf.predict_log_proba(window_features(frames, window, k))
    hits = run_detector(lp, onset_ages(frames, window, k), classes, threshold, release, rate, dwell=dwell_frames)
    return Timeline(subject, classes, np.arange(len(frames)) / rate, lp, truth,
                    [(d.frame / rate, d.gesture) for d in hits])


def _error_pct(rate: float) -> float:
    return 100.0 * (1.0 - rate)


def patch_figures(out_dir: str | Path, best: dict, table: Sequence[tuple[float, int, dict, float]],
                  sessions: Sequence[Session], say: Callable[[str], None] | None = None) -> dict[str, str]:
    """Draw the patch report's PNGs into ``out_dir``; returns figure key -> Markdown line.

    Args:
        best: ``EvaluationResult.as_dict()`` of the grid search (its best setting).
        table: (window_s, n_components, Metrics.as_dict(), us_per_frame) of the speed-against-error runs.
        sessions: the evaluated sessions (for the posteriors over time).

    Keys: ``event_confusion``, ``sample_confusion``, ``speed_error``, ``posteriors``.
    """
    setting = (f"{best['n_components']} components, threshold {best['threshold']}, dwell {best['dwell_frames']} "
               'frames, leave-one-subject-out')
    out = {}
    rows, cols, counts = matrix_from_nested(best['event_confusion'])
    out['event_confusion'] = figure_md(
        out_dir, 'patch-event-confusion.png', 'patch gesture events: confusion matrix (synthetic)',
        lambda path: confusion_figure(path, counts, rows, cols, f'Patch events ({setting})', SYNTHETIC,
                                      'performed gesture', 'detected event'), say)
    pred, truth, by_pred = matrix_from_nested(best['sample_confusion'])
    out['sample_confusion'] = figure_md(
        out_dir, 'patch-sample-confusion.png', 'patch frames: confusion matrix (synthetic)',
        lambda path: confusion_figure(path, by_pred.T, truth, pred, f'Patch frames ({setting})', SYNTHETIC,
                                      'truth', 'decision (posterior >= threshold)'), say)
    by_components: dict[str, list] = {}
    by_window: dict[str, list] = {}
    for window_s, n, d, us in table:
        err = _error_pct(d['event_correct_rate'])
        by_components.setdefault(f'{n} components', []).append((d['median_detection_latency_s'], err,
                                                                 f'{window_s:g} s'))
        by_window.setdefault(f'window {window_s:g} s', []).append((us, err, f'{n}'))
    panels = [SpeedErrorPanel(by_components, 'median detection latency, s', 'window length (labels)',
                              ylabel='events not detected correctly, %'),
              SpeedErrorPanel(by_window, 'us per frame (one core, shared machine)', 'components (labels)',
                              ylabel='events not detected correctly, %')]
    out['speed_error'] = figure_md(out_dir, 'patch-speed-error.png', 'patch: speed against error (synthetic)',
                                   lambda path: speed_error_figure(path, panels, 'Patch: speed against error '
                                                                   '(threshold 0.99)', SYNTHETIC), say)

    def draw_posteriors(path: Path) -> Path:
        line = posterior_timeline(sessions, best['n_components'], best['threshold'], best['dwell_frames'],
                                  best['window_s'], best.get('release', 0.9))
        return posteriors_figure(path, line.times_s, line.log_posteriors, line.classes, line.truth, line.detections,
                                 best['threshold'], f'Patch class posteriors over time, {line.subject} held out '
                                 f'({setting})', SYNTHETIC)

    out['posteriors'] = figure_md(out_dir, 'patch-posteriors.png', 'patch class posteriors over time (synthetic)',
                                  draw_posteriors, say)
    return out
