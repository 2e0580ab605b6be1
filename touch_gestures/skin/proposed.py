"""A recogniser for traced gestures: :class:`TraceRecogniser` (direction-aware).

1. **Resampling by time bins** (``n_points``): the gesture's duration is cut into ``n_points``
   equal bins and each bin's contact points are averaged. Uniform in time like the paper's NNA, so
   it keeps the speed profile; the bin mean filters the contact point's jitter, cannot alias, and
   an empty bin (dropped frames) is interpolated from its neighbours.
2. **Uniform scaling** (``aspect_floor`` = 1): centre on the bounding box and divide both axes by
   the larger extent, which keeps a line's proportions (eq. (6) blows a line's wobble up to full
   height). ``aspect_floor`` < 1 divides each axis by at least that fraction of the larger extent
   (0 is eq. (6)).
3. **Nearest neighbour by Euclidean distance** over the (x, y) points, one matrix-vector product
   against the codebook. No rotation search: on a skin a line's orientation is the command.

The distance is the root-mean-square point distance in units of the gesture's size.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .base import TemplateRecogniser
from .gesture import TouchGesture

__all__ = ['TraceRecogniser', 'time_bin_resample', 'trace_features']


def time_bin_resample(points: np.ndarray, times: np.ndarray, n_bins: int) -> np.ndarray:
    """Mean point of each of ``n_bins`` equal time bins: (n, 2), (n,) -> (n_bins, 2) float64.

    Empty bins (fewer points than bins, dropped frames) are interpolated between their
    neighbours; times that are constant or go backwards fall back to the sample index; one
    point gives ``n_bins`` copies.

    >>> time_bin_resample(np.array([[0.0, 0], [1, 0], [2, 0], [3, 0]]), np.arange(4.0), 2)[:, 0].tolist()
    [0.5, 2.5]
    >>> time_bin_resample(np.array([[0.0, 0], [3, 0]]), np.array([0.0, 1.0]), 4)[:, 0].tolist()
    [0.0, 1.0, 2.0, 3.0]
    """
    pts = np.asarray(points, dtype=np.float64)
    n = len(pts)
    if n == 0:
        raise ValueError('cannot resample an empty trajectory')
    if n == 1:
        return np.repeat(pts, n_bins, axis=0)
    t = np.asarray(times, dtype=np.float64)
    duration = t[-1] - t[0]
    # A subnormal duration passes `> 0` but overflows n_bins / duration: treat it as constant time.
    with np.errstate(over='ignore', divide='ignore'):
        scale = n_bins / duration if duration > 0 else math.inf
    if not math.isfinite(scale) or (t[1:] < t[:-1]).any():
        t, scale = np.arange(n, dtype=np.float64), n_bins / float(n - 1)
    k = ((t - t[0]) * scale).astype(np.intp)
    np.minimum(k, n_bins - 1, out=k)  # the last point falls on the upper edge: last bin
    counts = np.bincount(k, minlength=n_bins)
    out = np.empty((n_bins, 2))
    out[:, 0] = np.bincount(k, pts[:, 0], n_bins)
    out[:, 1] = np.bincount(k, pts[:, 1], n_bins)
    if counts.all():
        out /= counts[:, None]
        return out
    full = np.flatnonzero(counts)
    empty = np.flatnonzero(counts == 0)
    out[full] /= counts[full, None]
    out[empty, 0] = np.interp(empty, full, out[full, 0])
    out[empty, 1] = np.interp(empty, full, out[full, 1])
    return out


def trace_features(points: np.ndarray, times: np.ndarray, n_points: int = 32, aspect_floor: float = 1.0
                   ) -> np.ndarray:
    """(n, 2) points and (n,) times -> (2 * n_points,) float32 features, x and y interleaved
    (module doc, steps 1-2). A dab that never moves has no shape: all zeros.

    >>> f = trace_features(np.array([[0.0, 5.0], [10.0, 5.0]]), np.array([0.0, 1.0]), n_points=3)
    >>> f.reshape(3, 2).tolist()   # a horizontal line keeps its proportions: y stays 0
    [[-0.5, 0.0], [0.0, 0.0], [0.5, 0.0]]
    """
    res = time_bin_resample(points, times, n_points)
    lo, hi = res.min(axis=0), res.max(axis=0)
    span = hi - lo
    size = span.max()
    if not size > 1e-9:
        return np.zeros(2 * n_points, dtype=np.float32)
    scale = np.maximum(span, aspect_floor * size)
    return ((res - 0.5 * (lo + hi)) / scale).reshape(-1).astype(np.float32)


@dataclass(eq=False)
class TraceRecogniser(TemplateRecogniser):
    """Time-binned, uniformly scaled trajectory matching (module doc).

    Args:
        n_points: time bins (see the speed-against-error table in docs/skin-evaluation.md).
        aspect_floor: smallest axis scale as a fraction of the larger extent (1 = uniform
            scaling, the default; 0 = eq. (6) per-axis min-max).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'trace'
    direction_aware = True

    n_points: int = 32
    aspect_floor: float = 1.0

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0:
            return None
        return trace_features(gesture.trajectory, gesture.times, self.n_points, self.aspect_floor)

    def _prepare_codebook(self) -> None:
        self._sq_norms = np.einsum('ij,ij->i', self.templates_, self.templates_)

    def distances(self, query: np.ndarray) -> np.ndarray:
        d2 = self._sq_norms - 2.0 * (self.templates_ @ query) + float(query @ query)
        return np.sqrt(np.maximum(d2, 0.0) / self.n_points)
