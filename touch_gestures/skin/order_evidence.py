"""Evidence an order-free match throws away: the order of the points along a one-stroke touch.

A point cloud (:class:`~.clouds.CloudRecogniser`) is blind to the order of its points, so a
random scribble whose points happen to fill the places of a five-point star is as close to
the star as a star. A person who writes a star in one stroke, though, traces its points in
one of few orders: from one of its tips, one way or the other. :class:`OrderEvidence` asks
whether the touch, as the path it was traced, is near such a path of the class:

- only a touch of **one stroke** is checked, against the templates of one stroke of its
  nearest class (a multi-stroke symbol's strokes come in any order, which is what the cloud
  is for; a random brush of the hand is one stroke);
- the **path distance** is the root-mean-square distance between the touch's and a
  template's points, both resampled along the ink (:func:`~.clouds.cloud_features`, in
  units of the gesture's size), the smaller of the two directions; where the template is a
  **closed** stroke (its ends less than ``closed`` gesture sizes apart: a star, a circle),
  from any of its points as the start as well. The touch is compared with every one-stroke
  template of the class at once: the open ones in one product of the touch's path with the
  templates' paths, as traced and reversed (stacked per class at fit time: a matrix of
  2 m x 2n by a vector, in blocks small enough that BLAS keeps to one thread, as threads
  stall on a busy machine); the closed ones from every start and both directions as a circular
  cross-correlation of the paths taken as complex numbers (the templates' FFTs computed once).
  Where the recogniser's own features are that path (the cloud's, for a touch of one stroke),
  the check reads them instead of resampling the touch again;
- **the threshold is calibrated on the codebook** as the shape distance's is (:mod:`.base`):
  ``auto_scale`` times the ``auto_quantile`` quantile of the path distances of the class's
  one-stroke templates to their nearest other such template (leave one out). A class with
  fewer than two one-stroke templates has nothing to calibrate with and no check (its touches
  of one stroke are a matter for :mod:`.evidence`'s stroke counts). At most ``per_class``
  evenly spaced templates per class are left out, which bounds the cost of the calibration.

A codebook that does not know its templates' paths (one loaded from a file without them)
skips the check.
"""

from __future__ import annotations

import math

import numpy as np

from .gesture import TouchGesture

__all__ = ['ORDER_REASON', 'OrderEvidence', 'one_stroke_path']

#: The rejection reason :meth:`OrderEvidence.check` gives.
ORDER_REASON = 'order'
#: Points of a path along the ink ($P's 32).
PATH_POINTS = 32
#: OpenBLAS's matrix-vector product runs on one thread below m x n = 2304 x GEMM_MULTITHREAD_THRESHOLD (4 by
#: default; interface/gemv.c): threads wait for a core on a busy machine, so the products stay below it.
_ONE_THREAD = 2304 * 4


def one_stroke_path(gesture: TouchGesture, n_points: int = PATH_POINTS) -> np.ndarray | None:
    """(n_points, 2) float64 path of a one-stroke ``gesture`` along its ink, centred and divided by
    the larger side of its box; None for a touch of several strokes or without points."""
    from .clouds import cloud_features  # here: clouds imports base, which imports this module

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
        z = np.where(one_stroke[:, None], paths[..., 0] + 1j * paths[..., 1], 0.0)   # (T, n) complex
        self._energy = (np.abs(z) ** 2).sum(axis=1)                                  # (T,)
        self._paths = np.where(one_stroke[:, None, None], paths, 0.0)                 # (T, n, 2)
        self._spectra = np.fft.fft(z, axis=1)                                        # (T, n)
        self._closed = one_stroke & (np.abs(z[:, 0] - z[:, -1]) < closed)
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

    def _gathered(self, templates: np.ndarray) -> tuple[list[tuple[np.ndarray, np.ndarray]], np.ndarray, np.ndarray]:
        """What :meth:`_distance` reads of the given templates (indices): the open ones' paths as traced and
        reversed, (2 m_open, 2n) times 2, with their (2 m_open,) energies, in blocks of rows small enough for
        one thread (:data:`_ONE_THREAD`); the closed ones' (m_closed, n) spectra with their (m_closed,) energies."""
        loops = self._closed[templates]
        opened, closed = templates[~loops], templates[loops]
        n = self.n_points
        paths = self._paths[opened]
        both = 2.0 * np.concatenate([paths, paths[:, ::-1]]).reshape(-1, 2 * n)
        energy = np.tile(self._energy[opened], 2)
        rows = max(1, (_ONE_THREAD - 1) // (2 * n))
        blocks = [(both[i:i + rows], energy[i:i + rows]) for i in range(0, len(both), rows)]
        return blocks, self._spectra[closed], self._energy[closed]

    def path_distance(self, path: np.ndarray, templates: np.ndarray) -> float:
        """Smallest root-mean-square point distance of an (n, 2) path to the given templates' paths
        (indices), in either direction, from any start on a closed template (inf without templates)."""
        if len(templates) == 0:
            return float('inf')
        return self._distance(path, *self._gathered(templates))

    def _distance(self, path: np.ndarray, open_blocks: list[tuple[np.ndarray, np.ndarray]],
                  closed_spectra: np.ndarray, closed_energy: np.ndarray) -> float:
        """:meth:`path_distance` to templates gathered by :meth:`_gathered`."""
        # sum_k |t_k - q_(k+s)|^2 = |t|^2 + |q|^2 - 2 sum_k (t_k . q_(k+s)), the points as 2-vectors. An open
        # template is read from either end of the touch only (s = 0; the touch reversed is the template
        # reversed): one product of the touch's (2n,) path with the templates' both ways, doubled at fit
        # time. A closed one from any start: the sums for every shift s at once are the circular
        # cross-correlation of the paths as complex numbers, Re ifft(fft(t) * conj(fft(q))).
        xy = np.ascontiguousarray(path, dtype=np.float64)                            # (n, 2)
        flat = xy.reshape(-1)                                                        # x, y interleaved
        best = np.inf
        for paths2, energy in open_blocks:
            best = _smaller(best, float((energy - paths2 @ flat).min()))
        if len(closed_energy):
            q = xy.view(np.complex128).reshape(-1)                                   # (n,) x + iy, no copy
            spectra = np.conj(np.fft.fft(np.stack([q, q[::-1]]), axis=1))              # (2, n)
            corr = np.fft.ifft(closed_spectra[:, None, :] * spectra, axis=2).real  # (m_closed, 2, n)
            best = _smaller(best, float((closed_energy - 2 * corr.max(axis=(1, 2))).min()))
        return math.sqrt(max(best + float(flat @ flat), 0.0) / self.n_points)

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
