"""Pre-elaboration of maps and trajectories (cirillo2017 3.1-3.2), as small pure functions.

Maps are (12, 12) bool, trajectories (n, 2) float mm. Every function handles the
degenerate inputs a real touch produces: an empty map, a one-point trajectory, a trace
along one row (min == max in eq. 6), a trajectory that does not move at all.
"""

from __future__ import annotations

import functools

import numpy as np

__all__ = [
    'arc_length_resample',
    'arc_length_resample_complex',
    'bounding_box',
    'cloud_features',
    'minmax_normalise',
    'nna_indices',
    'nna_resample',
    'nna_rescale',
    'running_ink',
    'shift_to_corner',
]


def bounding_box(mask: np.ndarray) -> tuple[int, int, int, int] | None:
    """``(row0, row1, col0, col1)`` (end-exclusive) of the True cells, or None if there are none.

    >>> m = np.zeros((4, 4), bool); m[1, 2] = m[2, 3] = True
    >>> bounding_box(m), bounding_box(np.zeros((4, 4), bool))
    ((1, 3, 2, 4), None)
    """
    rows = np.flatnonzero(mask.any(axis=1))
    if rows.size == 0:
        return None
    cols = np.flatnonzero(mask.any(axis=0))
    return int(rows[0]), int(rows[-1]) + 1, int(cols[0]), int(cols[-1]) + 1


def shift_to_corner(mask: np.ndarray) -> np.ndarray:
    """The map with its bounding box moved to the upper-left corner (cirillo2017 3.1).

    >>> m = np.zeros((3, 3), bool); m[2, 1] = True
    >>> shift_to_corner(m).astype(int).tolist()
    [[1, 0, 0], [0, 0, 0], [0, 0, 0]]
    """
    out = np.zeros_like(mask)
    box = bounding_box(mask)
    if box is not None:
        r0, r1, c0, c1 = box
        out[: r1 - r0, : c1 - c0] = mask[r0:r1, c0:c1]
    return out


def nna_indices(n_in: int, n_out: int) -> np.ndarray:
    """Source index of each of ``n_out`` samples taken from ``n_in`` by the nearest-neighbour
    algorithm (cirillo2017 eq. 5: the sample whose cell centre is nearest).

    >>> nna_indices(4, 8).tolist(), nna_indices(8, 4).tolist(), nna_indices(1, 3).tolist()
    ([0, 0, 1, 1, 2, 2, 3, 3], [1, 3, 5, 7], [0, 0, 0])
    """
    if n_in < 1 or n_out < 1:
        raise ValueError(f'nearest-neighbour resampling needs n_in >= 1 and n_out >= 1, got {n_in}, {n_out}')
    # Output cell k covers [k, k+1) * n_in / n_out; its centre falls in input cell floor(.).
    idx = ((np.arange(n_out) + 0.5) * (n_in / n_out)).astype(np.intp)
    return np.minimum(idx, n_in - 1)


def nna_rescale(mask: np.ndarray, size: int = 12) -> np.ndarray | None:
    """Crop the map to its bounding box and rescale it to ``size`` x ``size`` by nearest
    neighbour (cirillo2017 3.2.1, Fig. 6); None for an empty map.

    >>> m = np.zeros((12, 12), bool); m[5, 2:8] = True   # a horizontal line
    >>> r = nna_rescale(m); r.shape, int(r.sum())
    ((12, 12), 144)
    """
    box = bounding_box(mask)
    if box is None:
        return None
    r0, r1, c0, c1 = box
    crop = mask[r0:r1, c0:c1]
    return crop[np.ix_(nna_indices(r1 - r0, size), nna_indices(c1 - c0, size))]


def nna_resample(points: np.ndarray, length: int) -> np.ndarray:
    """``length`` rows of ``points`` chosen by nearest neighbour along the sample index
    (cirillo2017 3.2.2: "resampled exploiting the NNA ... time-independent"). (n, d) -> (length, d).

    >>> nna_resample(np.array([[0.0, 0.0], [1.0, 2.0]]), 4).tolist()
    [[0.0, 0.0], [0.0, 0.0], [1.0, 2.0], [1.0, 2.0]]
    """
    return points[nna_indices(len(points), length)]


def minmax_normalise(values: np.ndarray, axis: int = 0, eps: float = 1e-6) -> np.ndarray:
    """Min-max normalisation of cirillo2017 eq. (6), per column, into [0, 1].

    A column whose range is below ``eps`` (a trace along one row, a single point: max ==
    min) has no extent to normalise; it maps to 0.5, the middle of the range, instead of
    dividing by zero.

    >>> minmax_normalise(np.array([[0.0, 3.0], [2.0, 3.0], [4.0, 3.0]])).tolist()
    [[0.0, 0.5], [0.5, 0.5], [1.0, 0.5]]
    """
    lo = values.min(axis=axis, keepdims=True)
    span = values.max(axis=axis, keepdims=True) - lo
    flat = span < eps
    out = (values - lo) / np.where(flat, 1.0, span)
    return np.where(flat, 0.5, out).astype(values.dtype, copy=False)


@functools.lru_cache(maxsize=16)
def _steps(n: int) -> np.ndarray:
    """(n,) float64 0, 1, ..., n - 1, read-only (shared between calls)."""
    steps = np.arange(n, dtype=np.float64)
    steps.flags.writeable = False
    return steps


def arc_length_resample(points: np.ndarray, n: int, stroke: np.ndarray | None = None) -> np.ndarray:
    """``n`` points equally spaced along the path (the $1 recogniser's resampling), (m, 2) -> (n, 2).

    With ``stroke`` ((m,) stroke index of each point) the length is measured along the ink
    only, as $P does: the jump from the end of one stroke to the start of the next adds
    nothing, so no resampled point lies in the air between strokes. A path of one point, or
    one that never moves, gives ``n`` copies of its first point.

    >>> arc_length_resample(np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 2.0]]), 5).tolist()
    [[0.0, 0.0], [1.0, 0.0], [2.0, 0.0], [2.0, 1.0], [2.0, 2.0]]
    >>> arc_length_resample(np.array([[0.0, 0], [2, 0], [0, 5], [2, 5]]), 4, np.array([0, 0, 1, 1])).round(3).tolist()
    [[0.0, 0.0], [1.333, 0.0], [0.667, 5.0], [2.0, 5.0]]
    """
    return arc_length_resample_complex(points, n, stroke).view(np.float64).reshape(n, 2)


def running_ink(path: np.ndarray, stroke: np.ndarray | None = None) -> np.ndarray:
    """(m,) complex128 path ``x + 1j * y`` with (m,) stroke ids -> (m,) float64 ink length up to each point.

    The steps are numpy's complex ``abs``; the jump from one stroke to the next adds nothing.

    >>> running_ink(np.array([0, 3 + 4j, 9 + 4j, 9 + 5j]), np.array([0, 0, 1, 1])).tolist()
    [0.0, 5.0, 5.0, 6.0]
    """
    step = np.abs(path[1:] - path[:-1])
    if stroke is not None:
        stroke = np.asarray(stroke)
        step[stroke[1:] != stroke[:-1]] = 0.0  # the finger is lifted: no ink between strokes
    cum = np.empty(len(path))
    cum[0] = 0.0
    np.cumsum(step, out=cum[1:])
    return cum


def arc_length_resample_complex(points: np.ndarray, n: int, stroke: np.ndarray | None = None) -> np.ndarray:
    """:func:`arc_length_resample` as (n,) complex128 ``x + 1j * y`` (x and y interleaved in memory).

    Few numpy calls on purpose: this runs once per recognition (us matter, issue 13). As complex
    numbers the step lengths are one ``abs`` (the same ``hypot``) and both coordinates one
    ``np.interp``, which multiplies by the reciprocal of a step where the real version divides by
    it: a coordinate may differ from interpolating x and y apart by an ulp (1e-16 relative).
    """
    pts = np.ascontiguousarray(points, dtype=np.float64)
    if len(pts) == 0:
        raise ValueError('cannot resample an empty path')
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f'a path is (m, 2) points; got shape {pts.shape}')
    path = pts.view(np.complex128).reshape(-1)
    cum = running_ink(path, stroke)
    total = cum[-1]
    if not total > 0:
        return np.repeat(path[:1], n)
    # np.linspace(0, total, n) without its per-call checks: the same numbers.
    target = _steps(n) * (total / (n - 1)) if n > 1 else np.zeros(1)
    target[-1] = total if n > 1 else 0.0
    return np.interp(target, cum, path)


def cloud_features(points: np.ndarray, stroke: np.ndarray | None, n_points: int = 32) -> np.ndarray:
    """(m, 2) points with (m,) stroke ids -> (2 * n_points,) float32 cloud, x and y interleaved.

    Resampled along the ink, centred on the mean, divided by the larger side of the box
    (a dab that never moves stays at the origin).

    >>> f = cloud_features(np.array([[0.0, 0], [4, 0], [0, 4], [4, 4]]), np.array([0, 0, 1, 1]), 4)
    >>> f.reshape(4, 2).astype(float).round(2).tolist()   # two strokes of 4: every 8/3 along the ink, none in the air
    [[-0.5, -0.5], [0.17, -0.5], [-0.17, 0.5], [0.5, 0.5]]
    """
    cloud = arc_length_resample_complex(points, n_points, stroke)   # (n,) x + 1j * y: fewer numpy calls
    cloud -= cloud.sum() / n_points
    x, y = cloud.real, cloud.imag                                   # views: cheaper than reducing (n, 2) along 0
    width, height = float(x.max()) - float(x.min()), float(y.max()) - float(y.min())
    size = width if width > height or width != width else height    # the larger side; NaN if either is, as numpy's
    xy = cloud.view(np.float64)                                     # the same memory, x and y interleaved
    if size > 1e-9:
        xy /= size
    return xy.astype(np.float32)
