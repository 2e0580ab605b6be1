"""Cheap evidence a shape match throws away: strokes and duration, checked against the codebook.

A scribble that happens to look like a symbol is as close to it as the symbol; what the shape
normalisation discards still tells them apart, and :class:`CodebookEvidence`, calibrated on the
codebook alone, says what each class allows:

- **strokes**: a stroke count the class shows in fewer than ``min_share`` of its templates (in a
  class of fewer than 1 / ``min_share`` templates: in none) is taken for an accident of the
  recording and not allowed; with ``stroke_tolerance`` k (default 1), :meth:`~CodebookEvidence.check` passes
  a count within k strokes of an allowed one (a stroke the skin broke or joined), while
  :meth:`~CodebookEvidence.allowed`, which picks the class, keeps to the counts shown;
- **duration**: the time in contact (:attr:`~.gesture.TouchGesture.contact_s`, the pauses between
  strokes left out) must lie between the ``low`` and ``high`` quantiles of the class's contact
  times, widened by ``slack`` (1.5: half again faster than the fastest, slower than the slowest);
  checked only for classes with at least ``min_templates`` templates.

A codebook that does not know its templates' strokes or contact times skips that check.
"""

from __future__ import annotations

import numpy as np

from .gesture import TouchGesture

__all__ = ['EVIDENCE_REASONS', 'CodebookEvidence']

#: The rejection reasons :meth:`CodebookEvidence.check` gives.
EVIDENCE_REASONS = ('strokes', 'duration')


class CodebookEvidence:
    """Per class, the stroke counts and contact times its templates show (module doc).

    Args:
        template_labels: (T,) class index of each template.
        n_classes: number of classes.
        strokes: (T,) strokes of each template, or None.
        contact_s: (T,) time in contact of each template, s, or None.
        low, high: quantiles of a class's contact times that bound it...
        slack: ...widened by this factor (>= 1)...
        min_templates: ...for classes with at least this many templates (the others: no bound).
        min_share: a stroke count is allowed when at least this fraction of the class's templates
            show it (and always when one does in a class of fewer than ``1 / min_share``).
        stroke_tolerance: strokes (>= 0) a touch's count may differ from an allowed one and still pass
            :meth:`check`.
    """

    def __init__(self, template_labels: np.ndarray, n_classes: int, strokes: np.ndarray | None = None,
                 contact_s: np.ndarray | None = None, low: float = 0.01, high: float = 0.99,
                 slack: float = 1.5, min_templates: int = 30, min_share: float = 0.01,
                 stroke_tolerance: int = 1) -> None:
        if not (0 <= low <= high <= 1 and np.isfinite(slack) and slack >= 1 and 0 <= min_share < 1):
            raise ValueError(f'need 0 <= low <= high <= 1, slack >= 1 and 0 <= min_share < 1; got {low}, {high}, '
                             f'{slack}, {min_share}')
        if isinstance(stroke_tolerance, bool) or not isinstance(stroke_tolerance, int | np.integer) \
                or stroke_tolerance < 0:
            raise ValueError(f'stroke_tolerance must be a whole number of strokes >= 0, got {stroke_tolerance!r}')
        labels = np.asarray(template_labels)
        self.stroke_counts: list[frozenset[int]] | None = None
        if strokes is not None:
            strokes = np.asarray(strokes)
            self.stroke_counts = []
            for c in range(n_classes):
                counts, seen = np.unique(strokes[labels == c], return_counts=True)
                enough = seen >= max(1.0, min_share * seen.sum())
                self.stroke_counts.append(frozenset(counts[enough].tolist()))
        # What check() passes: the counts shown, each widened by the tolerance (never below one stroke).
        self.plausible_strokes: list[frozenset[int]] | None = None if self.stroke_counts is None else [
            frozenset(k + d for k in shown for d in range(-stroke_tolerance, stroke_tolerance + 1) if k + d >= 1)
            for shown in self.stroke_counts]
        self.contact_bounds_s: np.ndarray | None = None
        if contact_s is not None:
            contact_s = np.asarray(contact_s, dtype=np.float64)
            bounds = np.full((n_classes, 2), [0.0, np.inf])
            for c in range(n_classes):
                own = contact_s[(labels == c) & np.isfinite(contact_s)]
                if own.size >= max(1, min_templates):
                    lo, hi = np.quantile(own, [low, high])
                    bounds[c] = lo / slack, hi * slack
            self.contact_bounds_s = bounds
        # What allowed() hands out per touch: a mask per stroke count seen (any other count fits no class).
        # The masks are handed out as they are: read-only, so that no caller changes them for the next.
        self._no_class = np.zeros(n_classes, dtype=bool)
        self._stroke_masks = None if self.stroke_counts is None else {
            k: np.array([k in counts for counts in self.stroke_counts]) for k in set().union(*self.stroke_counts)}
        for mask in [self._no_class, *(self._stroke_masks or {}).values()]:
            mask.flags.writeable = False

    def allowed(self, gesture: TouchGesture) -> np.ndarray | None:
        """(n_classes,) bool, read-only: the classes written with ``gesture``'s number of strokes (None: the
        codebook does not know its templates' strokes, every class fits).

        The time in contact is left out: people trace at their own pace (a slow performer is out of every
        class's range), so it rejects a command (:meth:`check`) but does not pick the class; the stroke
        count of a symbol is how it is written."""
        if self._stroke_masks is None:
            return None
        return self._stroke_masks.get(int(gesture.strokes), self._no_class)

    def check(self, gesture: TouchGesture, label: int) -> str | None:
        """Why ``gesture`` cannot be class ``label`` (one of :data:`EVIDENCE_REASONS`), or None."""
        if self.plausible_strokes is not None and int(gesture.strokes) not in self.plausible_strokes[label]:
            return 'strokes'
        if self.contact_bounds_s is not None:
            lo, hi = self.contact_bounds_s[label].tolist()   # Python floats: cheaper to compare
            if not lo <= gesture.contact_s <= hi:
                return 'duration'
        return None
