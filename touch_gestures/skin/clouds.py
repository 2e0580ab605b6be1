"""Point clouds for multi-stroke gestures: :class:`CloudRecogniser`.

As an unordered cloud of points a symbol looks the same whatever the order and direction of its
strokes ($P, Vatavu, Anthony and Wobbrock, ICMI 2012). The steps:

1. **Resampling along the ink** (``n_points``): the strokes are resampled to ``n_points`` equally
   spaced along the ink only, centred on their mean and divided by the larger side of their box.
2. **A $Q-style lookup table** (Vatavu, Anthony and Wobbrock, MobileHCI 2018): each template's
   distance field is sampled on a ``grid`` x ``grid`` raster at fit time; the query's points read
   their distance to every template in one gather, and the template points read the query's field.
   Their mean (symmetric Chamfer distance, to within ``2 / grid``) ranks the codebook.
3. **One-to-one matching on the closest** (``exact``): the ``exact`` templates with the smallest
   Chamfer distance are matched point to point by optimal assignment
   (:func:`.assignment.min_cost_assignment`); the mean point distance is the distance. The other
   templates keep their Chamfer bound, raised to the farthest of the closest, so the margin is
   never overstated. An assignment is solved only where its exact Chamfer bound is below both its
   class's matched cost and the runner-up class's; where each query point's nearest template point
   differs, that pairing is already optimal; a zero cost settles no class, so the nearest other
   template is matched too. The nearest class gets the distance that solving all ``exact``
   assignments gives (test/test_skin_cloud_search.py).

Distances are in units of the gesture's size. The cloud is blind to direction; where a vocabulary
tells directions apart, the trace (:mod:`.proposed`) or the fused recogniser (:mod:`.fused`) reads it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .assignment import min_cost_assignment
from .base import TemplateRecogniser
from .features import cloud_features
from .gesture import TouchGesture
from .order_evidence import PATH_POINTS

__all__ = ['CloudRecogniser', 'cloud_features']

#: Normalised clouds lie within +-1 of their mean; the raster covers that square.
_EXTENT = 1.0
#: Rasters up to this many cells keep a cell-to-cell distance table (4 MiB); larger ones compute it per query.
_TABLE_CELLS = 1024


@dataclass(eq=False)
class CloudRecogniser(TemplateRecogniser):
    """Order- and direction-free matching of point clouds (module doc).

    Args:
        n_points: points per cloud ($P's 32).
        grid: side of the distance-field raster (cells of ``2 / grid`` gesture sizes).
        exact: the closest templates (raster Chamfer) considered for one-to-one matching; of those, only
            the ones that can change the nearest class or the runner-up are solved (0: Chamfer only).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'cloud'
    direction_aware = False

    n_points: int = 32
    grid: int = 24
    exact: int = 6

    def _check_params(self) -> None:
        super()._check_params()
        if self.n_points < 2 or self.grid < 2 or self.exact < 0:
            raise ValueError(f'need n_points >= 2, grid >= 2 and exact >= 0; got {self.n_points}, {self.grid}, '
                             f'{self.exact}')

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0:
            return None
        cloud = cloud_features(gesture.trajectory, gesture.stroke, self.n_points)
        # A NaN or infinite point makes no cloud (the search needs finite points):
        # one dot product, as the sum of squares of 2 n numbers within +-1 is finite exactly when they are.
        return cloud if math.isfinite(float(cloud @ cloud)) else None

    def one_stroke_path_of(self, gesture: TouchGesture, query: np.ndarray) -> np.ndarray | None:
        # A touch whose points are all of one stroke (ids all 0, as the segmenter numbers them) is resampled
        # the same with and without its stroke ids: the cloud is the order check's path, as float64.
        if self.n_points != PATH_POINTS or getattr(gesture, 'strokes', 1) != 1 or gesture.stroke.any():
            return None
        return query.reshape(self.n_points, 2).astype(np.float64)

    def _cells(self, clouds: np.ndarray) -> np.ndarray:
        """(..., n, 2) normalised points -> (..., n) flat raster cell index (clipped to the raster)."""
        # Truncation is the floor for the points inside the raster; those left of it clip to 0 either way.
        ij = ((clouds + _EXTENT) * (self.grid / (2 * _EXTENT))).astype(np.intp)
        np.minimum(np.maximum(ij, 0, out=ij), self.grid - 1, out=ij)   # np.clip's checks cost more here
        return np.dot(ij, self._cell_steps)                            # row * grid + column, one call

    def _prepare_codebook(self) -> None:
        n, g = self.n_points, self.grid
        self._cell_steps = np.array([1, g], dtype=np.intp)
        self._clouds = self.templates_.reshape(len(self.templates_), n, 2).astype(np.float64)
        self._cell_mm = 2 * _EXTENT / g   # the raster's cell side, gesture sizes
        centres = (np.arange(g) + 0.5) * self._cell_mm - _EXTENT
        cx, cy = np.meshgrid(centres, centres)            # (g, g), row = y
        self._raster = np.column_stack([cx.ravel(), cy.ravel()])  # (g*g, 2) cell centres
        # (g*g, T): distance from each raster cell to each template's nearest point (its distance
        # field), cells first so that a query's n cells gather n contiguous rows.
        fields = np.empty((g * g, len(self._clouds)), dtype=np.float32)
        for k, cloud in enumerate(self._clouds):
            fields[:, k] = np.sqrt(_squared_distances(self._raster, cloud).min(axis=1))
        self._fields = fields
        self._template_cells = self._cells(self._clouds)    # (T, n)
        # Cell-to-cell distances (g*g, g*g): a query's distance field is the minimum of its cells'
        # rows. Kept for rasters up to _TABLE_CELLS cells (1024: 4 MiB); larger ones compute the rows per query.
        self._cell_table = (np.sqrt(_squared_distances(self._raster, self._raster)).astype(np.float32)
                            if g * g <= _TABLE_CELLS else None)
        # (T, g*g): how many points of each template fall in each cell; the template-to-query sums are
        # one matrix-vector product with the query's field (cheaper than gathering T x n cells).
        T = len(self._clouds)
        counts = np.zeros((T, g * g), dtype=np.float32)
        np.add.at(counts, (np.repeat(np.arange(T), n), self._template_cells.ravel()), 1.0)
        self._cell_counts = counts
        self._visit_labels = self.template_labels_.tolist()
        # flat start of each (point, template) row of the (n, k, n) point distances to the k closest
        self._row_starts = np.arange(0, n * n * min(self.exact, T), n).reshape(n, min(self.exact, T))

    def _query_field(self, cells: np.ndarray) -> np.ndarray:
        """(g*g,) float32 distance from each raster cell's centre to the nearest cell centre occupied
        by the query's (n,) ``cells``, in gesture sizes (the Euclidean distance transform of the
        query's raster, as one row minimum of a table)."""
        if self._cell_table is not None:
            return self._cell_table[cells].min(axis=0)
        return np.sqrt(_squared_distances(self._raster[cells], self._raster).min(axis=0)).astype(np.float32)

    def _bounds(self, q: np.ndarray) -> np.ndarray:
        """(T,) float64 symmetric Chamfer distance of the (n, 2) float64 query to every template (module doc, 2)."""
        cells = self._cells(q)
        # Query -> templates: each query point reads every template's field at its cell; templates ->
        # query: every template point reads the query's field at its cell. Sums of n float32 values
        # below 3 (the raster's diagonal): float32 adds ~1e-7 relative, far under the half-cell.
        to_templates = self._fields[cells].sum(axis=0)
        to_templates += self._cell_counts @ self._query_field(cells)
        return np.multiply(to_templates, 0.5 / self.n_points, dtype=np.float64)   # as float64, then scaled

    def distances(self, query: np.ndarray) -> np.ndarray:
        n = self.n_points
        q = query.reshape(n, 2).astype(np.float64)
        out = self._bounds(q)
        k = min(self.exact, len(out))
        if not k:
            return out
        closest = np.argpartition(out, k - 1)[:k] if k < len(out) else np.arange(len(out))
        # (n, k, n) point distances to the closest templates, in one call; float64, as the assignment's.
        pair = np.sqrt(_squared_distances(q, self._clouds[closest].reshape(-1, 2))).reshape(n, k, n)
        nearest = pair.argmin(axis=2)                        # (n, k) each query point's nearest template point
        # Their distances gathered by flat index: numpy's min along a short last axis is slower.
        rows = pair.reshape(-1)[self._row_starts + nearest]
        to_template = rows.sum(axis=0) / n                   # (k,) directed Chamfer means, both ways
        chamfer = np.maximum(to_template, pair.min(axis=0).sum(axis=1) / n)   # true lower bounds
        # The visit is over k (6) values: Python lists, not numpy calls.
        costs = chamfer.tolist()
        bounds, means, templates = list(costs), to_template.tolist(), closest.tolist()
        labels = self._visit_labels
        settled = [np.inf] * len(self.classes_)   # per class: smallest non-zero matching cost so far
        first = second = np.inf                   # the two smallest of ``settled``
        for i in sorted(range(k), key=bounds.__getitem__):
            bound = bounds[i]
            if bound >= second:
                break      # neither the nearest class nor the runner-up can change
            c = labels[templates[i]]
            if bound >= settled[c]:
                continue   # its cost is at least its bound: it cannot lower its class's distance
            cost = self._match(pair[:, i], nearest[:, i], means[i])
            costs[i] = cost
            if 0.0 < cost < settled[c]:
                was, settled[c] = settled[c], cost
                if was == first:      # the nearest class got nearer
                    first = cost
                elif cost < first:    # a new nearest class; the old one is the runner-up
                    first, second = cost, first
                elif cost < second:
                    second = cost
        # The others were ranked farther: none is taken as closer than the farthest of the closest, so
        # a raster bound never beats a matching cost or a true bound.
        np.maximum(out, max(costs), out=out)
        out[closest] = costs
        return out

    @staticmethod
    def _match(cost: np.ndarray, nearest: np.ndarray, nearest_mean: float) -> float:
        """Mean point distance of the optimal one-to-one matching, given the (n, n) ``cost`` matrix
        and each row's argmin ``nearest`` (n,) with its mean: when the nearest points already pair
        one to one, that pairing is optimal and the assignment need not be solved."""
        if len(set(nearest.tolist())) == len(nearest):
            return nearest_mean
        cols = min_cost_assignment(cost)
        return float(cost[np.arange(len(cols)), cols].sum() / len(cols))


def _squared_distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(p, 2) and (r, 2) points -> (p, r) squared distances."""
    dx = a[:, 0, None] - b[None, :, 0]
    dy = a[:, 1, None] - b[None, :, 1]
    return dx * dx + dy * dy
