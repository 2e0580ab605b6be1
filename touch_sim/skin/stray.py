"""A second kind of touches that are no gesture (synthetic), for calibrating rejection apart from measuring it.

:func:`touch_sim.skin.synthetic.random_touches` (scribbles, zigzags, dabs) is what the evaluation counts as
random touches. Calibrating the rejection on touches from that same generator (another seed) would make the
measured firing rate no independent check, so the calibration draws from this one instead: touches a robot's
skin gets from people who are not giving a command, none of them drawn the way ``random_touches`` draws:

- **press**: a hand resting on the skin, 0.5-3 s, drifting 1-5 mm;
- **swipe**: a fast arc (a brush in passing), 60-200 degrees of a circle of 8-25 mm radius, 150-400 mm/s;
- **spiral**: 1.5-3 turns in or out, 15-39 mm across;
- **rub**: stroking back and forth 3-6 times along one 8-30 mm line, with a sideways drift;
- **taps**: 2-4 short touches (50-200 ms each) at random places, 0.1-0.4 s apart (one stroke each).

Traces are :class:`~touch_sim.skin.traces.TraceSample` in mm on the skin with ``t_ms`` (as ``random_touches``).
"""

from __future__ import annotations

import numpy as np

from touch_gestures.skin.gesture import ACTIVE_MM
from touch_sim.skin.traces import TraceSample

__all__ = ['STRAY_KINDS', 'stray_touches']

#: The kinds of :func:`stray_touches`, drawn in turn.
STRAY_KINDS = ('press', 'swipe', 'spiral', 'rub', 'taps')


def stray_touches(count: int = 300, seed: int = 0, rate_hz: float = 100.0, margin_mm: float = 4.0
                  ) -> list[TraceSample]:
    """``count`` touches that are no gesture, the kinds of :data:`STRAY_KINDS` in turn (module doc).

    Args:
        count: touches to draw (>= 0).
        seed: everything is drawn from it.
        rate_hz: sampling rate of the points.
        margin_mm: every point stays this far from the edge of the active area.
    """
    if count < 0:
        raise ValueError(f'count must be >= 0, got {count}')
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        kind = STRAY_KINDS[i % len(STRAY_KINDS)]
        strokes = _DRAW[kind](rng, rate_hz)
        x, y, t, s = _fit_to_skin(strokes, rng, margin_mm)
        out.append(TraceSample('stray', 'synthetic', f'stray_{kind}', str(i), x=x, y=y, t_ms=t * 1000.0, stroke=s))
    return out


def _timed(path: np.ndarray, duration_s: float, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """(n, 2) points of ``path`` (m, 2) at ``rate_hz`` over ``duration_s`` at constant speed, and their times, s."""
    arc = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(path, axis=0).T))])
    ts = np.arange(0.0, duration_s + 1e-9, 1.0 / rate_hz)
    if len(ts) < 2:
        ts = np.array([0.0, duration_s])
    where = ts / duration_s * arc[-1] if arc[-1] > 0 else np.zeros_like(ts)
    return np.column_stack([np.interp(where, arc, path[:, 0]), np.interp(where, arc, path[:, 1])]), ts


def _press(rng: np.random.Generator, rate_hz: float) -> list[tuple[np.ndarray, np.ndarray]]:
    duration = rng.uniform(0.5, 3.0)
    drift = np.cumsum(rng.normal(0, 1, (8, 2)), axis=0)
    drift *= rng.uniform(1.0, 5.0) / max(float(np.ptp(drift, axis=0).max()), 1e-9)
    return [_timed(drift, duration, rate_hz)]


def _swipe(rng: np.random.Generator, rate_hz: float) -> list[tuple[np.ndarray, np.ndarray]]:
    radius = rng.uniform(8.0, 25.0)
    start = rng.uniform(0, 2 * np.pi)
    sweep = np.radians(rng.uniform(60.0, 200.0)) * rng.choice([-1, 1])
    a = start + np.linspace(0, sweep, 60)
    path = radius * np.column_stack([np.cos(a), np.sin(a)])
    return [_timed(path, radius * abs(sweep) / rng.uniform(150.0, 400.0), rate_hz)]


def _spiral(rng: np.random.Generator, rate_hz: float) -> list[tuple[np.ndarray, np.ndarray]]:
    turns = rng.uniform(1.5, 3.0)
    a = np.linspace(0, 2 * np.pi * turns, 300)
    r = np.linspace(0.1, 1.0, len(a)) * rng.uniform(7.5, 19.5)
    path = np.column_stack([r * np.cos(a), r * np.sin(a)])
    if rng.random() < 0.5:   # spiral inwards
        path = path[::-1]
    return [_timed(path, rng.uniform(0.8, 3.0), rate_hz)]


def _rub(rng: np.random.Generator, rate_hz: float) -> list[tuple[np.ndarray, np.ndarray]]:
    length = rng.uniform(8.0, 30.0)
    passes = int(rng.integers(3, 7))
    along = np.resize([0.0, length], passes + 1)
    side = np.linspace(0.0, rng.uniform(-4.0, 4.0), passes + 1)
    angle = rng.uniform(0, np.pi)
    c, s = np.cos(angle), np.sin(angle)
    path = np.column_stack([along * c - side * s, along * s + side * c])
    return [_timed(path, passes * length / rng.uniform(40.0, 200.0), rate_hz)]


def _taps(rng: np.random.Generator, rate_hz: float) -> list[tuple[np.ndarray, np.ndarray]]:
    out, t0 = [], 0.0
    for _ in range(int(rng.integers(2, 5))):
        where = rng.uniform(0.0, 30.0, 2) + rng.normal(0, 0.3, (4, 2))
        points, ts = _timed(where, rng.uniform(0.05, 0.2), rate_hz)
        out.append((points, ts + t0))
        t0 = out[-1][1][-1] + rng.uniform(0.1, 0.4)
    return out


_DRAW = {'press': _press, 'swipe': _swipe, 'spiral': _spiral, 'rub': _rub, 'taps': _taps}


def _fit_to_skin(strokes: list[tuple[np.ndarray, np.ndarray]], rng: np.random.Generator, margin_mm: float
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Strokes ((n, 2) mm, (n,) s) -> x, y, t, stroke index, shrunk to fit and placed at random on the skin."""
    points = np.concatenate([p for p, _ in strokes])
    room = ACTIVE_MM - 2 * margin_mm
    span = float(np.ptp(points, axis=0).max())
    if span > room:
        points = points * (room / span)
    points = points - points.min(axis=0)
    points = points + rng.uniform(margin_mm, ACTIVE_MM - margin_mm - points.max(axis=0) + 1e-9)
    t = np.concatenate([ts for _, ts in strokes])
    stroke = np.concatenate([np.full(len(ts), k, dtype=np.int32) for k, (_, ts) in enumerate(strokes)])
    return points[:, 0], points[:, 1], t, stroke
