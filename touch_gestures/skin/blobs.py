"""How many separate contacts a thresholded skin map shows (:func:`count_blobs`), with numpy.

A blob is a set of taxels joined through their eight neighbours (sides and corners), after
each has been grown by ``grow`` taxels in every direction (a square of side ``2 grow + 1``,
the same as ``grow`` dilations by the 3 x 3 square). The count works on row runs: the runs of
adjacent rows that touch (sides or corners) are joined with a union-find, so the Python work
is per run (a finger is a few runs per row), not per taxel. It equals scipy.ndimage's
``label(binary_dilation(mask, ones((3, 3)), grow), ones((3, 3)))[1]`` (test/test_skin_blobs.py);
scipy would add its image package to the recogniser's process for this one count.
"""

from __future__ import annotations

import numpy as np

__all__ = ['count_blobs', 'grown']


def grown(mask: np.ndarray, grow: int) -> np.ndarray:
    """(r, c) bool ``mask`` with each True taxel grown by ``grow`` taxels in every direction (clipped at the edge)."""
    if grow <= 0:
        return mask
    rows, cols = mask.shape
    padded = np.zeros((rows + 2 * grow, cols + 2 * grow), dtype=bool)
    padded[grow:grow + rows, grow:grow + cols] = mask
    across = np.zeros((rows + 2 * grow, cols), dtype=bool)
    for k in range(2 * grow + 1):
        across |= padded[:, k:k + cols]
    out = np.zeros((rows, cols), dtype=bool)
    for k in range(2 * grow + 1):
        out |= across[k:k + rows]
    return out


def count_blobs(mask: np.ndarray, grow: int = 0) -> int:
    """Number of eight-connected blobs of the (r, c) bool ``mask`` after growing it by ``grow`` taxels.

    >>> m = np.zeros((6, 6), dtype=bool); m[0, 0] = m[1, 1] = m[4, 4] = True
    >>> count_blobs(m), count_blobs(m, grow=1)
    (2, 1)
    """
    image = grown(np.asarray(mask, dtype=bool), grow)
    rows, cols = image.shape
    framed = np.zeros((rows, cols + 2), dtype=np.int8)
    framed[:, 1:-1] = image
    edges = framed[:, 1:] - framed[:, :-1]                                     # +1 run start, -1 run end
    r_start, c_start = np.nonzero(edges == 1)
    c_end = np.nonzero(edges == -1)[1] - 1                                     # inclusive last column
    n = len(r_start)
    if n < 2:
        return n
    parent = list(range(n))

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    blobs = n
    row_of, first, last = r_start.tolist(), c_start.tolist(), c_end.tolist()
    # Runs come row by row, left to right: compare each run with the runs of the row above.
    above_begin, row_begin = 0, 0
    for i in range(n):
        if i and row_of[i] != row_of[i - 1]:
            above_begin, row_begin = (row_begin, i) if row_of[i] == row_of[i - 1] + 1 else (i, i)
        for j in range(above_begin, row_begin):
            if first[j] <= last[i] + 1 and first[i] <= last[j] + 1:   # overlap, corners included
                a, b = root(i), root(j)
                if a != b:
                    parent[a] = b
                    blobs -= 1
    return blobs
