"""Point clouds that know which way their ink runs: :class:`OrientedCloudRecogniser`.

The cloud (:mod:`.clouds`) forgets stroke order and direction, which is right for symbols people
write their own way, but it also forgets the *orientation* of the ink at each point, which is
neither: an N's diagonal and an H's bar cross the same middle of the box, an I's serifs and an H's
legs end at the same corners. Each point here carries the orientation of the ink through it, as an
undirected angle theta (a line traced either way has one orientation), encoded as
``(cos 2 theta, sin 2 theta)``: the distance between two points is

    ``|p - q| + w * |o_p - o_q|``  (positions in gesture sizes, ``w = orientation_weight``),

where ``|o_p - o_q| = 2 |sin(theta_p - theta_q)|``: 0 for parallel ink, 2 for crossing ink. A point
of a stroke too short to have a direction (a dot) carries ``o = 0``, 1 from every orientation. This
is $P's cloud with a per-point direction, as $P+ adds turning angles (Vatavu, ICMI 2017); it stays
free of stroke order and direction.

The distance of a query to a template is the symmetric Chamfer distance (the mean of the two
directed means of nearest-point distances), read from rasters as $Q reads its lookup tables
(Vatavu, Anthony and Wobbrock, MobileHCI 2018): at fit time each template's distance field is
sampled on ``grid`` x ``grid`` positions x ``bins`` orientations (+ one code for no orientation);
a query's points read their distance to every template in one gather, the query's own field is
made on the same raster and read at the templates' points. Raster error: a point is read at the
centre of its cell, at most half a cell diagonal (``sqrt(2) / grid`` gesture sizes) away, and its
orientation at the centre of its bin, at most ``pi / (2 bins)`` off (``w * 2 sin(pi / (2 bins))``):
each directed mean is within the sum of the two of the exact one (test/test_skin_oriented.py).

Measured leave-one-person-out through the virtual skin (``social-touch eval skin --traces <file>
--json --recognisers fused,fused_oriented``; docs/skin-multistroke.md): as the naming opinion of
:class:`OrientedFusedRecogniser` in place of the cloud, summed with the trace.
"""

from __future__ import annotations

import math

import numpy as np

from .base import TemplateRecogniser
from .features import arc_length_resample_complex
from .fused import FusedRecogniser, relative_distances
from .gesture import TouchGesture

__all__ = ['OrientedCloudRecogniser', 'OrientedFusedRecogniser', 'exact_oriented_chamfer', 'oriented_cloud']

#: Values per point of an oriented cloud: x, y, cos 2 theta, sin 2 theta.
POINT_WIDTH = 4


def _resampled_strokes(points: np.ndarray, stroke: np.ndarray | None, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(m, 2) points, (m,) stroke ids -> (n, 2) float64 points along the ink and (n,) the stroke of each."""
    pts = np.asarray(points, dtype=np.float64)
    path = arc_length_resample_complex(pts, n, stroke)
    ids = np.zeros(len(pts), dtype=np.int64) if stroke is None else np.asarray(stroke, dtype=np.int64)
    # The stroke of each resampled point: the one its ink position falls in (the air adds no length).
    step = np.hypot(*np.diff(pts, axis=0).T)
    step[ids[1:] != ids[:-1]] = 0.0
    cum = np.concatenate([[0.0], np.cumsum(step)])
    target = np.linspace(0.0, cum[-1], n)
    # A target at a stroke's end (where the air step of length 0 starts) belongs to that stroke.
    at = np.clip(np.searchsorted(cum, target, side='left'), 0, len(pts) - 1)
    return np.column_stack([path.real, path.imag]), ids[at]


def oriented_cloud(points: np.ndarray, stroke: np.ndarray | None, n_points: int = 32) -> np.ndarray:
    """(m, 2) points with (m,) stroke ids -> (n_points, 4) float64: x, y, cos 2 theta, sin 2 theta per point.

    Resampled along the ink, centred on the mean, divided by the larger side of the box (as
    :func:`~.clouds.cloud_features`). theta is the direction of the ink through the point, from its
    neighbours of the same stroke (one neighbour at a stroke's end; none: no orientation, 0, 0).

    >>> c = oriented_cloud(np.array([[0.0, 0], [4, 0], [0, 4], [0, 8]]), np.array([0, 0, 1, 1]), 4)
    >>> c[:, 2:].round(2).tolist()   # a horizontal stroke (cos 0 = 1), then a vertical one (cos 2 * 90 deg = -1)
    [[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]
    """
    xy, ids = _resampled_strokes(points, stroke, n_points)
    xy -= xy.mean(axis=0)
    size = float(max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1])))
    if size > 1e-9:
        xy /= size
    same_before = np.r_[False, ids[1:] == ids[:-1]]
    same_after = np.r_[ids[:-1] == ids[1:], False]
    before = np.where(same_before, np.arange(n_points) - 1, np.arange(n_points))
    after = np.where(same_after, np.arange(n_points) + 1, np.arange(n_points))
    tangent = xy[after] - xy[before]
    length = np.hypot(tangent[:, 0], tangent[:, 1])
    theta = np.arctan2(tangent[:, 1], tangent[:, 0])
    directed = length > 1e-9   # a point with no neighbour of its stroke, or none apart from it: no direction
    cloud = np.empty((n_points, POINT_WIDTH))
    cloud[:, :2] = xy
    cloud[:, 2] = np.where(directed, np.cos(2 * theta), 0.0)
    cloud[:, 3] = np.where(directed, np.sin(2 * theta), 0.0)
    return cloud


def exact_oriented_chamfer(a: np.ndarray, b: np.ndarray, weight: float) -> float:
    """Symmetric Chamfer distance of two (n, 4) oriented clouds, every pair computed (the reference the
    raster reads approximate; module doc)."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1])
    d += weight * np.hypot(a[:, None, 2] - b[None, :, 2], a[:, None, 3] - b[None, :, 3])
    return 0.5 * float(d.min(axis=1).mean() + d.min(axis=0).mean())


class OrientedCloudRecogniser(TemplateRecogniser):
    """Order- and direction-free matching of clouds whose points carry the ink's orientation (module doc).

    Args:
        n_points: points per cloud.
        grid: side of the position raster (cells of ``2 / grid`` gesture sizes).
        bins: orientation bins over 180 degrees (plus one code for points without orientation).
        orientation_weight: ``w`` of the point distance, gesture sizes per unit of ``|o_p - o_q|`` (0..2).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.

    The raster of a codebook holds ``grid**2 * (bins + 1)`` float32 per template (24, 8: 20 KiB).
    """

    name = 'oriented'
    direction_aware = False

    def __init__(self, n_points: int = 32, grid: int = 24, bins: int = 8, orientation_weight: float = 0.35,
                 max_distance: float | str | None = 'auto', auto_scale: float = 2.0, auto_quantile: float = 0.9,
                 min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.grid = grid
        self.bins = bins
        self.orientation_weight = orientation_weight
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def _check_params(self) -> None:
        super()._check_params()
        for key, low in (('n_points', 2), ('grid', 2), ('bins', 1)):
            value = getattr(self, key)
            if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < low:
                raise ValueError(f'{key} must be an integer >= {low}, got {value!r}')
        w = self.orientation_weight
        if isinstance(w, bool) or not isinstance(w, int | float | np.floating) or not (math.isfinite(w) and w >= 0):
            raise ValueError(f'orientation_weight must be a finite number >= 0 (gesture sizes), got {w!r}')

    def _features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0 or not np.isfinite(gesture.trajectory).all():
            return None   # a NaN point would make the ink's length NaN: no cloud, not a dab
        cloud = oriented_cloud(gesture.trajectory, gesture.stroke, self.n_points).ravel()
        return cloud.astype(np.float32) if np.isfinite(cloud).all() else None

    # --- the raster -----------------------------------------------------------------------------------

    def _codes(self) -> np.ndarray:
        """(bins + 1, 2) orientation code of each bin's centre, then (0, 0): no orientation."""
        theta = (np.arange(self.bins) + 0.5) * (math.pi / self.bins)
        return np.vstack([np.column_stack([np.cos(2 * theta), np.sin(2 * theta)]), np.zeros((1, 2))])

    def _cells(self, clouds: np.ndarray) -> np.ndarray:
        """(..., n, 4) oriented clouds -> (..., n) flat raster index ((row * grid + column) * (bins + 1) + bin)."""
        g, b = self.grid, self.bins
        ij = np.clip(((clouds[..., :2] + 1.0) * (g / 2.0)).astype(np.intp), 0, g - 1)
        theta = np.mod(0.5 * np.arctan2(clouds[..., 3], clouds[..., 2]), math.pi)
        k = np.minimum((theta * (b / math.pi)).astype(np.intp), b - 1)
        k[np.hypot(clouds[..., 2], clouds[..., 3]) < 0.5] = b   # (0, 0): no orientation
        return (ij[..., 1] * g + ij[..., 0]) * (b + 1) + k

    def _field(self, cloud: np.ndarray) -> np.ndarray:
        """(n, 4) oriented cloud -> (grid**2 * (bins + 1),) float32: each cell's distance to its nearest point."""
        positional = np.hypot(self._centres[:, None, 0] - cloud[None, :, 0],
                              self._centres[:, None, 1] - cloud[None, :, 1])               # (g*g, n)
        angular = self.orientation_weight * np.hypot(self._code_table[:, None, 0] - cloud[None, :, 2],
                                                     self._code_table[:, None, 1] - cloud[None, :, 3])  # (b+1, n)
        return (positional[:, None, :] + angular[None, :, :]).min(axis=2).ravel().astype(np.float32)

    def _prepare_codebook(self) -> None:
        g = self.grid
        centres = (np.arange(g) + 0.5) * (2.0 / g) - 1.0
        cx, cy = np.meshgrid(centres, centres)            # (g, g), row = y
        self._centres = np.column_stack([cx.ravel(), cy.ravel()])
        self._code_table = self._codes()
        clouds = self.templates_.reshape(len(self.templates_), self.n_points, POINT_WIDTH).astype(np.float64)
        fields = np.empty((len(self._centres) * len(self._code_table), len(clouds)), dtype=np.float32)
        for k, cloud in enumerate(clouds):
            fields[:, k] = self._field(cloud)
        self._fields = fields                            # cells first: a query's n cells gather n rows
        self._template_cells = self._cells(clouds)       # (T, n)

    def _distances(self, query: np.ndarray) -> np.ndarray:
        cloud = np.asarray(query, dtype=np.float64).reshape(self.n_points, POINT_WIDTH)
        to_templates = self._fields[self._cells(cloud)].mean(axis=0)          # (T,) query -> template
        from_templates = self._field(cloud)[self._template_cells].mean(axis=1)  # (T,) template -> query
        return 0.5 * (to_templates + from_templates)


class OrientedFusedRecogniser(FusedRecogniser):
    """:class:`~.fused.FusedRecogniser` with the oriented cloud, not the cloud, naming the class with the trace.

    The cloud stays the primary: distances, thresholds, rejection, the end of a gesture and early
    candidates are its own, so what fires is what the cloud alone fires (as in ``fused``); the class
    is the smallest sum of the oriented cloud's and the trace's relative distances.

    Args:
        n_points, trace_points, stroke_orders: as :class:`~.fused.FusedRecogniser`.
        grid, bins, orientation_weight: the oriented cloud's (:class:`OrientedCloudRecogniser`).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base` (the cloud's distances).

    Attributes:
        oriented_: the fitted oriented cloud (its codebook: the templates' part after the cloud's).
    """

    name = 'fused_oriented'

    def __init__(self, n_points: int = 32, trace_points: int = 32, stroke_orders: int = 3, grid: int = 24,
                 bins: int = 8, orientation_weight: float = 0.35, max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        super().__init__(n_points=n_points, trace_points=trace_points, stroke_orders=stroke_orders,
                         max_distance=max_distance, auto_scale=auto_scale, auto_quantile=auto_quantile,
                         min_margin=min_margin)
        self.grid = grid
        self.bins = bins
        self.orientation_weight = orientation_weight

    def _oriented(self) -> OrientedCloudRecogniser:
        return OrientedCloudRecogniser(n_points=self.n_points, grid=self.grid, bins=self.bins,
                                       orientation_weight=self.orientation_weight, max_distance=None)

    def _check_params(self) -> None:
        super()._check_params()
        self._oriented()._check_params()

    def _features(self, gesture: TouchGesture) -> np.ndarray | None:
        # A template's: the fused ones with the oriented cloud after the cloud.
        fused = super()._features(gesture)
        oriented = self._oriented()._features(gesture)
        if fused is None or oriented is None:
            return None
        split = self._primary_width(self._parts()[0])
        return np.concatenate([fused[:split], oriented, fused[split:]])

    def _oriented_width(self) -> int:
        return POINT_WIDTH * self.n_points

    def _trace_start(self, split: int) -> int:
        return split + self._oriented_width()

    def _prepare_codebook(self) -> None:
        super()._prepare_codebook()
        split = self._split
        oriented = self._oriented()
        unlimited = np.full(len(self.classes_), np.inf)
        oriented.set_codebook(self.templates_[:, split:split + self._oriented_width()],
                              self.classes_[self.template_labels_], class_thresholds=unlimited)
        self.oriented_ = oriented

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        second = self.referee_.class_distances(gesture)
        first = self.oriented_.class_distances(gesture)
        if second is None or first is None:   # the trace or the oriented cloud cannot read it: the cloud alone
            return TemplateRecogniser._nearest(self, gesture, per_class, allowed)
        return TemplateRecogniser._nearest(self, gesture, relative_distances(first) + relative_distances(second),
                                           allowed)
