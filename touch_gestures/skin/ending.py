"""When a gesture is over: the vocabulary tells whether the strokes so far are a whole gesture.

After a lift, the strokes traced so far look either like a whole gesture of the vocabulary (a line,
a finished X) or like the beginning of one with more strokes (the first bar of an X).
:class:`GestureEnd` asks the codebook:

- **whole or prefix** (``margin``, ``prefixes``): the k strokes so far are matched against the whole
  templates and against the prefixes of templates with more strokes (``'strokes'``: a template of n
  strokes cut at k/n of its ink; ``'fractions'``, where the codebook does not know its templates'
  strokes: cut at a quarter, half and three quarters, :class:`~.early.PrefixMatcher`). The strokes
  are complete when a whole template is nearer than every prefix by ``margin`` relative to the
  prefix's distance (default :data:`ENDING_MARGIN`: strokes that make a whole gesture but are nearly as
  near the beginning of a longer one, the X of an asterisk, wait for it up to the bound);
- **stroke counts** (``strokes``, where the codebook knows ``template_strokes_``): and the nearest
  whole class has templates of no more strokes than traced so far.

The answer is a :class:`~.segmentation.Verdict`: ``WHOLE`` (the lift ends the gesture), ``PREFIX``
(wait for a next stroke up to the segmenter's bound) or, with ``unfinished``, ``UNFINISHED``: the
nearest class was never written with so few strokes, so ending them would fire nothing
(:mod:`.evidence`); those wait up to the segmenter's ``max_duration_s``, so a touch within that time
joins them. :class:`~.segmentation.GestureSegmenter` asks once per lift, never per frame.
"""

from __future__ import annotations

import numpy as np

from .base import TemplateRecogniser
from .early import PrefixMatcher, ordered_recogniser, prefix_recogniser
from .gesture import TouchGesture
from .segmentation import ENDING_GAP_S, ENDING_WAIT_S, MULTISTROKE_GAP_S, SINGLE_STROKE_GAP_S, Verdict

__all__ = ['ENDING_MARGIN', 'PREFIXES', 'GestureEnd', 'vocabulary_ending']

#: The prefixes the whole templates are compared with (module doc).
PREFIXES = ('strokes', 'fractions')
#: How much nearer (relative) the whole gesture must be than a longer one's beginning to end at the short gap
#: (its cost in latency and the samples it keeps whole: docs/skin-multistroke.md).
ENDING_MARGIN = 0.25


class GestureEnd:
    """``verdict(gesture)`` (also the call): are the strokes so far a whole gesture of the codebook
    (module doc)? ``complete(gesture)``: the verdict is ``WHOLE``.

    Args:
        recogniser: a fitted recogniser whose deciding recogniser is a ``cloud`` or ``trace``
            (:func:`~.early.ordered_recogniser`).
        margin: how much nearer (relative) a whole template must be than the best prefix.
        strokes: also require the nearest class to have templates of at most the strokes traced.
        unfinished: strokes fewer than every template of the nearest class has are ``UNFINISHED``
            (wait as long as a gesture may last) rather than a ``PREFIX`` (needs ``strokes``).
        prefixes: ``'strokes'`` (cut between strokes; ``'fractions'`` where the codebook does not know its
            templates' strokes) or ``'fractions'`` (module doc); :attr:`prefixes` is the one used.

    Raises:
        ValueError: a recogniser without ordered points (:func:`~.early.ordered_recogniser`), bad options.
    """

    def __init__(self, recogniser: TemplateRecogniser, margin: float = ENDING_MARGIN, strokes: bool = True,
                 unfinished: bool = True, prefixes: str = 'strokes') -> None:
        if not (np.isfinite(margin) and margin >= 0):
            raise ValueError(f'margin must be a finite fraction >= 0, got {margin}')
        if prefixes not in PREFIXES:
            raise ValueError(f'prefixes must be one of {PREFIXES}, got {prefixes!r}')
        self.recogniser = chosen = ordered_recogniser(recogniser)
        self.margin = float(margin)
        self.unfinished = bool(unfinished)
        known = getattr(chosen, 'template_strokes_', None)
        counts = None if known is None else np.asarray(known)
        # Fewest strokes of each class's templates (n_classes,); None when the codebook does not know them.
        self.class_min_strokes: np.ndarray | None = None
        if counts is not None and strokes:
            self.class_min_strokes = np.minimum.reduceat(counts, chosen.class_starts_)
        self.prefixes = 'fractions' if counts is None else prefixes
        # Only the prefixes of the comparison in use are built: cut at fractions, or between strokes,
        # where k -> the recogniser's codebook cut to the first k strokes of the templates with more.
        self.matcher = PrefixMatcher(chosen) if self.prefixes == 'fractions' else None
        self._stroke_prefixes: dict[int, TemplateRecogniser] = {}
        if counts is not None and self.prefixes == 'strokes':
            for k in range(1, int(counts.max())):
                self._stroke_prefixes[k] = prefix_recogniser(chosen, k / counts, keep=counts > k)

    def verdict(self, gesture: TouchGesture) -> Verdict:
        """What ``gesture`` (the strokes so far) is (module doc); an unusable one is whole (nothing to wait for)."""
        if self.prefixes == 'strokes':
            query = self.recogniser.features(gesture)
            if query is None:
                return Verdict.WHOLE
            whole = self.recogniser.query_class_distances(query)
            longer = self._stroke_prefixes.get(int(gesture.strokes))
            prefix = np.inf if longer is None else float(longer.query_class_distances(query).min())
        else:
            per_fraction = self.matcher.fraction_distances(gesture)   # type: ignore[union-attr]
            if per_fraction is None:
                return Verdict.WHOLE
            whole = per_fraction[-1]             # the matcher's fractions end at 1: the whole templates
            prefix = min((float(d.min()) for d in per_fraction[:-1]), default=np.inf)
        best = int(np.argmin(whole))
        if self.class_min_strokes is not None and self.class_min_strokes[best] > int(gesture.strokes):
            return Verdict.UNFINISHED if self.unfinished else Verdict.PREFIX
        return Verdict.WHOLE if float(whole[best]) * (1.0 + self.margin) <= prefix else Verdict.PREFIX

    def complete(self, gesture: TouchGesture) -> bool:
        """True when ``gesture`` (the strokes so far) is a whole gesture (:meth:`verdict` is ``WHOLE``)."""
        return self.verdict(gesture) is Verdict.WHOLE

    __call__ = verdict


def vocabulary_ending(recogniser: TemplateRecogniser, max_strokes: int | None = None
                      ) -> tuple[float, float | None, GestureEnd | None]:
    """The segmenter's ``gap_s``, ``wait_s`` and ``is_complete`` for a fitted recogniser's vocabulary.

    A multi-stroke vocabulary (``max_strokes``, default the recogniser's ``max_strokes_``, above 1)
    read by a recogniser with ordered points gets the rule: :data:`~.segmentation.ENDING_GAP_S`
    and :data:`~.segmentation.ENDING_WAIT_S`. One without ordered points (the paper's maps) cannot
    tell a prefix from a whole gesture: the fixed :data:`~.segmentation.MULTISTROKE_GAP_S`. A
    single-stroke vocabulary has nothing to wait for: :data:`~.segmentation.SINGLE_STROKE_GAP_S`.
    """
    if max_strokes is None:
        max_strokes = int(getattr(recogniser, 'max_strokes_', 1))
    if max_strokes <= 1:
        return SINGLE_STROKE_GAP_S, None, None
    try:
        rule = GestureEnd(recogniser)
    except ValueError:
        return MULTISTROKE_GAP_S, None, None
    return ENDING_GAP_S, ENDING_WAIT_S, rule
