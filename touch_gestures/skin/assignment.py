"""The optimal one-to-one assignment of a square cost matrix, without scipy (:func:`min_cost_assignment`).

The shortest augmenting path method (Jonker and Volgenant 1987, as in Crouse 2016, "On
implementing 2D rectangular assignment algorithms", which scipy's ``linear_sum_assignment``
implements in C): one free row at a time, a Dijkstra search over reduced costs finds the
cheapest way to give it a column, the dual potentials keep every reduced cost >= 0, and the
path is flipped (after the rows whose cheapest column is free are given it). An (n, n) problem
costs at most n searches of at most n steps over at most n columns; the arithmetic is scipy's,
in the same order.
The cloud matcher solves it for its 32 points, a few times per gesture; scipy's would load
scipy.optimize into the recogniser's process for this one function.
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ['min_cost_assignment']


def min_cost_assignment(cost: np.ndarray) -> np.ndarray:
    """The column of each row in a minimum-cost one-to-one assignment.

    Args:
        cost: (n, n) finite costs.

    Returns:
        (n,) intp: row ``i`` takes column ``result[i]``; ``cost[arange(n), result].sum()`` is minimal.

    >>> min_cost_assignment(np.array([[4.0, 1.0, 3.0], [2.0, 0.0, 5.0], [3.0, 2.0, 2.0]]))
    array([1, 0, 2])
    """
    cost = np.asarray(cost, dtype=np.float64)
    n = cost.shape[0]
    if cost.ndim != 2 or cost.shape != (n, n) or not np.isfinite(cost).all():
        raise ValueError(f'need a square matrix of finite costs; got shape {cost.shape}')
    if n == 0:
        return np.zeros(0, dtype=np.intp)
    # Start from each row's cheapest column: with the row minima as row potentials every reduced
    # cost is >= 0 and those pairs are tight, so the rows whose cheapest column no earlier row took
    # are assigned already; only the others need a search.
    row_min = cost.min(axis=1)
    u = row_min.tolist()                   # row potentials
    row_of = [-1] * n                      # row assigned to each column
    col_of = [-1] * n                      # column assigned to each row
    for r, c in enumerate(cost.argmin(axis=1).tolist()):
        if row_of[c] < 0:
            row_of[c], col_of[r] = r, c
    # Then each column's cheapest reduced cost as its potential (0 for the columns just taken, so
    # their pairs stay tight): a free column is tight with the row of that minimum, and takes it
    # if that row is free too.
    reduced = cost - row_min[:, None]
    v = reduced.min(axis=0).tolist()       # column potentials
    for c, r in enumerate(reduced.argmin(axis=0).tolist()):
        if row_of[c] < 0 and col_of[r] < 0:
            row_of[c], col_of[r] = r, c
    # The searches run over Python floats: for the few dozen columns of a cloud, a loop over a list
    # costs less than the dozen numpy calls a vectorised step takes.
    rows_cost = cost.tolist()
    for start in [r for r in range(n) if col_of[r] < 0]:
        shortest = [math.inf] * n          # reduced path cost to each column
        path = [-1] * n                    # the row each column is reached from
        remaining = list(range(n))         # columns whose shortest path is not final
        rows, columns = [start], []        # rows and columns the search reached
        i, reach = start, 0.0
        while True:
            row, ui = rows_cost[i], u[i]
            lowest, index = math.inf, -1
            for k, j in enumerate(remaining):
                reduced = reach + row[j] - ui - v[j]
                if reduced < shortest[j]:
                    path[j], shortest[j] = i, reduced
                if shortest[j] < lowest or (shortest[j] == lowest and row_of[j] < 0):
                    lowest, index = shortest[j], k
            reach = lowest
            j = remaining[index]
            remaining[index] = remaining[-1]
            remaining.pop()
            columns.append(j)
            if row_of[j] < 0:
                break
            i = row_of[j]
            rows.append(i)
        # Potentials: every reduced cost stays >= 0 and the new path's are 0.
        u[start] += reach
        for r in rows[1:]:
            u[r] += reach - shortest[col_of[r]]
        for c in columns:
            v[c] -= reach - shortest[c]
        while True:                        # flip the path back to the start row
            i = path[j]
            row_of[j] = i
            col_of[i], j = j, col_of[i]
            if i == start:
                break
    return np.array(col_of, dtype=np.intp)
