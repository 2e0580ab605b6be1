"""Point clouds that know which way their ink runs: :class:`OrientedCloudRecogniser`.

Each point carries the undirected orientation theta of the ink through it, as ``(cos 2 theta, sin 2
theta)``; the distance between two points is ``|p - q| + w * |o_p - o_q|`` (positions in gesture sizes,
``w = orientation_weight``); a dot carries ``o = 0``. This is $P's cloud with a per-point direction, as
$P+ adds turning angles (Vatavu, ICMI 2017); it stays free of stroke order and direction.

A query's distance to a template is the directed Chamfer distance, read from a raster as $Q reads its
lookup tables: each template's distance field is sampled on ``grid`` x ``grid`` positions x ``bins``
orientations (+ one code for none). The raster error is at most ``sqrt(2) / grid + w * 2 sin(pi / (2
bins))`` (test/test_skin_oriented.py). :class:`OrientedFusedRecogniser` sums it with the trace.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser, nearest_allowed
from touch_gestures.skin.features import arc_length_resample_complex, running_ink
from touch_gestures.skin.fused import FusedRecogniser, sum_rule_nearest
from touch_gestures.skin.gesture import TouchGesture

__all__ = ['OrientedCloudRecogniser', 'OrientedFusedRecogniser', 'distance_field', 'exact_oriented_chamfer',
           'gather_mean', 'oriented_cloud', 'raster_cells']

#: Values per point of an oriented cloud: x, y, cos 2 theta, sin 2 theta.
POINT_WIDTH = 4


def _resampled_strokes(points: np.ndarray, stroke: np.ndarray | None, n: int) -> tuple[np.ndarray, np.ndarray]:
    """(m, 2) points, (m,) stroke ids -> (n, 2) float64 points along the ink and (n,) the stroke of each."""
    pts = np.ascontiguousarray(points, dtype=np.float64)
    path = arc_length_resample_complex(pts, n, stroke)
    ids = np.zeros(len(pts), dtype=np.int64) if stroke is None else np.asarray(stroke)
    # The stroke of each resampled point: the one its ink position falls in (the air adds no length), a target
    # at a stroke's end (where the air step of length 0 starts) in that stroke.
    cum = running_ink(pts.view(np.complex128).reshape(-1), stroke)
    at = np.clip(np.searchsorted(cum, np.linspace(0.0, cum[-1], n), side='left'), 0, len(pts) - 1)
    return np.column_stack([path.real, path.imag]), ids[at]


def oriented_cloud(points: np.ndarray, stroke: np.ndarray | None, n_points: int = 32) -> np.ndarray:
    """(m, 2) points with (m,) stroke ids -> (n_points, 4) float64: x, y, cos 2 theta, sin 2 theta per point.

    Resampled along the ink, centred on the mean, divided by the larger side of the box (as
    :func:`~touch_gestures.skin.features.cloud_features`). theta is the direction of the ink through the point, from its
    neighbours of the same stroke (one neighbour at a stroke's end; none: no orientation, 0, 0).

    >>> c = oriented_cloud(np.array([[0.0, 0], [4, 0], [0, 4], [0, 8]]), np.array([0, 0, 1, 1]), 4)
    >>> c[:, 2:].round(2).tolist()   # a horizontal stroke (cos 0 = 1), then a vertical one (cos 2 * 90 deg = -1)
    [[1.0, 0.0], [1.0, 0.0], [-1.0, 0.0], [-1.0, 0.0]]
    """
    xy, ids = _resampled_strokes(points, stroke, n_points)
    xy -= np.cumsum(xy, axis=0)[-1] / n_points   # the mean, summed in point order
    size = float(max(np.ptp(xy[:, 0]), np.ptp(xy[:, 1])))
    if size > 1e-9:
        xy /= size
    same_before = np.r_[False, ids[1:] == ids[:-1]]
    same_after = np.r_[ids[:-1] == ids[1:], False]
    before = np.where(same_before, np.arange(n_points) - 1, np.arange(n_points))
    after = np.where(same_after, np.arange(n_points) + 1, np.arange(n_points))
    dx, dy = (xy[after] - xy[before]).T
    square = dx * dx + dy * dy
    directed = square > 1e-18   # a point with no neighbour of its stroke, or none apart from it: no direction
    safe = np.where(directed, square, 1.0)
    cloud = np.empty((n_points, POINT_WIDTH))
    cloud[:, :2] = xy
    # (cos 2 theta, sin 2 theta) of the tangent (dx, dy): its square as a complex number over its squared length.
    cloud[:, 2] = np.where(directed, (dx * dx - dy * dy) / safe, 0.0)
    cloud[:, 3] = np.where(directed, 2.0 * dx * dy / safe, 0.0)
    return cloud


def exact_oriented_chamfer(query: np.ndarray, template: np.ndarray, weight: float) -> float:
    """Mean over the (n, 4) ``query``'s points of the distance to the nearest point of ``template``, every pair
    computed: the distance the raster reads approximate (module doc)."""
    d = np.hypot(query[:, None, 0] - template[None, :, 0], query[:, None, 1] - template[None, :, 1])
    d += weight * np.hypot(query[:, None, 2] - template[None, :, 2], query[:, None, 3] - template[None, :, 3])
    return float(d.min(axis=1).mean())


@functools.lru_cache(maxsize=8)
def _bin_codes(bins: int) -> np.ndarray:
    """(bins + 1, 2) the orientation code of each bin's centre (bin 0 centred on 0 degrees), then (0, 0);
    read-only: made once per ``bins``, shared by every template's field."""
    theta = np.arange(bins) * (math.pi / bins)
    codes = np.vstack([np.column_stack([np.cos(2 * theta), np.sin(2 * theta)]), np.zeros((1, 2))])
    codes.flags.writeable = False
    return codes


@functools.lru_cache(maxsize=8)
def _cell_centres(grid: int) -> np.ndarray:
    """(grid * grid, 2) x, y of each cell's centre, row by row (row = y), over [-1, 1] x [-1, 1]; read-only:
    made once per ``grid``, shared by every template's field."""
    centres = (np.arange(grid) + 0.5) * (2.0 / grid) - 1.0
    cx, cy = np.meshgrid(centres, centres)
    xy = np.column_stack([cx.ravel(), cy.ravel()])
    xy.flags.writeable = False
    return xy


def raster_cells(clouds: np.ndarray, grid: int, bins: int) -> np.ndarray:
    """(..., n, 4) oriented clouds -> (..., n) flat raster index, ``(row * grid + column) * (bins + 1) + bin``.

    Positions clip to the raster's border cells; bin k holds the orientations within ``pi / (2 bins)`` of
    ``k pi / bins`` (horizontal ink: bin 0), the code ``bins`` the points without orientation.

    >>> raster_cells(np.array([[-1.0, -1.0, 1.0, 0.0], [0.99, 0.99, -1.0, 0.0], [0.0, 0.0, 0.0, 0.0]]), 2, 4).tolist()
    [0, 17, 19]
    """
    ij = np.clip(((clouds[..., :2] + 1.0) * (grid / 2.0)).astype(np.intp), 0, grid - 1)
    # 2 theta in (-pi, pi]: bin round(theta / (pi / bins)) modulo bins.
    half_turns = np.arctan2(clouds[..., 3], clouds[..., 2]) * (bins / (2 * math.pi))
    k = np.floor(half_turns + 0.5).astype(np.intp) % bins
    k[clouds[..., 2] * clouds[..., 2] + clouds[..., 3] * clouds[..., 3] < 0.25] = bins   # (0, 0)
    return (ij[..., 1] * grid + ij[..., 0]) * (bins + 1) + k


def distance_field(cloud: np.ndarray, grid: int, bins: int, weight: float) -> np.ndarray:
    """(n, 4) oriented cloud -> (grid * grid * (bins + 1),) float32: each raster cell's distance to the nearest
    point of the cloud (its centre's position and its bin's orientation; :func:`raster_cells` order)."""
    centres, codes = _cell_centres(grid), _bin_codes(bins)
    positional = np.hypot(centres[:, None, 0] - cloud[None, :, 0], centres[:, None, 1] - cloud[None, :, 1])
    angular = weight * np.hypot(codes[:, None, 0] - cloud[None, :, 2], codes[:, None, 1] - cloud[None, :, 3])
    return (positional[:, None, :] + angular[None, :, :]).min(axis=2).ravel().astype(np.float32)


def gather_mean(fields: np.ndarray, cells: np.ndarray) -> np.ndarray:
    """(C, T) float32 fields, (n,) cells -> (T,) float32 mean of the rows the cells name, added in order in float32
    and divided once. (numpy's ``mean(axis=0)`` adds rows in order too,
    except for a single column, T = 1, which it adds pairwise: an ulp apart now and then.)

    >>> gather_mean(np.array([[1.0, 2.0], [3.0, 4.0]], dtype=np.float32), np.array([0, 1, 1])).tolist()
    [2.3333332538604736, 3.3333332538604736]
    """
    rows = fields[cells]
    return np.add.accumulate(rows, axis=0)[-1] / np.float32(len(rows))


class OrientedCloudRecogniser(TemplateRecogniser):
    """Order- and direction-free matching of clouds whose points carry the ink's orientation (module doc).

    Args:
        n_points: points per cloud.
        grid: side of the position raster (cells of ``2 / grid`` gesture sizes).
        bins: orientation bins over 180 degrees (plus one code for points without orientation).
        orientation_weight: ``w`` of the point distance, gesture sizes per unit of ``|o_p - o_q|`` (0..2).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`.

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

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0 or not np.isfinite(gesture.trajectory).all():
            return None   # a NaN point would make the ink's length NaN: no cloud, not a dab
        cloud = oriented_cloud(gesture.trajectory, gesture.stroke, self.n_points).ravel()
        return cloud.astype(np.float32) if np.isfinite(cloud).all() else None

    def _prepare_codebook(self) -> None:
        clouds = self.templates_.reshape(len(self.templates_), self.n_points, POINT_WIDTH).astype(np.float64)
        fields = np.empty((self.grid * self.grid * (self.bins + 1), len(clouds)), dtype=np.float32)
        for k, cloud in enumerate(clouds):
            fields[:, k] = distance_field(cloud, self.grid, self.bins, self.orientation_weight)
        self._fields = fields   # cells first: a query's n cells gather n contiguous rows

    def distances(self, query: np.ndarray) -> np.ndarray:
        cloud = np.asarray(query, dtype=np.float64).reshape(self.n_points, POINT_WIDTH)
        return gather_mean(self._fields, raster_cells(cloud, self.grid, self.bins))   # (T,) float32

    def query_cells(self, gesture: TouchGesture) -> np.ndarray | None:
        """(n_points,) raster cells of ``gesture``'s oriented cloud (made from its float64 points, not from the
        float32 features), or None if it is unusable (no point, or a NaN or infinite one; float32 points, as a
        gesture holds them, never overflow the float64 ink)."""
        points = gesture.trajectory
        if len(points) == 0 or not np.isfinite(points).all():
            return None
        return raster_cells(oriented_cloud(points, gesture.stroke, self.n_points), self.grid, self.bins)

    def class_distances(self, gesture: TouchGesture) -> np.ndarray | None:
        # The query side without its features: the cells they would fall in, and one gather (what the fused
        # recogniser asks on every touch).
        self._check_fitted()
        cells = self.query_cells(gesture)
        if cells is None:
            return None
        distances = gather_mean(self._fields, cells)
        return np.minimum.reduceat(distances, self.class_starts_).astype(np.float64, copy=False)


class OrientedFusedRecogniser(TemplateRecogniser):
    """The fused recogniser with the oriented cloud, not the cloud, naming the class with the trace.

    Made of a :class:`~touch_gestures.skin.fused.FusedRecogniser` (:attr:`fused_`) and an
    :class:`OrientedCloudRecogniser` (:attr:`oriented_`). The fused recogniser's cloud decides: distances,
    thresholds, rejection, the end of a gesture and early candidates are its own, so what fires is what the
    cloud alone fires (as in ``fused``); the class is the smallest sum of the oriented cloud's and the trace's
    relative distances. A template holds the cloud's features, the oriented cloud's, then the trace's.

    Args:
        n_points, trace_points, stroke_orders: as :class:`~touch_gestures.skin.fused.FusedRecogniser`.
        grid, bins, orientation_weight: the oriented cloud's (:class:`OrientedCloudRecogniser`).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base` (the
            cloud's distances).

    Attributes:
        fused_: the fitted fused recogniser (its codebook: the templates less the oriented cloud's part).
        oriented_: the fitted oriented cloud (the templates' part after the cloud's).
    """

    name = 'fused_oriented'
    direction_aware = False

    def __init__(self, n_points: int = 32, trace_points: int = 32, stroke_orders: int = 3, grid: int = 24,
                 bins: int = 8, orientation_weight: float = 0.35, max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.trace_points = trace_points
        self.stroke_orders = stroke_orders
        self.grid = grid
        self.bins = bins
        self.orientation_weight = orientation_weight
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def parts(self) -> tuple[FusedRecogniser, OrientedCloudRecogniser]:
        """New, unfitted fused recogniser and oriented cloud (no limits of their own)."""
        return (FusedRecogniser(n_points=self.n_points, trace_points=self.trace_points,
                                stroke_orders=self.stroke_orders, max_distance=None),
                OrientedCloudRecogniser(n_points=self.n_points, grid=self.grid, bins=self.bins,
                                        orientation_weight=self.orientation_weight, max_distance=None))

    def _check_params(self) -> None:
        super()._check_params()
        for part in self.parts():
            part._check_params()

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        fused, oriented = self.parts()
        both, own = fused.features(gesture), oriented.features(gesture)
        if both is None or own is None:
            return None
        split = fused.cloud_width
        return np.concatenate([both[:split], own, both[split:]]).astype(np.float32, copy=False)

    def _prepare_codebook(self) -> None:
        fused, oriented = self.parts()
        split, width = fused.cloud_width, POINT_WIDTH * self.n_points
        trace = 2 * self.trace_points
        if self.templates_.shape[1] <= split + width or (self.templates_.shape[1] - split - width) % trace:
            raise ValueError(f'a {self.name} codebook holds the cloud ({split} values), the oriented cloud ({width}) '
                             f'and the trace ({trace} values) of one or more stroke orders; got templates of '
                             f'{self.templates_.shape[1]} (made with other n_points or trace_points?)')
        labels = self.classes_[self.template_labels_]
        unlimited = np.full(len(self.classes_), np.inf)   # thresholds are this recogniser's, not the parts'
        fused.set_codebook(np.hstack([self.templates_[:, :split], self.templates_[:, split + width:]]), labels,
                           class_thresholds=unlimited, template_strokes=self.template_strokes_,
                           template_contact_s=self.template_contact_s_)
        oriented.set_codebook(self.templates_[:, split:split + width], labels, class_thresholds=unlimited)
        self.fused_, self.oriented_ = fused, oriented

    def deciding_recogniser(self) -> TemplateRecogniser:
        return self.fused_.deciding_recogniser()

    def _query_features(self, gesture: TouchGesture) -> np.ndarray | None:
        return self.fused_.cloud_.features(gesture)

    def one_stroke_path_of(self, gesture: TouchGesture, query: np.ndarray) -> np.ndarray | None:
        return self.fused_.one_stroke_path_of(gesture, query)

    def distances(self, query: np.ndarray) -> np.ndarray:
        return self.fused_.distances(query)   # a template's or a query's: the cloud comes first

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        trace = self.fused_.trace_.class_distances(gesture)
        oriented = self.oriented_.class_distances(gesture)   # the oriented cloud's, in the cloud's place
        if trace is None or oriented is None:   # either cannot read the touch: the cloud alone
            return nearest_allowed(per_class, allowed)
        return sum_rule_nearest(oriented, trace, allowed)
