"""Point clouds for multi-stroke gestures: :class:`CloudRecogniser`.

People write an X, an H or a star with the strokes in any order and either way round; as
an unordered cloud of points the symbol looks the same however it was traced ($P, Vatavu,
Anthony and Wobbrock, ICMI 2012). Measured leave-one-person-out on the Mixed Multistroke
Gestures traces, order-free matching is what tells these symbols apart, while the
time-ordered trace of :class:`~.proposed.TraceRecogniser` loses to the people's different
stroke orders (docs/skin-evaluation.md). The steps:

1. **Resampling along the ink** (``n_points``): the strokes are resampled to ``n_points``
   equally spaced along the ink only ($P's resampling: the air between strokes adds no
   length), then centred on their mean and divided by the larger side of their box.
2. **A $Q-style lookup table** (Vatavu, Anthony and Wobbrock, MobileHCI 2018): at
   fit time each template's distance field is sampled on a ``grid`` x ``grid`` raster;
   a query's points read their distance to every template in one gather, and the
   template points read the query's own distance field the same way. Their mean (the
   symmetric Chamfer distance) is, up to the raster's half-cell, a lower bound of the
   matching cost below, and ranks the codebook in one vectorised pass.
3. **One-to-one matching on the closest** (``exact``): the ``exact`` templates with the
   smallest Chamfer distance are matched point to point with the optimal assignment
   (Hungarian method, :func:`scipy.optimize.linear_sum_assignment`), which $P's greedy
   matching approximates. Its mean point distance is the distance; the other templates
   keep their Chamfer bound, so the margin over the runner-up class is never overstated.

Distances are in units of the gesture's size. The cloud is blind to direction: a line
traced left-to-right and right-to-left are the same cloud. Where a vocabulary tells such
gestures apart, :func:`~.vocabulary.choose_recogniser` picks a direction-aware recogniser.
"""

from __future__ import annotations

import numpy as np
from scipy import ndimage
from scipy.optimize import linear_sum_assignment

from .base import TemplateRecogniser
from .features import arc_length_resample
from .gesture import TouchGesture

__all__ = ['CloudRecogniser', 'cloud_features']

#: Normalised clouds lie within +-1 of their mean; the raster covers that square.
_EXTENT = 1.0


def cloud_features(points: np.ndarray, stroke: np.ndarray | None, n_points: int = 32) -> np.ndarray:
    """(m, 2) points with (m,) stroke ids -> (2 * n_points,) float32 cloud, x and y interleaved.

    Resampled along the ink, centred on the mean, divided by the larger side of the box
    (a dab that never moves stays at the origin).

    >>> f = cloud_features(np.array([[0.0, 0], [4, 0], [0, 4], [4, 4]]), np.array([0, 0, 1, 1]), 4)
    >>> f.reshape(4, 2).round(2).tolist()   # two strokes of 4: every 8/3 along the ink, none in the air
    [[-0.5, -0.5], [0.17, -0.5], [-0.17, 0.5], [0.5, 0.5]]
    """
    pts = arc_length_resample(points, n_points, stroke)
    pts = pts - pts.mean(axis=0)
    size = float(np.ptp(pts, axis=0).max())
    if size > 1e-9:
        pts /= size
    return pts.reshape(-1).astype(np.float32)


class CloudRecogniser(TemplateRecogniser):
    """Order- and direction-free matching of point clouds (module doc).

    Args:
        n_points: points per cloud ($P's 32).
        grid: side of the distance-field raster (cells of ``2 / grid`` gesture sizes).
        exact: templates matched one-to-one after the Chamfer ranking (0: Chamfer only).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'cloud'
    direction_aware = False

    def __init__(self, n_points: int = 32, grid: int = 24, exact: int = 6,
                 max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.grid = grid
        self.exact = exact
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def _check_params(self) -> None:
        super()._check_params()
        if self.n_points < 2 or self.grid < 2 or self.exact < 0:
            raise ValueError(f'need n_points >= 2, grid >= 2 and exact >= 0; got {self.n_points}, {self.grid}, '
                             f'{self.exact}')

    def _features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0:
            return None
        return cloud_features(gesture.trajectory, gesture.stroke, self.n_points)

    def _cells(self, clouds: np.ndarray) -> np.ndarray:
        """(..., n, 2) normalised points -> (..., n) flat raster cell index (clipped to the raster)."""
        ij = np.floor((clouds + _EXTENT) * (self.grid / (2 * _EXTENT))).astype(np.intp)
        np.clip(ij, 0, self.grid - 1, out=ij)
        return ij[..., 1] * self.grid + ij[..., 0]

    def _prepare_codebook(self) -> None:
        n, g = self.n_points, self.grid
        self._clouds = self.templates_.reshape(len(self.templates_), n, 2).astype(np.float64)
        self._cell_mm = 2 * _EXTENT / g   # the raster's cell side, gesture sizes
        centres = (np.arange(g) + 0.5) * self._cell_mm - _EXTENT
        cx, cy = np.meshgrid(centres, centres)            # (g, g), row = y
        raster = np.column_stack([cx.ravel(), cy.ravel()])  # (g*g, 2)
        # (g*g, T): distance from each raster cell to each template's nearest point (its distance
        # field), cells first so that a query's n cells gather n contiguous rows.
        fields = np.empty((g * g, len(self._clouds)), dtype=np.float32)
        for k, cloud in enumerate(self._clouds):
            dx = raster[:, 0, None] - cloud[None, :, 0]
            dy = raster[:, 1, None] - cloud[None, :, 1]
            fields[:, k] = np.sqrt((dx * dx + dy * dy).min(axis=1))
        self._fields = fields
        self._template_cells = self._cells(self._clouds)    # (T, n)

    def _query_field(self, cells: np.ndarray) -> np.ndarray:
        """(g*g,) float32 distance from each raster cell to the nearest occupied cell of the query, in
        gesture sizes (a Euclidean distance transform of the query's raster)."""
        g = self.grid
        empty = np.ones(g * g, dtype=bool)
        empty[cells] = False
        return (ndimage.distance_transform_edt(empty.reshape(g, g)).ravel() * self._cell_mm).astype(np.float32)

    def _distances(self, query: np.ndarray) -> np.ndarray:
        n = self.n_points
        q = query.reshape(n, 2).astype(np.float64)
        cells = self._cells(q)
        # Query -> templates: each query point reads every template's field at its cell; templates ->
        # query: every template point reads the query's field at its cell.
        to_templates = self._fields[cells].sum(axis=0)
        to_query = np.take(self._query_field(cells), self._template_cells).sum(axis=1)
        out = (to_templates + to_query).astype(np.float64) * (0.5 / n)
        k = min(self.exact, len(out))
        if k:
            closest = np.argpartition(out, k - 1)[:k] if k < len(out) else np.arange(len(out))
            exact = np.empty(k)
            for i, t in enumerate(closest):
                dx = q[:, 0, None] - self._clouds[t][None, :, 0]
                dy = q[:, 1, None] - self._clouds[t][None, :, 1]
                cost = np.sqrt(dx * dx + dy * dy)
                rows, cols = linear_sum_assignment(cost)
                exact[i] = cost[rows, cols].mean()
            # The others were ranked farther: none is taken as closer than the farthest matched one,
            # so a bound never beats a true matching cost.
            np.maximum(out, exact.max(), out=out)
            out[closest] = exact
        return out
