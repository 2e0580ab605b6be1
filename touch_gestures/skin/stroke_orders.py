"""A touch's strokes traced in another order: :func:`every_order`.

People write the strokes of a symbol in their own order: an X's two bars either one first,
an H's bar before or after its second post. A recogniser that follows the path in time (the
trace, :mod:`.proposed`) finds a person who writes in an order nobody in the codebook used
far from every template of the class, however alike the strokes are (on the Mixed Multistroke
traces one person of ten draws the other bar of the X first, and the trace named most of
that person's X's a pitchfork). As $N does for its templates' unistrokes (:mod:`.ndollar`), a
template of a few strokes is held in every order of its strokes (the fused recogniser's trace,
:mod:`.fused`). Each stroke keeps its points, its times and its direction (on the skin a line's
direction is the command; adding each stroke reversed too, as $N does, read worse on those
traces), and the lifts keep their lengths in turn: the first lift still comes after the first
stroke traced, whichever stroke that is.
"""

from __future__ import annotations

import itertools

import numpy as np

from .gesture import TouchGesture

__all__ = ['every_order', 'reordered', 'stroke_spans']


def stroke_spans(stroke: np.ndarray) -> list[slice]:
    """(n,) stroke index of each point -> the strokes in time order: slices of consecutive points
    with one index.

    >>> stroke_spans(np.array([0, 0, 1, 1, 1]))
    [slice(0, 2, None), slice(2, 5, None)]
    """
    n = len(stroke)
    if n == 0:
        return []
    starts = np.concatenate(([0], np.flatnonzero(stroke[1:] != stroke[:-1]) + 1, [n]))
    return [slice(int(a), int(b)) for a, b in itertools.pairwise(starts)]


def reordered(points: np.ndarray, times: np.ndarray, spans: list[slice], order: tuple[int, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
    """The path with its strokes (``spans``, :func:`stroke_spans`) traced in ``order`` (each index once).

    Args:
        points: (n, 2) contact points, mm; times: (n,) s, non-decreasing.

    Returns:
        (n, 2) points and (n,) float64 times: each stroke's own points and clock, the lifts between
        strokes of the same lengths in turn, from the same first time.

    Raises:
        ValueError: ``order`` is not a permutation of the strokes.
    """
    if sorted(order) != list(range(len(spans))):
        raise ValueError(f'order must list each of the {len(spans)} strokes once, got {order}')
    times = np.asarray(times, dtype=np.float64)
    if not spans:   # no stroke: nothing to reorder
        return np.asarray(points).copy(), times.copy()
    lifts = [times[b.start] - times[a.stop - 1] for a, b in itertools.pairwise(spans)]
    stamps = []
    t = float(times[0]) if len(times) else 0.0
    for k, index in enumerate(order):
        span = spans[index]
        own = times[span] - times[span.start]   # the stroke's own clock, from its first point
        if k:
            t += lifts[k - 1]
        stamps.append(t + own)
        t += float(own[-1])
    return np.concatenate([points[spans[i]] for i in order]), np.concatenate(stamps)


def every_order(gesture: TouchGesture, max_strokes: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The gesture's path ((n, 2) points, (n,) times) in every order of its k strokes (k! paths, the
    order traced first) when 2 <= k <= ``max_strokes``; otherwise just the path as traced.

    >>> g = TouchGesture.from_trajectory(np.array([[0.0, 0], [1, 0], [5, 5], [5, 6]]), np.array([0.0, 1, 3, 4]))
    >>> g.stroke[:] = [0, 0, 1, 1]
    >>> [(p[0].tolist(), t.tolist()) for p, t in every_order(g, 2)]
    [([0.0, 0.0], [0.0, 1.0, 3.0, 4.0]), ([5.0, 5.0], [0.0, 1.0, 3.0, 4.0])]
    """
    spans = stroke_spans(gesture.stroke)
    if not 2 <= len(spans) <= max_strokes:
        return [(gesture.trajectory, gesture.times)]
    return [reordered(gesture.trajectory, gesture.times, spans, order)
            for order in itertools.permutations(range(len(spans)))]
