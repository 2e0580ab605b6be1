"""The optimal one-to-one assignment of a square cost matrix, with numpy (:func:`min_cost_assignment`).

The shortest augmenting path method (Jonker and Volgenant 1987, as in Crouse 2016, "On
implementing 2D rectangular assignment algorithms", which scipy's ``linear_sum_assignment``
implements in C): one free row at a time, a Dijkstra search over reduced costs finds the
cheapest way to give it a column, the dual potentials keep every reduced cost >= 0, and the
path is flipped (after the rows whose cheapest column is free are given it). Each search step
is one numpy operation over the columns, so an (n, n) problem costs at most n * n such steps.
The cloud matcher solves it for its 32 points, a few times per gesture; scipy's would load
scipy.optimize into the recogniser's process for this one function.
"""

from __future__ import annotations

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
    if cost.shape != (n, n) or not np.isfinite(cost).all():
        raise ValueError(f'need a square matrix of finite costs; got shape {cost.shape}')
    # Start from each row's cheapest column: with the row minima as row potentials (and 0 for the
    # columns) every reduced cost is >= 0 and those pairs are tight, so the rows whose cheapest column
    # no earlier row took are assigned already; only the others need a search.
    v = np.zeros(n)                        # column potentials
    u = cost.min(axis=1)                   # row potentials
    row_of = np.full(n, -1, dtype=np.intp)  # row assigned to each column
    col_of = np.full(n, -1, dtype=np.intp)  # column assigned to each row
    for r, c in enumerate(cost.argmin(axis=1).tolist()):
        if row_of[c] < 0:
            row_of[c], col_of[r] = r, c
    for start in np.flatnonzero(col_of < 0).tolist():
        shortest = np.full(n, np.inf)      # reduced path cost to each column
        path = np.full(n, -1, dtype=np.intp)
        done = np.zeros(n, dtype=bool)     # columns whose shortest path is final
        rows = [start]                     # rows reached by the search
        i, reach = start, 0.0
        while True:
            reduced = reach + cost[i] - u[i] - v
            better = ~done & (reduced < shortest)
            path[better] = i
            shortest[better] = reduced[better]
            open_costs = np.where(done, np.inf, shortest)
            reach = float(open_costs.min())
            ties = open_costs == reach
            free = ties & (row_of < 0)
            j = int(np.argmax(free)) if free.any() else int(np.argmax(ties))
            done[j] = True
            if row_of[j] < 0:
                break
            i = int(row_of[j])
            rows.append(i)
        # Potentials: every reduced cost stays >= 0 and the new path's are 0.
        u[start] += reach
        for r in rows[1:]:
            u[r] += reach - shortest[col_of[r]]
        v[done] -= reach - shortest[done]
        while True:                        # flip the path back to the start row
            i = int(path[j])
            row_of[j] = i
            col_of[i], j = j, int(col_of[i])
            if i == start:
                break
    return col_of
