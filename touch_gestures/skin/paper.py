"""The three recognisers of cirillo2017 section 3, each against an n x m codebook.

- :class:`StaticRecogniser` (3.1, eq. 2): thresholded map, bounding box moved to the
  upper-left corner, dot-product score. For static touches (a hand pressing a line).
- :class:`MapRecogniser` (3.2.1, Algorithm 1): OR-accumulated binary map, bounding box
  cropped and rescaled to 12x12 by nearest neighbour, Hamming distance. Blind to direction.
- :class:`CentroidRecogniser` (3.2.2, Algorithm 2): contact-point trajectory resampled by
  nearest neighbour, min-max normalised per axis (eq. 6), distance of eq. (7). Direction-aware.

Matching is vectorised over the whole codebook. Rejection is the shared rule of
:mod:`touch_gestures.skin.base`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .base import TemplateRecogniser
from .features import minmax_normalise, nna_resample, nna_rescale, shift_to_corner
from .gesture import GRID, TouchGesture

__all__ = ['CentroidRecogniser', 'MapRecogniser', 'StaticRecogniser']


@dataclass(eq=False)
class StaticRecogniser(TemplateRecogniser):
    """Dot-product matching of thresholded static maps (cirillo2017 3.1, eq. 2).

    The score of template x_i against the acquired map y is s_i = sum_j x_ij y_j (eq. 2),
    highest wins. It is reported as the distance ``1 - s_i / |y|``, the fraction of the
    touched taxels the template does not cover (0 = fully covered), which ranks templates
    exactly as eq. 2 does for a given touch.

    Args:
        threshold: pressure (1 = full scale) above which a taxel is "1" in the bit map,
            applied to the gesture's peak map; None uses the segmenter's binary map.
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'static'
    direction_aware = False

    threshold: float | None = None

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        bitmap = gesture.binary_map if self.threshold is None else gesture.peak_map >= self.threshold
        if not bitmap.any():
            return None
        # Columns stacked (the paper's 144x1 vector of the 12 columns); any fixed order gives the same sums.
        return shift_to_corner(bitmap).T.reshape(-1).astype(np.float32)

    def distances(self, query: np.ndarray) -> np.ndarray:
        score = self.templates_ @ query  # eq. (2) for every template at once
        return 1.0 - score / max(float(query.sum()), 1.0)


@dataclass(eq=False)
class MapRecogniser(TemplateRecogniser):
    """Hamming distance between rescaled binary maps (cirillo2017 3.2.1, Algorithm 1).

    The distance is the number of taxels (of ``size`` x ``size``) at which the rescaled maps differ.

    Args:
        size: side of the rescaled map (the paper rescales to 12x12).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'map'
    direction_aware = False

    size: int = GRID

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        scaled = nna_rescale(gesture.binary_map, self.size)
        return None if scaled is None else scaled.reshape(-1).astype(np.float32)

    def _prepare_codebook(self) -> None:
        self._ones = self.templates_.sum(axis=1)

    def distances(self, query: np.ndarray) -> np.ndarray:
        # For 0/1 vectors, Hamming = |t| + |q| - 2 t.q: one matrix-vector product for the codebook.
        return self._ones + query.sum() - 2.0 * (self.templates_ @ query)


@dataclass(eq=False)
class CentroidRecogniser(TemplateRecogniser):
    """Resampled, min-max normalised contact-point trajectories (cirillo2017 3.2.2, Algorithm 2).

    Features are the l nearest-neighbour samples of g_x and g_y, each normalised into
    [0, 1] by eq. (6) (an axis with max == min, a trace along one row or a single point,
    maps to 0.5). The distance is eq. (7): the mean of the Euclidean distances of the x
    and of the y vectors.

    Args:
        length: l, samples after resampling. The paper does not give it; 32 (see the
            speed-against-error table in docs/skin-evaluation.md).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`.base`.
    """

    name = 'centroid'
    direction_aware = True

    length: int = 32

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        if len(gesture.trajectory) == 0:
            return None
        g = minmax_normalise(nna_resample(gesture.trajectory, self.length))
        return g.T.reshape(-1)  # [g_x(1..l), g_y(1..l)]

    def _prepare_codebook(self) -> None:
        # Eq. (7) per axis as |t|^2 - 2 t.q + |q|^2: two matrix-vector products for the codebook.
        half = self.length
        self._tx = np.ascontiguousarray(self.templates_[:, :half])
        self._ty = np.ascontiguousarray(self.templates_[:, half:])
        self._tx2 = np.einsum('ij,ij->i', self._tx, self._tx)
        self._ty2 = np.einsum('ij,ij->i', self._ty, self._ty)

    def distances(self, query: np.ndarray) -> np.ndarray:
        qx, qy = query[: self.length], query[self.length:]
        ex2 = self._tx2 - 2.0 * (self._tx @ qx) + float(qx @ qx)
        ey2 = self._ty2 - 2.0 * (self._ty @ qy) + float(qy @ qy)
        return 0.5 * (np.sqrt(np.maximum(ex2, 0.0)) + np.sqrt(np.maximum(ey2, 0.0)))  # eq. (7)
