"""Evidence an order-free match throws away: the order of the points along a one-stroke touch.

A point cloud (:class:`~.clouds.CloudRecogniser`) is blind to point order, so a scribble that fills
the places of a star is as close as a star. :class:`OrderEvidence` asks whether a touch of **one
stroke** is near a one-stroke template path of its nearest class:

- the **path distance** is the RMS distance between the touch's and a template's points, both
  resampled along the ink (:func:`~.features.cloud_features`, units of the gesture's size), the
  smaller of both directions; for a **closed** template (ends less than ``closed`` sizes apart),
  from any of its points as the start as well. The products run in blocks small enough that BLAS
  keeps to one thread. Where the recogniser's features are that path, they are read, not recomputed;
- **the threshold** is calibrated on the codebook as the shape distance's is (:mod:`.base`):
  ``auto_scale`` times the ``auto_quantile`` quantile of the leave-one-out path distances among the
  class's one-stroke templates (at most ``per_class`` of them). A class with fewer than two has no
  check, nor has a codebook that does not know its templates' paths.
"""

from __future__ import annotations

import math

import numpy as np

from .features import cloud_features
from .gesture import TouchGesture

__all__ = ['ORDER_REASON', 'OrderEvidence', 'one_stroke_path']

#: The rejection reason :meth:`OrderEvidence.check` gives.
ORDER_REASON = 'order'
#: Points of a path along the ink ($P's 32).
PATH_POINTS = 32
#: OpenBLAS's matrix-vector product runs on one thread below m x n = 2304 x GEMM_MULTITHREAD_THRESHOLD (4 by
#: default; interface/gemv.c), its matrix product up to m x n x k = 65536 x 4 (interface/gemm.c): threads wait
#: for a core on a busy machine, so the products stay within them.
_ONE_THREAD_VECTOR = 2304 * 4
_ONE_THREAD_PRODUCT = 65536 * 4


def one_stroke_path(gesture: TouchGesture, n_points: int = PATH_POINTS) -> np.ndarray | None:
    """(n_points, 2) float64 path of a one-stroke ``gesture`` along its ink, centred and divided by
    the larger side of its box; None for a touch of several strokes or without points."""
    if int(getattr(gesture, 'strokes', 1)) != 1 or len(gesture.trajectory) == 0:
        return None
    return cloud_features(gesture.trajectory, None, n_points).reshape(n_points, 2).astype(np.float64)


class OrderEvidence:
    """Per class, how far a one-stroke touch's path may lie from its one-stroke templates (module doc).

    Args:
        paths: (T, n, 2) path of each template (:func:`one_stroke_path`), NaN for templates of
            several strokes.
        template_labels: (T,) class index of each template.
        n_classes: number of classes.
        scale, quantile: the threshold is ``scale`` times this quantile of the leave-one-out path distances.
        closed: ends closer than this (gesture sizes) make a template a closed stroke.
        per_class: at most this many templates per class are left out for the calibration.
    """

    def __init__(self, paths: np.ndarray, template_labels: np.ndarray, n_classes: int, scale: float = 2.0,
                 quantile: float = 0.9, closed: float = 0.2, per_class: int = 40) -> None:
        paths = np.asarray(paths, dtype=np.float64)
        labels = np.asarray(template_labels)
        if paths.ndim != 3 or paths.shape[2] != 2 or len(paths) != len(labels) or paths.shape[1] < 2:
            raise ValueError(f'paths must be (T, n >= 2, 2) with one label each; got {paths.shape} and '
                             f'{len(labels)} labels')
        if not (np.isfinite(scale) and scale > 0 and 0 <= quantile <= 1 and np.isfinite(closed) and closed >= 0
                and per_class >= 1):
            raise ValueError(f'need scale > 0, 0 <= quantile <= 1, closed >= 0 and per_class >= 1; got {scale}, '
                             f'{quantile}, {closed}, {per_class}')
        self.n_points = paths.shape[1]
        one_stroke = np.isfinite(paths).all(axis=(1, 2))
        #: per class, the indices (into ``T``) of its one-stroke templates
        self.members = [np.flatnonzero(one_stroke & (labels == c)) for c in range(n_classes)]
        self._paths = np.where(one_stroke[:, None, None], paths, 0.0)                 # (T, n, 2)
        self._energy = (self._paths ** 2).sum(axis=(1, 2))                          # (T,) squared norms
        self._closed = one_stroke & (np.hypot(*(self._paths[:, 0] - self._paths[:, -1]).T) < closed)
        # (2n, 2n): column d * n + s gathers the touch's path read from point s (d = 0: as traced; 1: reversed),
        # x and y interleaved, from its (2n,) flat path
        k = np.arange(self.n_points)
        starts = (k[None, :] + k[:, None]) % self.n_points                          # [s, k]: point k + s
        points = np.concatenate([starts, self.n_points - 1 - starts])                # (2n shifts, n)
        self._shifts = np.stack([2 * points, 2 * points + 1], axis=2).reshape(2 * self.n_points, -1).T.copy()
        #: per class, what :meth:`check` reads of its one-stroke templates, gathered once (no copy per check)
        self._by_class = [self._gathered(own) for own in self.members]
        #: (n_classes,) path distance thresholds; inf: no check (fewer than two one-stroke templates).
        self.thresholds = np.full(n_classes, np.inf)
        for c, own in enumerate(self.members):
            if len(own) < 2:
                continue
            left_out = own[np.unique(np.linspace(0, len(own) - 1, min(len(own), per_class)).astype(np.intp))]
            loo = [self.path_distance(paths[i], own[own != i]) for i in left_out]
            self.thresholds[c] = scale * float(np.quantile(loo, quantile))

    def _gathered(self, templates: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray]],
                                                         list[tuple[np.ndarray, np.ndarray]]]:
        """What :meth:`_distance` reads of the given templates (indices), in blocks of rows small enough for
        BLAS to keep to one thread: the open ones' paths as traced and reversed, (2 m_open, 2n) with half
        their squared norms (:data:`_ONE_THREAD_VECTOR`); the closed ones' paths (m_closed, 2n) times 2
        with their squared norms (:data:`_ONE_THREAD_PRODUCT`)."""
        loops = self._closed[templates]
        opened, closed = templates[~loops], templates[loops]
        n = self.n_points
        paths = self._paths[opened]
        both = np.concatenate([paths, paths[:, ::-1]]).reshape(-1, 2 * n)
        return (_blocks(both, 0.5 * np.tile(self._energy[opened], 2), (_ONE_THREAD_VECTOR - 1) // (2 * n)),
                _blocks(2.0 * self._paths[closed].reshape(-1, 2 * n), self._energy[closed],
                        _ONE_THREAD_PRODUCT // (2 * n) ** 2))

    def path_distance(self, path: np.ndarray, templates: np.ndarray) -> float:
        """Smallest root-mean-square point distance of an (n, 2) path to the given templates' paths
        (indices), in either direction, from any start on a closed template (inf without templates)."""
        if len(templates) == 0:
            return float('inf')
        return self._distance(path, *self._gathered(templates))

    def _distance(self, path: np.ndarray, open_blocks: list[tuple[np.ndarray, np.ndarray]],
                  closed_blocks: list[tuple[np.ndarray, np.ndarray]]) -> float:
        """:meth:`path_distance` to templates gathered by :meth:`_gathered`."""
        # sum_k |t_k - q_(k+s)|^2 = |t|^2 + |q|^2 - 2 sum_k t_k . q_(k+s), the points as 2-vectors.
        flat = np.ascontiguousarray(path, dtype=np.float64).reshape(-1)             # (2n,) x, y interleaved
        best = np.inf
        for paths, half_norms in open_blocks:
            # An open template is read from either end of the touch only (the touch reversed is the template
            # reversed): |t|^2 / 2 - t . q ranks them in one matrix-vector product; the nearest one's distance
            # is then taken as the difference (no rounding of the expansion left in it: a path is 0 from itself).
            diff = paths[int((half_norms - paths @ flat).argmin())] - flat
            best = _smaller(best, float(diff @ diff))
        if closed_blocks:
            # A closed one from any start s, either way: the sums t . q_(k+s) for every start in one product
            # with the (2n, 2n) matrix of the touch's path read from each of its points both ways.
            energy = float(flat @ flat)
            every_start = flat[self._shifts]                                         # (2n, 2n starts)
            for paths2, norms in closed_blocks:
                best = _smaller(best, float(((norms + energy)[:, None] - paths2 @ every_start).min()))
        return math.sqrt(max(best, 0.0) / self.n_points)

    def check(self, gesture: TouchGesture, label: int, path: np.ndarray | None = None) -> str | None:
        """``'order'`` when the one-stroke ``gesture``'s path is farther than class ``label``'s threshold
        from every one-stroke template of the class, else None. ``path``: the gesture's
        :func:`one_stroke_path` if the caller has it already (a cloud's own features), else computed here."""
        threshold = float(self.thresholds[label])
        if not math.isfinite(threshold):
            return None
        if path is None or len(path) != self.n_points:
            path = one_stroke_path(gesture, self.n_points)
        elif int(getattr(gesture, 'strokes', 1)) != 1:
            path = None
        if path is None:
            return None
        if self._distance(path, *self._by_class[label]) > threshold:
            return ORDER_REASON
        return None


def _smaller(a: float, b: float) -> float:
    """The smaller of two floats, NaN if either is (as numpy's minimum)."""
    return b if b < a or b != b else a


def _blocks(rows: np.ndarray, values: np.ndarray, size: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(m, d) ``rows`` with their (m,) ``values`` in blocks of at most ``size`` (>= 1) rows; none for m = 0."""
    size = max(1, size)
    return [(rows[i:i + size], values[i:i + size]) for i in range(0, len(rows), size)]
