"""How long a lift must be to end a gesture: the pauses between strokes of a trace file.

A sample stays one gesture when its longest pause is shorter than the segmenter's gap.
:func:`gap_table` gives, per gap, the share of samples kept whole (the gap is the latency it adds).

>>> from touch_sim.skin.traces import TraceSample
>>> s = TraceSample('1', 'a', 'X', '0', np.zeros(4), np.zeros(4), np.array([0, 100, 700, 800.0]),
...                 np.array([0, 0, 1, 1]))
>>> longest_pauses_s([s]).tolist()
[0.6]
>>> gap_table([s], [0.5, 1.0])
[{'gap_s': 0.5, 'whole': 0.0}, {'gap_s': 1.0, 'whole': 1.0}]
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from touch_sim.skin.traces import TraceSample

__all__ = ['DEFAULT_GAPS_S', 'gap_table', 'longest_pauses_s', 'pause_percentiles_s']

#: Gaps (s) the table reports by default.
DEFAULT_GAPS_S = (0.15, 0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 1.75, 2.0, 3.0, 5.0, 8.0)


def _pauses_ms(sample: TraceSample) -> np.ndarray:
    """(k - 1,) pauses between the k strokes of a sample, ms (in time order; empty for one stroke)."""
    ids = np.unique(sample.stroke)
    if len(ids) < 2:
        return np.zeros(0)
    first = np.array([sample.t_ms[sample.stroke == i].min() for i in ids])
    last = np.array([sample.t_ms[sample.stroke == i].max() for i in ids])
    order = np.argsort(first)
    return first[order][1:] - last[order][:-1]


def longest_pauses_s(samples: Sequence[TraceSample]) -> np.ndarray:
    """(n,) float64 longest pause between strokes of each sample, s (0 for one stroke)."""
    return np.array([_pauses_ms(s).max(initial=0.0) / 1000.0 for s in samples], dtype=np.float64)


def pause_percentiles_s(samples: Sequence[TraceSample], q: Sequence[float] = (50, 90, 95, 99)) -> dict[str, float]:
    """Percentiles (s) of all the pauses between strokes of the samples (empty dict when none)."""
    pauses = np.concatenate([_pauses_ms(s) for s in samples] or [np.zeros(0)]) / 1000.0
    if not pauses.size:
        return {}
    return {f'p{g:g}': float(v) for g, v in zip(q, np.percentile(pauses, q), strict=True)}


def gap_table(samples: Sequence[TraceSample], gaps_s: Sequence[float] = DEFAULT_GAPS_S) -> list[dict[str, float]]:
    """Per gap (s): the fraction of samples whose every pause is shorter (kept as one gesture)."""
    if not samples:
        raise ValueError('gap_table needs at least one sample')
    longest = longest_pauses_s(samples)
    return [{'gap_s': float(g), 'whole': float(np.mean(longest < g))} for g in gaps_s]
