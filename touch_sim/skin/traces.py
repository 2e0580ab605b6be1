"""Traced gestures (:class:`TraceSample`) and a finger tracing one across the skin (:class:`TraceStimulus`).

A :class:`TraceSample` is one gesture as a pen or finger drew it (recorded: :func:`touch_lab.skin.datasets.read_traces`,
or synthetic: :mod:`~touch_sim.skin.synthetic`). :meth:`TraceStimulus.from_points` places screen
points (x, y pixels, y downward, t ms) on the skin:

- **space**: the bounding box is scaled onto the 47 x 47 mm active area minus a margin on each side,
  keeping the aspect ratio, and centred; screen x runs along the columns, y along the rows. A
  sample with no extent lands in the centre.
- **time**: after ``lead_in_s`` of untouched skin the force ramps up over ``ramp_s``, the finger
  follows the points (linear between samples, ``t_ms`` times ``time_scale``), the force ramps down,
  and ``tail_s`` of untouched skin follows.
- **strokes** are traced in time order with a lift between them; overlapping strokes are an error.
- **a coarse clock** stamps several points with one time: :func:`spread_stamps` spreads each such
  run evenly over its tick, so the finger passes every point.

:func:`~touch_sim.skin.device.render_frames` turns the stimulus into raw frames with the device model
of the ``skinsim://`` URL handler::

    stim = TraceStimulus.from_points(x, y, t_ms)
    frames = render_frames(stim, seed=1)            # (n, 144) uint16 at 150 Hz
    states = calibrate_frames(frames)               # pressure, contact, contact_xy_mm, force
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from touch_driver.skin.protocol import ACTIVE_SIDE_MM, TAXEL_PITCH_MM
from touch_sim.skin.contact import Contact

__all__ = ['TraceSample', 'TraceStimulus', 'clock_tick', 'spread_stamps', 'spread_strokes',
           'traced_strokes']


@dataclass(frozen=True, eq=False)
class TraceSample:
    """One traced gesture: the points of every stroke in time order.

    Attributes:
        subject, variant, gesture, sample: the key columns, as strings.
        x, y: (n,) float64, the file's units (pixels for the $1 logs).
        t_ms: (n,) float64, ms from the first point, non-decreasing within each stroke.
        stroke: (n,) int32 stroke index of each point, non-decreasing.
    """

    subject: str
    variant: str
    gesture: str
    sample: str
    x: np.ndarray
    y: np.ndarray
    t_ms: np.ndarray
    stroke: np.ndarray

    @property
    def n_strokes(self) -> int:
        return len(np.unique(self.stroke))

    @property
    def key(self) -> tuple[str, str, str, str]:
        return (self.subject, self.variant, self.gesture, self.sample)

    @property
    def duration_ms(self) -> float:
        return float(self.t_ms[-1] - self.t_ms[0]) if len(self.t_ms) else 0.0

    def __repr__(self) -> str:
        return (f'TraceSample(subject={self.subject!r}, variant={self.variant!r}, gesture={self.gesture!r}, '
                f'sample={self.sample!r}, points={len(self.x)}, strokes={self.n_strokes})')


#: Strokes closer in time than this (ms, a logger's rounding) are one touch (TraceStimulus.from_points).
_SAME_INSTANT_MS = 2.0


def clock_tick(t: np.ndarray, stroke: np.ndarray) -> float:
    """The tick of the clock that stamped a sample's points: the median step between successive distinct
    times within its strokes (the unit of ``t``); NaN when no stroke has two distinct times.

    >>> clock_tick(np.array([0, 0, 16, 16, 31, 100, 116]), np.array([0, 0, 0, 0, 0, 1, 1]))
    16.0
    """
    t, stroke = np.asarray(t, dtype=np.float64), np.asarray(stroke)
    steps = [d[d > 0] for d in (np.diff(np.unique(t[stroke == sid])) for sid in np.unique(stroke))]
    steps = np.concatenate(steps) if steps else np.empty(0)
    return float(np.median(steps)) if steps.size else math.nan


def spread_stamps(t: np.ndarray, tick: float, end: float = math.inf) -> tuple[np.ndarray, np.ndarray]:
    """Strictly increasing times for one stroke's points stamped by a clock of ``tick``.

    A clock that reads ``t`` from ``t`` to ``t + tick`` stamps a run of k points ``t``; they are spread evenly
    over that tick: ``t + delta * j / k``, j = 0..k-1, ``delta`` the step to the next time of the stroke (the
    stroke's last run: to ``end``, the next stroke's start), at most ``tick``. A run that cannot be spread
    (``tick`` NaN, no time left before ``end``) keeps its last point, at ``t``.

    Args:
        t: (n,) float64 non-decreasing times of one stroke's points. tick: the clock's tick (:func:`clock_tick`),
            same unit. end: the latest time the stroke may reach.

    Returns:
        (n,) float64 times and an (n,) bool mask of the points kept; the kept times strictly increase.

    >>> times, keep = spread_stamps(np.array([0.0, 0.0, 0.0, 31.0]), 16.0)
    >>> times[keep].tolist()
    [0.0, 5.333333333333333, 10.666666666666666, 31.0]
    """
    t = np.asarray(t, dtype=np.float64)
    if not t.size:
        return t.copy(), np.ones(0, dtype=bool)
    first = np.r_[True, np.diff(t) > 0]            # the first point of each run of one time
    run = np.cumsum(first) - 1
    run_t, run_len = t[first], np.bincount(run)
    with np.errstate(invalid='ignore'):            # a NaN tick: no run is spread
        delta = np.minimum(np.r_[run_t[1:], end] - run_t, tick)
    spread = np.isfinite(delta) & (delta > 0)
    place = np.arange(t.size) - np.flatnonzero(first)[run]   # 0..k-1 within its run
    times = t + np.where(spread[run], np.where(spread, delta, 0.0)[run] * place / run_len[run], 0.0)
    return times, spread[run] | (place == run_len[run] - 1)


def spread_strokes(stamped: Sequence[np.ndarray], tick: float) -> list[np.ndarray]:
    """Strokes as logged -> strokes a finger can trace: each stroke's (k, 3) rows (t, x, y), in time order,
    with its equal times spread over ``tick`` (:func:`spread_stamps`; a stroke ends before the next starts)."""
    out = []
    for i, rows in enumerate(stamped):
        end = stamped[i + 1][0, 0] if i + 1 < len(stamped) else math.inf
        times, keep = spread_stamps(rows[:, 0], tick, end)
        out.append(np.column_stack([times, rows[:, 1:]])[keep])
    return out


def traced_strokes(t: np.ndarray, x: np.ndarray, y: np.ndarray, stroke: np.ndarray, tick: float) -> list[np.ndarray]:
    """Points (n,) of times, positions and stroke ids -> :func:`spread_strokes` of their strokes in time order."""
    t, x, y, stroke = (np.asarray(a) for a in (t, x, y, stroke))
    stamped = [np.column_stack([t[sel], x[sel], y[sel]]).astype(np.float64)
               for sel in (stroke == sid for sid in np.unique(stroke))]
    return spread_strokes(sorted(stamped, key=lambda rows: rows[0, 0]), tick)


class TraceStimulus:
    """A finger tracing strokes of (time s, position mm) across the skin; build it with :meth:`from_points`.

    Args:
        strokes: per stroke a (k, 3) float64 array of rows (t_s, x_mm, y_mm), times strictly increasing,
            strokes in time order and not overlapping.
        force_n: normal force while tracing, N. radius_mm: finger contact radius, mm.
        ramp_s: touch-down / lift ramp, s. tail_s: untouched time after the last lift, s.
    """

    def __init__(self, strokes: Sequence[np.ndarray], force_n: float = 1.5, radius_mm: float = 4.0,
                 ramp_s: float = 0.05, tail_s: float = 0.5) -> None:
        if not strokes:
            raise ValueError('a trace needs at least one stroke')
        for name, value in (('force_n', force_n), ('radius_mm', radius_mm), ('ramp_s', ramp_s), ('tail_s', tail_s)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f'{name} must be a finite number >= 0, got {value}')
        if ramp_s <= 0:
            raise ValueError(f'ramp_s must be > 0, got {ramp_s}')
        self.strokes = [np.asarray(s, dtype=np.float64) for s in strokes]
        for i, s in enumerate(self.strokes):
            if s.ndim != 2 or s.shape[1] != 3 or len(s) == 0 or not np.isfinite(s).all():
                raise ValueError(f'stroke {i} must be a non-empty (k, 3) array of finite (t_s, x_mm, y_mm)')
            if np.any(np.diff(s[:, 0]) <= 0):
                raise ValueError(f'stroke {i}: times must strictly increase')
        self.force_n, self.radius_mm, self.ramp_s, self.tail_s = float(force_n), float(radius_mm), ramp_s, tail_s
        # Ramps per stroke: (down_ramp, up_ramp), shortened to half of a short gap between strokes.
        self._ramps = []
        for i, s in enumerate(self.strokes):
            before = ramp_s if i == 0 else (s[0, 0] - self.strokes[i - 1][-1, 0]) / 2
            after = ramp_s if i == len(self.strokes) - 1 else (self.strokes[i + 1][0, 0] - s[-1, 0]) / 2
            if before <= 0 or after <= 0:
                raise ValueError(f'stroke {i} overlaps its neighbour in time; strokes must follow each other')
            self._ramps.append((min(before, ramp_s), min(after, ramp_s)))
        if self.strokes[0][0, 0] < ramp_s:
            raise ValueError(f'the first point must come at least ramp_s={ramp_s} s after t=0 (for the touch-down)')
        self._starts = np.array([s[0, 0] - r[0] for s, r in zip(self.strokes, self._ramps, strict=True)])

    @property
    def duration_s(self) -> float:
        """Seconds from the start to the end of the tail after the last lift."""
        return float(self.strokes[-1][-1, 0] + self._ramps[-1][1] + self.tail_s)

    @classmethod
    def from_points(cls, x: Sequence[float] | np.ndarray, y: Sequence[float] | np.ndarray,
                    t_ms: Sequence[float] | np.ndarray, stroke: Sequence[int] | np.ndarray | None = None, *,
                    force_n: float = 1.5, radius_mm: float = 4.0, margin_mm: float = TAXEL_PITCH_MM,
                    area_mm: float = ACTIVE_SIDE_MM, lead_in_s: float = 0.5, tail_s: float = 0.5,
                    ramp_s: float = 0.05, time_scale: float = 1.0) -> TraceStimulus:
        """Place screen points (x, y px, y downward; t ms) on the skin (see the module doc).

        Points with equal times are spread over the clock's tick (:func:`spread_stamps`). Raises ValueError
        on empty, mismatched, non-finite or time-reversed input, and on overlapping strokes. A stroke that starts
        when the previous one ends, to 2 ms (a dot's pen-down logged twice), joins it: a finger cannot lift
        in no time.

        >>> stim = TraceStimulus.from_points([0, 100, 100], [0, 0, 50], [0, 500, 1000])
        >>> stim.strokes[0].round(2).tolist()      # t_s, x_mm, y_mm: 39.17 mm wide, centred vertically
        [[0.55, 3.92, 13.71], [1.05, 43.08, 13.71], [1.55, 43.08, 33.29]]
        """
        x, y, t = (np.asarray(a, dtype=np.float64).reshape(-1) for a in (x, y, t_ms))
        if not len(x) == len(y) == len(t):
            raise ValueError(f'x, y and t_ms must have the same length; got {len(x)}, {len(y)}, {len(t)}')
        if len(x) == 0:
            raise ValueError('a trace needs at least one point; got none')
        if not (np.isfinite(x).all() and np.isfinite(y).all() and np.isfinite(t).all()):
            raise ValueError('x, y and t_ms must be finite numbers (found NaN or inf); drop those samples first')
        for name, value in (('margin_mm', margin_mm), ('area_mm', area_mm), ('lead_in_s', lead_in_s),
                            ('time_scale', time_scale)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f'{name} must be a finite number >= 0, got {value}')
        if not (area_mm > 2 * margin_mm and time_scale > 0):
            raise ValueError(f'need area_mm > 2 * margin_mm and time_scale > 0; got {area_mm}, {margin_mm}, '
                             f'{time_scale}')
        ids = np.zeros(len(x), dtype=np.int64) if stroke is None else np.asarray(stroke).reshape(-1)
        if len(ids) != len(x):
            raise ValueError(f'stroke must give one id per point; got {len(ids)} ids for {len(x)} points')
        # Space: bounding box -> active area minus margins, aspect kept, centred.
        extent = max(np.ptp(x), np.ptp(y))
        scale = (area_mm - 2 * margin_mm) / extent if extent > 0 else 1.0
        cx, cy = (x.min() + x.max()) / 2, (y.min() + y.max()) / 2
        x_mm = (x - cx) * scale + area_mm / 2
        y_mm = (y - cy) * scale + area_mm / 2
        t_s = lead_in_s + ramp_s + (t - t.min()) * (time_scale / 1000.0)
        stamped: list[np.ndarray] = []
        for sid in sorted(set(ids.tolist()), key=lambda s: t_s[ids == s].min()):
            sel = ids == sid
            ts, xs, ys = t_s[sel], x_mm[sel], y_mm[sel]
            if np.any(np.diff(ts) < 0):
                raise ValueError(f'stroke {sid}: t_ms must not decrease within a stroke')
            rows = np.stack([ts, xs, ys], axis=1)
            # A stroke that starts when the previous one ends, to the logger's millisecond rounding (a dot's
            # pen-down reported twice, as in some exclamation marks of the Mixed Multistroke Gestures), is the
            # same touch: a finger cannot lift in no time. Joined, not refused; a real overlap still fails.
            if stamped and 0 <= stamped[-1][-1, 0] - ts[0] <= _SAME_INSTANT_MS * time_scale / 1000.0:
                rows = np.concatenate([stamped.pop(), rows])
                rows = rows[np.argsort(rows[:, 0], kind='stable')]
            stamped.append(rows)
        strokes = spread_strokes(stamped, clock_tick(t, ids) * (time_scale / 1000.0))
        return cls(strokes, force_n=force_n, radius_mm=radius_mm, ramp_s=ramp_s, tail_s=tail_s)

    def contacts(self, t: float) -> list[Contact]:
        """The finger contact at ``t`` s (empty between strokes and outside the trace)."""
        i = int(np.searchsorted(self._starts, t, side='right')) - 1
        if i < 0:
            return []
        s = self.strokes[i]
        ramp_down, ramp_up = self._ramps[i]
        t0, t1 = s[0, 0], s[-1, 0]
        if t > t1 + ramp_up:
            return []
        if t < t0:
            k, vx, vy = (t - (t0 - ramp_down)) / ramp_down, 0.0, 0.0
            x, y = s[0, 1], s[0, 2]
        elif t > t1:
            k, vx, vy = (t1 + ramp_up - t) / ramp_up, 0.0, 0.0
            x, y = s[-1, 1], s[-1, 2]
        else:
            k = 1.0
            j = min(int(np.searchsorted(s[:, 0], t, side='right')) - 1, len(s) - 2)
            if j < 0:                                   # a single-point stroke: a tap
                x, y, vx, vy = s[0, 1], s[0, 2], 0.0, 0.0
            else:
                dt = s[j + 1, 0] - s[j, 0]
                a = (t - s[j, 0]) / dt
                x = s[j, 1] + a * (s[j + 1, 1] - s[j, 1])
                y = s[j, 2] + a * (s[j + 1, 2] - s[j, 2])
                vx, vy = (s[j + 1, 1] - s[j, 1]) / dt, (s[j + 1, 2] - s[j, 2]) / dt
        if k <= 0:
            return []
        return [Contact(float(x), float(y), self.force_n * min(k, 1.0), self.radius_mm, float(vx), float(vy))]

    def truth(self, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Ground truth at ``times`` (n,) s: ((n, 2) float64 finger position in mm, NaN when lifted; (n,) bool down)."""
        times = np.asarray(times, dtype=np.float64).reshape(-1)
        xy = np.full((len(times), 2), np.nan)
        down = np.zeros(len(times), dtype=bool)
        for i, t in enumerate(times):
            c = self.contacts(float(t))
            if c:
                xy[i] = c[0].x_mm, c[0].y_mm
                down[i] = True
        return xy, down
