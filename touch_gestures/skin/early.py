"""Deciding before the finger lifts: the best candidate for a gesture still being traced.

A prefix of a gesture looks like the prefix of its templates, so :class:`PrefixMatcher` matches
what has been traced so far against the templates cut at a few fractions of their length
(``fractions``): a template's features are its points in order (along the ink for
:class:`~.clouds.CloudRecogniser`, in time for :class:`~.proposed.TraceRecogniser`), so its prefix
at fraction f is its first f of them, resampled to the full count and normalised as the features
are. The best fraction estimates how much of the gesture is done.

A :class:`Candidate` carries a confidence in [0, 1], the relative margin ``1 - d1 / d2`` of the best
class distance over the runner-up's: a score to react early on, not a probability; the command
still comes from the whole gesture.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .base import TemplateRecogniser
from .gesture import TouchGesture

__all__ = ['Candidate', 'PrefixMatcher', 'ordered_recogniser', 'prefix_recogniser', 'stable_fraction',
           'template_prefixes']

#: Recognisers whose features are (n, 2) points in order, with how each normalises its points.
_ORDERED = ('cloud', 'trace')


@dataclass(frozen=True, slots=True)
class Candidate:
    """The best class for a gesture under way.

    Attributes:
        label: the nearest class (None when the prefix is unusable).
        confidence: ``1 - d1 / d2`` in [0, 1] (module doc).
        distance: distance to the nearest template prefix (recogniser units).
        progress: the template fraction that matched best, an estimate of the part traced (0..1].
    """

    label: str | None
    confidence: float
    distance: float
    progress: float


def _normalise(points: np.ndarray, kind: str) -> np.ndarray:
    """(k, m, 2) -> (k, m, 2): the normalisation of the recogniser's own features."""
    if kind == 'cloud':
        centred = points - points.mean(axis=1, keepdims=True)
        size = np.ptp(centred, axis=1).max(axis=1)
    else:  # trace: centre of the box, uniform scale by the larger side (aspect_floor 1)
        lo, hi = points.min(axis=1, keepdims=True), points.max(axis=1, keepdims=True)
        centred = points - 0.5 * (lo + hi)
        size = (hi - lo)[:, 0].max(axis=1)
    size = np.where(size > 1e-9, size, 1.0)
    return centred / size[:, None, None]


class PrefixMatcher:
    """Candidates for gestures under way, against a fitted ``cloud`` or ``trace`` recogniser's codebook.

    Args:
        recogniser: the fitted recogniser of the final decision (its
            :meth:`~.base.TemplateRecogniser.deciding_recogniser` is matched).
        fractions: template prefixes to match, as fractions of the template (sorted, in (0, 1]).

    Raises:
        ValueError: a recogniser whose features are not ordered points, or bad fractions.
    """

    def __init__(self, recogniser: TemplateRecogniser, fractions: Sequence[float] = (0.25, 0.5, 0.75, 1.0)) -> None:
        recogniser = ordered_recogniser(recogniser)
        fractions = np.asarray(sorted(fractions), dtype=np.float64)
        if not len(fractions) or fractions[0] <= 0 or fractions[-1] > 1:
            raise ValueError(f'fractions must be in (0, 1]; got {fractions.tolist()}')
        self.recogniser = recogniser
        self.fractions = fractions
        # The whole templates are the recogniser's own codebook: only its distances are read.
        self._matchers = [prefix_recogniser(recogniser, f) if f < 1 else recogniser for f in fractions]

    def fraction_distances(self, gesture: TouchGesture) -> list[np.ndarray] | None:
        """Per fraction (in :attr:`fractions` order), the (n_classes,) float64 distance of ``gesture``
        (traced so far) to each class's nearest template prefix; None when the gesture is unusable."""
        # The matchers differ in codebook only: the gesture's features are computed once for all of them.
        query = self.recogniser.features(gesture)
        if query is None:
            return None
        return [m.query_class_distances(query) for m in self._matchers]

    def candidate(self, gesture: TouchGesture) -> Candidate:
        """The best class for ``gesture`` (traced so far) over the template prefixes."""
        per_fraction = self.fraction_distances(gesture)
        if per_fraction is None:
            return Candidate(None, 0.0, float('inf'), 0.0)
        best: tuple[float, int, np.ndarray] | None = None
        for k, per_class in enumerate(per_fraction):
            d1 = float(per_class.min())
            if best is None or d1 < best[0]:
                best = (d1, k, per_class)
        d1, k, per_class = best
        label = str(self.recogniser.classes_[int(np.argmin(per_class))])
        d2 = float(np.partition(per_class, 1)[1]) if len(per_class) > 1 else float('inf')
        confidence = 1.0 - d1 / d2 if d2 > 0 and np.isfinite(d2) else (1.0 if np.isinf(d2) else 0.0)
        return Candidate(label, float(np.clip(confidence, 0.0, 1.0)), d1, float(self.fractions[k]))


def ordered_recogniser(recogniser: TemplateRecogniser) -> TemplateRecogniser:
    """The fitted recogniser whose templates are points in order: its
    :meth:`~.base.TemplateRecogniser.deciding_recogniser` (the fused recogniser's cloud).

    Raises:
        ValueError: its features are no ordered points (a map, the centroid's sequence).
    """
    recogniser = recogniser.deciding_recogniser()
    if recogniser.name not in _ORDERED:
        raise ValueError(f'early decisions and the end of a gesture need the ordered points of '
                         f'{" or ".join(_ORDERED)}; {recogniser.name!r} has none')
    return recogniser


def template_prefixes(points: np.ndarray, fraction: float | np.ndarray, kind: str) -> np.ndarray:
    """(T, n, 2) -> (T, n, 2) float32: each template's first ``fraction`` of points (one number, or (T,)
    one per template), resampled to n, normalised as recogniser ``kind``'s features are."""
    n = points.shape[1]
    f = np.broadcast_to(np.asarray(fraction, dtype=np.float64), (len(points),))
    source = np.linspace(0.0, 1.0, n)[None, :] * (f[:, None] * (n - 1))   # (T, n) positions along the points
    lo = np.floor(source).astype(np.intp)
    hi = np.minimum(lo + 1, n - 1)
    w = (source - lo)[..., None]
    rows = np.arange(len(points))[:, None]
    return _normalise(points[rows, lo] * (1 - w) + points[rows, hi] * w, kind).astype(np.float32)


def prefix_recogniser(recogniser: TemplateRecogniser, fraction: float | np.ndarray,
                      keep: np.ndarray | None = None) -> TemplateRecogniser:
    """A copy of an :func:`ordered_recogniser` whose codebook is its templates' prefixes.

    Args:
        fraction: the part of each template kept, one number or (T,) one per template.
        keep: (T,) bool, the templates to keep (default all).

    Only its distances are meant to be read (``class_distances``, ``query_class_distances``): its
    rejection thresholds are not calibrated (inf), which saves a leave-one-out pass per copy.
    """
    n = recogniser.templates_.shape[1] // 2
    points = recogniser.templates_.reshape(-1, n, 2).astype(np.float64)
    labels = recogniser.classes_[recogniser.template_labels_]
    fraction = np.broadcast_to(np.asarray(fraction, dtype=np.float64), (len(points),))
    if keep is not None:
        points, labels, fraction = points[keep], labels[keep], fraction[keep]
    cut = template_prefixes(points, fraction, recogniser.name)
    prefixes = copy.deepcopy(recogniser)
    prefixes.set_codebook(cut.reshape(len(cut), -1), labels,
                          class_thresholds=np.full(len(np.unique(labels)), np.inf))
    return prefixes


def stable_fraction(labels: Sequence[str | None], truth: str) -> float | None:
    """Given the candidates after each of n equal steps of a gesture (the last is the whole
    gesture), the fraction at which the candidate became right and stayed so; None if it never
    did (the last one is wrong).

    >>> stable_fraction(['a', 'b', 'b', 'b'], 'b'), stable_fraction(['b', 'a', 'b', 'b'], 'b')
    (0.5, 0.75)
    >>> stable_fraction(['b', 'a'], 'b') is None
    True
    """
    n = len(labels)
    if n == 0 or labels[-1] != truth:
        return None
    k = n - 1
    while k > 0 and labels[k - 1] == truth:
        k -= 1
    return (k + 1) / n
