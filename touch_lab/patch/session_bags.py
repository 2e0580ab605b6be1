"""Patch sessions from ``collect patch`` bags: one labelled :class:`~.datasets.Session` per trial.

Each trial becomes a session: the ``/patch/frame`` activations from the middle of the pause before it
to the middle of the pause after it (the bag's ends for the first and last), its interval the
ground-truth event, the silences its class (as the paper's sessions). Each bag's rate is measured
(1 / median frame step); :func:`common_rate` accepts rates within 2 % of their median.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from touch_driver.patch.protocol import GRID
from touch_lab.collect.session_bag import SessionRecording

from .datasets import DatasetError, Session

__all__ = ['RATE_TOLERANCE', 'common_rate', 'trial_sessions']

#: Relative spread of frame rates treated as one rate (drivers' clocks drift by ~0.1 %).
RATE_TOLERANCE = 0.02


def common_rate(rates: list[float], sources: list[str] | None = None, tolerance: float = RATE_TOLERANCE) -> float:
    """The median of ``rates`` (Hz) if all lie within ``tolerance`` of it, else ValueError naming the outliers.

    >>> common_rate([20.0, 20.016, 19.99])
    20.0
    >>> common_rate([20.0, 20.0, 135.0], ['a', 'b', 'c'])
    Traceback (most recent call last):
    ...
    ValueError: frame rates differ by more than 2 %: c (135 Hz), against 20 Hz; train and evaluate one rate at a time
    """
    if not rates:
        raise ValueError('no sessions')
    median = float(np.median(rates))
    names = sources or [f'session {i + 1}' for i in range(len(rates))]
    off = [f'{n} ({r:.4g} Hz)' for n, r in zip(names, rates, strict=True) if abs(r / median - 1) > tolerance]
    if off:
        raise ValueError(f'frame rates differ by more than {100 * tolerance:g} %: {", ".join(off[:3])}, against '
                         f'{median:.4g} Hz; train and evaluate one rate at a time')
    return median


def trial_sessions(recordings: list[SessionRecording], progress: Callable[[str], None] | None = None) -> list[Session]:
    """One :class:`Session` per labelled trial of every recording (module doc)."""
    say = progress or (lambda _m: None)
    out: list[Session] = []
    for rec in recordings:
        times = rec.stamps_s['/patch/frame']
        rate = rec.rate_hz('/patch/frame')
        frames = rec.frames['/patch/frame']
        acts = np.stack([np.asarray(m.activation, dtype=np.float32) for m in frames])
        if acts.shape[1] != GRID[0] * GRID[1]:
            raise DatasetError(f'{rec.path}: PatchFrame with {acts.shape[1]} cells; expected {GRID[0]}x{GRID[1]}')
        acts = acts.reshape(len(frames), *GRID)
        edges = [0.0] + [(a.end_s + b.start_s) / 2 for a, b in zip(rec.labels, rec.labels[1:], strict=False)] \
            + [float(times[-1]) + 1.0]
        for i, lab in enumerate(rec.labels):
            sel = np.flatnonzero((times >= edges[i]) & (times < edges[i + 1]))
            if len(sel) < 2:
                say(f'warning: {rec.path} at {lab.start_s:.2f} s: {len(sel)} frames around {lab.gesture!r}; left out')
                continue
            t0 = float(times[sel[0]])
            out.append(Session(subject=lab.person, gesture=lab.gesture, activations=acts[sel], rate_hz=rate,
                               events=[(lab.start_s - t0, lab.end_s - t0)], source=f'{rec.path} at {lab.start_s:.2f} s',
                               synthetic=rec.synthetic))
    return out
