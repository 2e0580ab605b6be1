"""How a trace file's logger stamped its points: its clock's tick and the points that share a time.

A logger whose clock ticks slower than its pen reports several points with one time. The
virtual skin spreads them over the tick (:func:`touch_sim.skin.traces.spread_stamps`); a replay
that kept one point per time would trace the last point of each run only. :func:`logged_times`
says how much of a file that concerns: the ink such a replay would lose is the difference
between each stroke's polyline through every point and through the last point of each time.

>>> from touch_sim.skin.traces import TraceSample
>>> bar = TraceSample('1', 'a', 'line', '0', np.array([0, 10, 20, 20.0]), np.zeros(4),
...                   np.array([0, 0, 16, 32.0]), np.zeros(4, dtype=int))
>>> logged_times([bar])
{'tick_ms': 16.0, 'points_sharing_a_time': 0.5, 'ink_lost_one_point_per_time': {'p50': 0.5, 'p90': 0.5}}
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from touch_sim.skin.traces import TraceSample, clock_tick

__all__ = ['ink_lost_one_point_per_time', 'logged_times']


def _ink(x: np.ndarray, y: np.ndarray) -> float:
    return float(np.hypot(np.diff(x), np.diff(y)).sum())


def ink_lost_one_point_per_time(sample: TraceSample) -> float:
    """The fraction of a sample's ink (0..1) a replay keeping the last point of each logged time would lose
    (0 for a sample without ink)."""
    full = kept = 0.0
    for sid in np.unique(sample.stroke):
        sel = sample.stroke == sid
        t, x, y = sample.t_ms[sel], sample.x[sel], sample.y[sel]
        last = np.r_[np.diff(t) > 0, True]
        full += _ink(x, y)
        kept += _ink(x[last], y[last])
    return 1.0 - kept / full if full > 0 else 0.0


def logged_times(samples: Sequence[TraceSample], q: Sequence[float] = (50, 90)) -> dict:
    """``tick_ms``: the median over the samples of their clock's tick (:func:`~touch_sim.skin.traces.clock_tick`;
    NaN when no sample has one); ``points_sharing_a_time``: the fraction of all points whose time another point
    of their stroke has; ``ink_lost_one_point_per_time``: percentiles ``q`` of :func:`ink_lost_one_point_per_time`
    over the samples.

    Raises:
        ValueError: no samples.
    """
    if not samples:
        raise ValueError('logged_times needs at least one sample')
    ticks = np.array([clock_tick(s.t_ms, s.stroke) for s in samples])
    shared = points = 0
    for s in samples:
        for sid in np.unique(s.stroke):
            _, counts = np.unique(s.t_ms[s.stroke == sid], return_counts=True)
            shared += int(counts[counts > 1].sum())
            points += int(counts.sum())
    lost = np.array([ink_lost_one_point_per_time(s) for s in samples])
    finite = ticks[np.isfinite(ticks)]
    return {'tick_ms': float(np.median(finite)) if finite.size else float('nan'),
            'points_sharing_a_time': shared / points if points else 0.0,
            'ink_lost_one_point_per_time': {f'p{g:g}': float(v) for g, v in zip(q, np.percentile(lost, q),
                                                                                 strict=True)}}
