"""The recognisers people use for traced gestures, as peers to measure the paper's against.

- :class:`DollarOneRecogniser`: $1 (Wobbrock, Wilson and Li, UIST 2007).
- :class:`ProtractorRecogniser`: Protractor (Li, CHI 2010), orientation-sensitive by default.
- :class:`PointCloudRecogniser`: $P (Vatavu, Anthony and Wobbrock, ICMI 2012), direction-blind.
- :class:`DTWRecogniser`: dynamic time warping (Sakoe and Chiba 1978) with a Sakoe-Chiba band.

Each is vectorised over the codebook: all templates advance together through the search loops.
"""

from __future__ import annotations

import math

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.features import arc_length_resample, nna_indices
from touch_gestures.skin.gesture import TouchGesture

__all__ = ['DTWRecogniser', 'DollarOneRecogniser', 'PointCloudRecogniser', 'ProtractorRecogniser']

_PHI = 0.5 * (math.sqrt(5.0) - 1.0)


def _rotate(points: np.ndarray, angle: float | np.ndarray) -> np.ndarray:
    """Rotate (..., n, 2) points about the origin by ``angle`` radians (scalar or (...,) array)."""
    c, s = np.cos(angle), np.sin(angle)
    if np.ndim(angle):
        c, s = c[..., None], s[..., None]
    x, y = points[..., 0], points[..., 1]
    return np.stack([x * c - y * s, x * s + y * c], axis=-1)


def _path(gesture: TouchGesture) -> np.ndarray | None:
    return None if len(gesture.trajectory) == 0 else gesture.trajectory.astype(np.float64)


class DollarOneRecogniser(TemplateRecogniser):
    """$1 unistroke recogniser (Wobbrock et al. 2007), vectorised over the codebook.

    Distance: the mean distance between corresponding points after the best rotation, in
    units of ``square_size`` (the $1 "path distance").

    Args:
        n_points: resampled points (the $1 paper's N = 64).
        rotation_invariant: rotate to the indicative angle first (the $1 paper does); on a
            skin, where a line's orientation is the command, False keeps orientation.
        angle_range_deg: golden-section search range, +- degrees (the paper's 45).
        angle_precision_deg: search stops at this bracket (the paper's 2).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.
    """

    name = 'dollar1'

    @property
    def direction_aware(self) -> bool:  # rotated to its indicative angle, a line equals its reverse
        return not self.rotation_invariant

    def __init__(self, n_points: int = 64, rotation_invariant: bool = True, angle_range_deg: float = 45.0,
                 angle_precision_deg: float = 2.0, max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.rotation_invariant = rotation_invariant
        self.angle_range_deg = angle_range_deg
        self.angle_precision_deg = angle_precision_deg
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        path = _path(gesture)
        if path is None:
            return None
        pts = arc_length_resample(path, self.n_points)
        pts = pts - pts.mean(axis=0)
        if self.rotation_invariant:
            pts = _rotate(pts, -math.atan2(pts[0, 1], pts[0, 0]))  # centroid->first point at angle 0
        span = np.ptp(pts, axis=0)
        # Non-uniform scaling to a unit square, as $1 does; a flat axis (a line) is left unscaled.
        pts = pts / np.where(span > 1e-9, span, 1.0)
        return pts.reshape(-1).astype(np.float32)

    def distances(self, query: np.ndarray) -> np.ndarray:
        templates = self.templates_
        qx, qy = query[0::2].astype(np.float64), query[1::2].astype(np.float64)
        tx, ty = templates[:, 0::2], templates[:, 1::2]

        def path_distance(angle: np.ndarray) -> np.ndarray:
            c, s = np.cos(angle)[:, None], np.sin(angle)[:, None]
            return np.hypot(c * qx - s * qy - tx, s * qx + c * qy - ty).mean(axis=1)

        # Golden-section search, one bracket per template, all templates at once.
        a = np.full(len(templates), -math.radians(self.angle_range_deg))
        b = -a
        x1 = _PHI * a + (1 - _PHI) * b
        x2 = (1 - _PHI) * a + _PHI * b
        f1, f2 = path_distance(x1), path_distance(x2)
        precision = math.radians(self.angle_precision_deg)
        for _ in range(max(0, math.ceil(math.log(precision / (b[0] - a[0])) / math.log(_PHI)))):
            left = f1 < f2  # the minimum lies in [a, x2]
            b = np.where(left, x2, b)
            a = np.where(left, a, x1)
            x2n = np.where(left, x1, (1 - _PHI) * a + _PHI * b)
            x1n = np.where(left, _PHI * a + (1 - _PHI) * b, x2)
            fn = path_distance(np.where(left, x1n, x2n))
            f2, f1 = np.where(left, f1, fn), np.where(left, fn, f2)
            x1, x2 = x1n, x2n
        return np.minimum(f1, f2)


class ProtractorRecogniser(TemplateRecogniser):
    """Protractor (Li 2010): closed-form best rotation and angular distance, vectorised.

    Distance: the angle (radians, 0..pi) between the query and template vectors after the
    optimal rotation; Protractor's score is its inverse.

    Args:
        n_points: resampled points (Protractor's 16).
        orientation_sensitive: snap the indicative angle to 8 base orientations instead of
            removing it (Protractor's orientation-sensitive mode), so a line's direction counts.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.
    """

    name = 'protractor'
    direction_aware = False  # the free optimal rotation turns a line into its reverse

    def __init__(self, n_points: int = 16, orientation_sensitive: bool = True,
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.orientation_sensitive = orientation_sensitive
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        path = _path(gesture)
        if path is None:
            return None
        pts = arc_length_resample(path, self.n_points)
        pts = pts - pts.mean(axis=0)
        indicative = math.atan2(pts[0, 1], pts[0, 0])
        delta = -indicative
        if self.orientation_sensitive:
            base = (math.pi / 4) * math.floor((indicative + math.pi / 8) / (math.pi / 4))
            delta = base - indicative
        vec = _rotate(pts, delta).reshape(-1)
        norm = float(np.linalg.norm(vec))
        # A point that never moved has no shape: a zero vector, at distance pi/2 from everything.
        return (vec / norm if norm > 1e-9 else np.zeros_like(vec)).astype(np.float32)

    def distances(self, query: np.ndarray) -> np.ndarray:
        templates = self.templates_
        qx, qy = query[0::2], query[1::2]
        tx, ty = templates[:, 0::2], templates[:, 1::2]
        a = tx @ qx + ty @ qy
        b = tx @ qy - ty @ qx
        angle = np.arctan2(b, a)
        similarity = a * np.cos(angle) + b * np.sin(angle)
        return np.arccos(np.clip(similarity, -1.0, 1.0))


class PointCloudRecogniser(TemplateRecogniser):
    """$P point-cloud recogniser (Vatavu et al. 2012), vectorised over the codebook.

    Distance: the smallest weighted greedy-matching cost over the start points, in units of
    the gesture's size (the $P "cloud distance", which does not depend on stroke direction).

    Args:
        n_points: points per cloud ($P's 32).
        epsilon: start points are every ``floor(n ** (1 - epsilon))`` (0.5 in $P).
        preselect: run the greedy matching only on this many templates closest by Chamfer
            distance (as $Q prunes the codebook; None matches every template, exact $P).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.
    """

    name = 'pdollar'
    direction_aware = False

    def __init__(self, n_points: int = 32, epsilon: float = 0.5, preselect: int | None = 64,
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.epsilon = epsilon
        self.preselect = preselect
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        path = _path(gesture)
        if path is None:
            return None
        # $P resamples along the ink of every stroke, not across the lifts between them.
        pts = arc_length_resample(path, self.n_points, gesture.stroke)
        size = float(np.ptp(pts, axis=0).max())
        pts = (pts - pts.mean(axis=0)) / (size if size > 1e-9 else 1.0)
        return pts.reshape(-1).astype(np.float32)

    def distances(self, query: np.ndarray) -> np.ndarray:
        n = self.n_points
        q = query.reshape(n, 2)
        t = self.templates_.reshape(len(self.templates_), n, 2)
        # (T, n, n) pairwise distances, query point i to template point j.
        pair = np.hypot(q[None, :, None, 0] - t[:, None, :, 0], q[None, :, None, 1] - t[:, None, :, 1])
        out = np.full(len(t), np.inf)
        candidates = np.arange(len(t))
        if self.preselect is not None and len(t) > self.preselect:
            # The Chamfer distance (each point to its nearest in the other cloud) is one reduction
            # and ranks clouds much as $P does; only the closest go through the greedy matching.
            chamfer = pair.min(axis=2).sum(axis=1) + pair.min(axis=1).sum(axis=1)
            candidates = np.argpartition(chamfer, self.preselect)[: self.preselect]
        out[candidates] = self._greedy_all(pair[candidates])
        return out

    def _greedy_all(self, pair: np.ndarray) -> np.ndarray:
        """$P's greedy weighted matching from every start point, both ways, for all templates at
        once: (T, n, n) costs -> (T,) smallest sums. All runs advance together, one point per step."""
        T, n, _ = pair.shape
        starts = np.arange(0, n, max(1, int(n ** (1.0 - self.epsilon))))
        S = len(starts)
        both = np.stack([pair, pair.transpose(0, 2, 1)]).astype(np.float32)  # query->template, template->query
        work = np.broadcast_to(both[:, None], (2, S, T, n, n)).reshape(2 * S * T, n, n).copy()
        runs = np.arange(len(work))
        start_of = np.tile(np.repeat(starts, T), 2)
        total = np.zeros(len(work))
        for k in range(n):
            cost = work[runs, (start_of + k) % n]  # (runs, n): this step's point against every other point
            j = cost.argmin(axis=1)
            total += (1.0 - k / n) * cost[runs, j]
            work[runs, :, j] = np.inf  # matched: no other point may take it
        return total.reshape(2, S, T).min(axis=(0, 1))


class DTWRecogniser(TemplateRecogniser):
    """Dynamic time warping between resampled trajectories, vectorised along anti-diagonals.

    Trajectories are resampled to ``n_points`` (uniformly in time, or along the arc),
    centred and scaled uniformly by their larger bounding-box side. The distance is the
    DTW cost (sum of point distances along the best warping path within the band) divided
    by ``n_points``.

    Args:
        n_points: resampled points.
        band: Sakoe-Chiba band half-width, points (a path may not stray further from the
            diagonal); ``n_points`` for no band.
        resample: ``'time'`` (nearest-neighbour in time, as cirillo2017's NNA) or ``'arc'``.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.
    """

    name = 'dtw'
    direction_aware = True

    def __init__(self, n_points: int = 32, band: int = 4, resample: str = 'time',
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.band = band
        self.resample = resample
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        if self.resample not in ('time', 'arc'):
            raise ValueError(f"resample must be 'time' or 'arc', got {self.resample!r}")
        path = _path(gesture)
        if path is None:
            return None
        if self.resample == 'arc':
            pts = arc_length_resample(path, self.n_points)
        else:
            pts = path[nna_indices(len(path), self.n_points)]
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        size = float((hi - lo).max())
        pts = (pts - 0.5 * (lo + hi)) / (size if size > 1e-9 else 1.0)
        return pts.reshape(-1).astype(np.float32)

    def distances(self, query: np.ndarray) -> np.ndarray:
        templates = self.templates_
        n, band = self.n_points, max(0, int(self.band))
        q = query.reshape(n, 2)
        t = templates.reshape(len(templates), n, 2).transpose(1, 2, 0)  # (n, 2, T): templates last, contiguous
        prev = np.full((n + 1, t.shape[2]), np.inf, dtype=np.float32)
        prev[0] = 0.0
        for i in range(1, n + 1):
            lo, hi = max(1, i - band), min(n, i + band)
            # Costs of template point i-1 against the query points in the band, (w, T).
            cost = np.hypot(t[i - 1, 0][None, :] - q[lo - 1:hi, 0, None], t[i - 1, 1][None, :] - q[lo - 1:hi, 1, None])
            # The vertical and diagonal steps are vectorised over the band; only the
            # horizontal step (from j-1 in the same row) is sequential.
            vert_diag = np.minimum(prev[lo:hi + 1], prev[lo - 1:hi])
            cur = np.full_like(prev, np.inf)
            left = cur[lo - 1]
            for w in range(hi - lo + 1):
                left = cost[w] + np.minimum(vert_diag[w], left)
                cur[lo + w] = left
            prev = cur
        return prev[n] / n
