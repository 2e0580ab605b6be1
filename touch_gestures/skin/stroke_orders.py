"""A touch's strokes traced in another order: :func:`every_order`.

People write a symbol's strokes in their own order (an X's bars either one first), and a recogniser
that follows the path in time (:mod:`.proposed`) finds an order nobody in the codebook used far
from every template. As $N does, a template of a few strokes is held in every order of its strokes
(the fused recogniser's trace, :mod:`.fused`). Each stroke keeps its points, times and direction
(on the skin a line's direction is the command), and the lifts keep their lengths in turn.
"""

from __future__ import annotations

import itertools

import numpy as np

from .gesture import TouchGesture

__all__ = ['every_order', 'reordered', 'split_strokes']


def split_strokes(points: np.ndarray, ids: np.ndarray) -> list[np.ndarray]:
    """(m, 2) points with (m,) stroke ids -> each stroke's (m_i, 2) points, in traced order (a stroke
    is a run of one id)."""
    return np.split(points, np.flatnonzero(ids[1:] != ids[:-1]) + 1)


def reordered(strokes: list[np.ndarray], clocks: list[np.ndarray], order: tuple[int, ...]
              ) -> tuple[np.ndarray, np.ndarray]:
    """The path of ``strokes`` traced in ``order`` (each index once).

    Args:
        strokes: each stroke's (m_i, 2) contact points, mm, in the order traced (:func:`split_strokes`).
        clocks: each stroke's (m_i,) times, s, non-decreasing, in the same order.

    Returns:
        (sum m_i, 2) points and (sum m_i,) float64 times: each stroke's own points and clock, the lifts
        between strokes of the same lengths in turn, from the same first time.

    Raises:
        ValueError: ``order`` is not a permutation of the strokes, or a stroke has no point or no time
        for each point.
    """
    if sorted(order) != list(range(len(strokes))):
        raise ValueError(f'order must list each of the {len(strokes)} strokes once, got {order}')
    if len(clocks) != len(strokes):
        raise ValueError(f'need one clock per stroke: {len(strokes)} strokes, {len(clocks)} clocks')
    clocks = [np.asarray(c, dtype=np.float64) for c in clocks]
    if any(len(c) == 0 or len(c) != len(p) for p, c in zip(strokes, clocks, strict=True)):
        raise ValueError('every stroke needs at least one point and one time per point')
    if not strokes:   # no stroke: nothing to reorder
        return np.empty((0, 2)), np.empty(0)
    lifts = [b[0] - a[-1] for a, b in itertools.pairwise(clocks)]
    stamps = []
    t = float(clocks[0][0])
    for k, index in enumerate(order):
        own = clocks[index] - clocks[index][0]   # the stroke's own clock, from its first point
        if k:
            t += lifts[k - 1]
        stamps.append(t + own)
        t += float(own[-1])
    return np.concatenate([strokes[i] for i in order]), np.concatenate(stamps)


def every_order(gesture: TouchGesture, max_strokes: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """The gesture's path ((n, 2) points, (n,) times) in every order of its k strokes (k! paths, the
    order traced first) when 2 <= k <= ``max_strokes``; otherwise just the path as traced.

    >>> g = TouchGesture.from_trajectory(np.array([[0.0, 0], [1, 0], [5, 5], [5, 6]]), np.array([0.0, 1, 3, 4]))
    >>> g.stroke[:] = [0, 0, 1, 1]
    >>> [(p[0].tolist(), t.tolist()) for p, t in every_order(g, 2)]
    [([0.0, 0.0], [0.0, 1.0, 3.0, 4.0]), ([5.0, 5.0], [0.0, 1.0, 3.0, 4.0])]
    """
    strokes = split_strokes(gesture.trajectory, gesture.stroke)
    if not 2 <= len(strokes) <= max_strokes:
        return [(gesture.trajectory, gesture.times)]
    clocks = split_strokes(gesture.times, gesture.stroke)
    return [reordered(strokes, clocks, order) for order in itertools.permutations(range(len(strokes)))]
