"""A point cloud with a referee for its near ties: :class:`RefereedRecogniser`.

A few pairs of multi-stroke symbols are nearly the same cloud (:mod:`touch_gestures.skin.clouds`): an N and
an H, an asterisk and an X. Their stroke orders and directions tell them apart, which $N matches
(:mod:`.ndollar`). When the cloud's two nearest classes are within its ambiguity margin (``min_margin``
times the nearest distance), $N's distances to those two classes only
(:meth:`~.ndollar.NDollarRecogniser.class_distances_among`) choose between them. The referee names the
class; the tie stays a tie for the rejection rule, so what fires is what the cloud alone fires.
Features are the cloud's and the referee's side by side; distances, thresholds, the end of a gesture
and early candidates are the cloud's (:attr:`RefereedRecogniser.cloud_`).
"""

from __future__ import annotations

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser, nearest_allowed
from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.gesture import TouchGesture

from .ndollar import NDollarRecogniser

__all__ = ['RefereedRecogniser']

class RefereedRecogniser(TemplateRecogniser):
    """The cloud, with $N choosing between its two nearest classes when they tie (module doc).

    Args:
        n_points: points of the cloud (:class:`~touch_gestures.skin.clouds.CloudRecogniser`).
        referee_points: points of the referee's unistrokes (:class:`~.ndollar.NDollarRecogniser`).
        max_distance, auto_scale, auto_quantile, min_margin: rejection, see :mod:`touch_gestures.skin.base`;
            ``min_margin`` is also the tie the referee decides.

    Attributes:
        cloud_: the fitted cloud (its codebook: the templates' first ``2 n_points`` values), whose distances decide.
        ndollar_: the fitted $N, the referee (the templates' other values).
        referee_calls_: how many recognitions asked the referee (each such call matches the query against the
            two tied classes' unistrokes only).
    """

    name = 'refereed'
    direction_aware = False

    def __init__(self, n_points: int = 32, referee_points: int = 96, max_distance: float | str | None = 'auto',
                 auto_scale: float = 2.0, auto_quantile: float = 0.9, min_margin: float = 0.1) -> None:
        self.n_points = n_points
        self.referee_points = referee_points
        self.max_distance = max_distance
        self.auto_scale = auto_scale
        self.auto_quantile = auto_quantile
        self.min_margin = min_margin

    def _check_params(self) -> None:
        super()._check_params()
        for part in self.parts():
            part._check_params()

    def parts(self) -> tuple[CloudRecogniser, NDollarRecogniser]:
        """New, unfitted cloud and referee (no limits of their own: only their distances are read)."""
        return (CloudRecogniser(n_points=self.n_points, max_distance=None),
                NDollarRecogniser(n_points=self.referee_points, max_distance=None))

    @property
    def cloud_width(self) -> int:
        """How many of a template's first values are the cloud's."""
        return 2 * self.n_points

    def features(self, gesture: TouchGesture) -> np.ndarray | None:
        # Parts of the current parameters, not the fitted ones: a fit after set_params makes templates of the
        # new sizes (the features need no codebook; predict reads the cloud's through _query_features).
        cloud, ndollar = self.parts()
        points, unistrokes = cloud.features(gesture), ndollar.features(gesture)
        if points is None or unistrokes is None:
            return None
        return np.concatenate([points, unistrokes]).astype(np.float32, copy=False)

    def _prepare_codebook(self) -> None:
        cloud, ndollar = self.parts()
        split = self.cloud_width
        if self.templates_.shape[1] <= split:
            raise ValueError(f'a refereed codebook holds the cloud ({split} values) and the referee side by side; '
                             f'got templates of {self.templates_.shape[1]}')
        labels = self.classes_[self.template_labels_]
        unlimited = np.full(len(self.classes_), np.inf)   # thresholds are this recogniser's, not the parts'
        for part, templates in ((cloud, self.templates_[:, :split]), (ndollar, self.templates_[:, split:])):
            part.set_codebook(templates, labels, class_thresholds=unlimited, template_strokes=self.template_strokes_,
                              template_contact_s=self.template_contact_s_)
        self.cloud_, self.ndollar_ = cloud, ndollar
        self.referee_calls_ = 0

    def deciding_recogniser(self) -> TemplateRecogniser:
        return self.cloud_

    def _query_features(self, gesture: TouchGesture) -> np.ndarray | None:
        return self.cloud_.features(gesture)   # the referee's only on a tie (they cost more than the cloud's)

    def one_stroke_path_of(self, gesture: TouchGesture, query: np.ndarray) -> np.ndarray | None:
        return self.cloud_.one_stroke_path_of(gesture, query[:self.cloud_width])   # the cloud's features come first

    def distances(self, query: np.ndarray) -> np.ndarray:
        return self.cloud_.distances(query[:self.cloud_width])   # a template's or a query's: the cloud comes first

    def _nearest(self, gesture: TouchGesture, per_class: np.ndarray, allowed: np.ndarray | None) -> int:
        best = nearest_allowed(per_class, allowed)
        rivals = per_class.copy() if allowed is None else np.where(allowed, per_class, np.inf)
        rivals[best] = np.inf
        second = int(np.argmin(rivals))
        d1 = float(per_class[best])
        if not rivals[second] - d1 < self.min_margin * d1:   # no tie (or no rival: inf)
            return best
        self.referee_calls_ += 1
        judged = self.ndollar_.class_distances_among(gesture, (best, second))   # only the two tied classes
        if judged is None:
            return best
        return second if judged[1] < judged[0] else best
