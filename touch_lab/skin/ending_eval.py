"""The end of a gesture, measured: samples rendered once into pieces, joined per rule and codebook.

Whether a lift ends a gesture depends on the fold's codebook
(:class:`~touch_gestures.skin.ending.GestureEnd`), and rendering is the slow part: each sample is rendered
once with a short gap (:data:`PIECE_GAP_S`) into *pieces*, and :func:`join_pieces` does at each lift what
:class:`~touch_gestures.skin.segmentation.GestureSegmenter` does. Joining is exact for what recognisers
read; ``multi_contact`` and the ``max_duration_s`` limit are approximate (a piece starting past the limit
ends the gesture as truncated and is dropped).

Each gesture comes with its **latency**: the lift after its last contact at which it ended.
:func:`ending_table` gives whole samples, accuracy and latency per (gap, bound, rule);
:func:`ending_causes` tells per class why samples were not one gesture (``social-touch eval skin-ending``).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Iterator, Mapping, Sequence

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.ending import GestureEnd
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.segmentation import Verdict, verdict_of
from touch_sim.skin.render import RenderedSample

__all__ = ['CAUSES', 'DEFAULT_RULE', 'ENDING_CONFIGS', 'FRAME_PERIOD_S', 'PIECE_GAP_S', 'RULES', 'Cut', 'cut_pieces',
           'ending_causes', 'ending_table', 'join_pieces', 'merge_pieces']

#: The gap (s) samples are rendered at before joining: no shorter gap can be measured from them.
PIECE_GAP_S = 0.15
#: The skin's frame period (150 Hz): a lift is seen on the frames between two contacts.
FRAME_PERIOD_S = 1.0 / 150.0


def merge_pieces(pieces: Sequence[TouchGesture], max_duration_s: float = 10.0) -> TouchGesture:
    """One gesture of consecutive pieces, as the segmenter would have collected it (module doc)."""
    if not pieces:
        raise ValueError('merge_pieces needs at least one piece')
    if len(pieces) == 1:
        return pieces[0]
    offsets = np.cumsum([0] + [p.strokes for p in pieces[:-1]])
    first, last = pieces[0], pieces[-1]
    duration = last.start_s + last.duration_s - first.start_s
    return TouchGesture(
        binary_map=np.logical_or.reduce([p.binary_map for p in pieces]),
        peak_map=np.maximum.reduce([p.peak_map for p in pieces]),
        trajectory=np.concatenate([p.trajectory for p in pieces]),
        times=np.concatenate([p.times for p in pieces]),
        stroke=np.concatenate([p.stroke + k for p, k in zip(pieces, offsets, strict=True)]),
        frames=sum(p.frames for p in pieces), start_s=first.start_s, duration_s=duration,
        strokes=int(sum(p.strokes for p in pieces)), multi_contact=any(p.multi_contact for p in pieces),
        truncated=any(p.truncated for p in pieces) or duration >= max_duration_s)


@dataclasses.dataclass(frozen=True, slots=True)
class Cut:
    """One gesture cut from a sample's pieces, and why it ended there.

    Attributes:
        gesture: the joined pieces.
        latency_s: the lift after its last contact at which it ended, s.
        reason: ``'gap'`` (a lift of ``gap_s``: whole, or no rule), ``'bound'`` (a prefix, a lift of
            ``wait_s``), ``'limit'`` (unfinished strokes, ``max_duration_s`` after the start),
            ``'truncated'`` (a next piece came ``max_duration_s`` or more after the start) or ``'end'``
            (the sample's last piece; its latency is the verdict's).
        verdict: the rule's answer for the gesture (None without a rule).
        lift_s: the lift after it (inf after the last piece), s.
    """

    gesture: TouchGesture
    latency_s: float
    reason: str
    verdict: Verdict | None
    lift_s: float


def cut_pieces(pieces: Sequence[TouchGesture], gap_s: float, wait_s: float | None = None,
               is_complete: Callable[[TouchGesture], bool | Verdict] | None = None,
               max_duration_s: float = 10.0) -> Iterator[Cut]:
    """The gestures a segmenter with ``gap_s``, ``wait_s`` and ``is_complete`` cuts from a sample's
    pieces (time order), each with why it ended (module doc); short ones are not dropped here.

    Raises:
        ValueError: ``gap_s`` below :data:`PIECE_GAP_S` (the pieces cannot show shorter lifts).
    """
    if gap_s < PIECE_GAP_S - 1e-9:
        raise ValueError(f'pieces rendered at a {PIECE_GAP_S} s gap cannot be joined at a shorter one ({gap_s} s)')
    waits = is_complete is not None and wait_s is not None

    def ending(current: list[TouchGesture]) -> tuple[Verdict | None, float]:
        """The verdict on ``current`` and the lift (s) that ends it."""
        if not waits:
            return None, gap_s
        verdict = verdict_of(is_complete(merge_pieces(current, max_duration_s)))  # type: ignore[misc]
        if verdict is Verdict.WHOLE:
            return verdict, gap_s
        if verdict is Verdict.PREFIX:
            return verdict, wait_s  # type: ignore[return-value]
        last = current[-1].start_s + current[-1].duration_s
        return verdict, max(wait_s, current[0].start_s + max_duration_s - last)  # type: ignore[type-var]

    reasons = {None: 'gap', Verdict.WHOLE: 'gap', Verdict.PREFIX: 'bound', Verdict.UNFINISHED: 'limit'}
    current: list[TouchGesture] = []
    for piece in pieces:
        if current:
            end = current[-1].start_s + current[-1].duration_s
            lift = piece.start_s - end - FRAME_PERIOD_S   # the longest lift a no-contact frame saw
            if lift >= gap_s - 1e-9:
                verdict, bound = ending(current)
                if lift >= bound - 1e-9:
                    yield Cut(merge_pieces(current, max_duration_s), bound, reasons[verdict], verdict, lift)
                    current = []
            if current and piece.start_s - current[0].start_s >= max_duration_s:
                cut = dataclasses.replace(merge_pieces(current, max_duration_s), truncated=True)
                yield Cut(cut, lift, 'truncated', None, lift)
                current = []
                continue
        current.append(piece)
    if current:
        verdict, bound = ending(current)
        yield Cut(merge_pieces(current, max_duration_s), bound, 'end', verdict, float('inf'))


def join_pieces(pieces: Sequence[TouchGesture], gap_s: float, wait_s: float | None = None,
                is_complete: Callable[[TouchGesture], bool | Verdict] | None = None, min_frames: int = 3,
                max_duration_s: float = 10.0) -> tuple[list[TouchGesture], list[float]]:
    """The gestures a segmenter with ``gap_s``, ``wait_s`` and ``is_complete`` cuts from a sample's
    pieces (time order), and the latency (s) of each (:func:`cut_pieces`). Gestures of fewer than
    ``min_frames`` frames are dropped, as the segmenter drops them.

    Raises:
        ValueError: ``gap_s`` below :data:`PIECE_GAP_S` (the pieces cannot show shorter lifts).
    """
    cuts = _kept(list(cut_pieces(pieces, gap_s, wait_s, is_complete, max_duration_s)), min_frames)
    return [c.gesture for c in cuts], [c.latency_s for c in cuts]


#: The end-of-gesture rules compared (:class:`GestureEnd` options). ``fractions``: whole templates against
#: prefixes cut at fractions of their ink, strokes fewer than the nearest class ever shows wait the bound
#: like any prefix (the rule before); ``fractions-unfinished``: those wait until the gesture's limit;
#: ``strokes-unfinished-nomargin``: prefixes cut between strokes, and the limit; ``strokes-unfinished``
#: (the default): and strokes that make a whole gesture wait for a longer one nearly as near
#: (:data:`~touch_gestures.skin.ending.ENDING_MARGIN`). The rules before the default end whole strokes at the
#: gap however near a longer gesture's beginning (margin 0).
RULES: dict[str, dict[str, object]] = {
    'fractions': {'prefixes': 'fractions', 'unfinished': False, 'margin': 0.0},
    'fractions-unfinished': {'prefixes': 'fractions', 'unfinished': True, 'margin': 0.0},
    'strokes-unfinished-nomargin': {'prefixes': 'strokes', 'unfinished': True, 'margin': 0.0},
    'strokes-unfinished': {'prefixes': 'strokes', 'unfinished': True}}
#: The rule of :class:`GestureEnd`'s defaults.
DEFAULT_RULE = 'strokes-unfinished'

#: (gap_s, wait_s, rule) the report compares: fixed gaps (wait None) and the rules at a few bounds.
ENDING_CONFIGS: tuple[tuple[float, float | None, str | None], ...] = (
    (1.0, None, None), (1.5, None, None), (3.0, None, None), (1.0, 3.0, 'fractions'),
    (1.0, 3.0, 'fractions-unfinished'), (1.0, 3.0, 'strokes-unfinished-nomargin'), (0.75, 3.0, DEFAULT_RULE),
    (1.0, 3.0, DEFAULT_RULE), (1.0, 5.0, DEFAULT_RULE))

#: Why a sample is not one gesture (:func:`ending_causes`), in table order.
CAUSES = ('ended as whole', 'pause over the bound', 'pause over the limit', 'longer than the limit',
          'pause over the gap', 'no gesture')
_CAUSE_OF_REASON = {'bound': 'pause over the bound', 'limit': 'pause over the limit',
                    'truncated': 'longer than the limit', 'gap': 'pause over the gap'}


def _folds(pieces: Sequence[RenderedSample], make: Callable[[], TemplateRecogniser], codebook_gap_s: float
           ) -> Iterator[tuple[str, TemplateRecogniser, list[RenderedSample]]]:
    """Leave-one-person-out: (person, recogniser fitted on the others' samples cut at ``codebook_gap_s``
    (the whole ones, neither two fingers nor truncated), that person's samples)."""
    for subject in sorted({r.subject for r in pieces}):
        train = []
        for r in pieces:
            if r.subject != subject:
                cut = join_pieces(r.gestures, codebook_gap_s)[0]
                if len(cut) == 1 and not cut[0].multi_contact and not cut[0].truncated:
                    train.append((cut[0], r.label))
        recogniser = make().fit([g for g, _ in train], [y for _, y in train])
        yield subject, recogniser, [r for r in pieces if r.subject == subject]


def _kept(cuts: Sequence[Cut], min_frames: int = 3) -> list[Cut]:
    return [c for c in cuts if c.gesture.frames >= min_frames or c.gesture.truncated]


def ending_table(pieces: Sequence[RenderedSample], make: Callable[[], TemplateRecogniser],
                 configs: Sequence[tuple[float, float | None, str | None]] = ENDING_CONFIGS,
                 codebook_gap_s: float = 3.0, progress: Callable[[str], None] | None = None
                 ) -> list[dict[str, float | str | None]]:
    """Leave-one-person-out, per (gap_s, wait_s, rule) of ``configs`` (wait None: a fixed gap; rule a
    key of :data:`RULES`): ``whole`` (samples cut into one gesture), ``accuracy`` (nearest class right,
    rejection off), mean and median latency (s) of the whole ones, ``waits_after`` (whole samples after
    which the segmenter still waited) and ``waits_to_limit`` (of those, the ones that waited until the
    limit). A fold's codebook is the other people's samples cut at ``codebook_gap_s``."""
    counts = {c: [0, 0, [], 0, 0] for c in configs}   # whole, correct, latencies, waits after, ...to the limit
    for subject, recogniser, held_out in _folds(pieces, make, codebook_gap_s):
        used = {rule for _, wait_s, rule in configs if wait_s and rule}
        rules = {name: GestureEnd(recogniser, **RULES[name]) for name in used}  # type: ignore[arg-type]
        for r in held_out:
            for gap_s, wait_s, rule in configs:
                cuts = _kept(list(cut_pieces(r.gestures, gap_s, wait_s, rules[rule] if wait_s and rule else None)))
                if len(cuts) == 1:
                    row = counts[(gap_s, wait_s, rule)]
                    row[0] += 1
                    row[1] += recogniser.predict(cuts[0].gesture).nearest == r.label
                    row[2].append(cuts[0].latency_s)
                    row[3] += cuts[0].verdict not in (None, Verdict.WHOLE)
                    row[4] += cuts[0].verdict is Verdict.UNFINISHED
        if progress is not None:
            progress(f'end of gesture: fold {subject} done')
    n = len(pieces)
    return [{'gap_s': g, 'wait_s': w, 'rule': rule, 'whole': whole / n, 'accuracy': correct / n,
             'latency_mean_s': float(np.mean(lat)) if lat else None,
             'latency_median_s': float(np.median(lat)) if lat else None, 'waits_after': waits / n,
             'waits_to_limit': limit / n}
            for (g, w, rule), (whole, correct, lat, waits, limit) in counts.items()]


def ending_causes(pieces: Sequence[RenderedSample], make: Callable[[], TemplateRecogniser],
                  file_strokes: Mapping[tuple[str, str, str, str], int] | None = None, gap_s: float = 1.0,
                  wait_s: float | None = 3.0, rule: str | None = DEFAULT_RULE, codebook_gap_s: float = 3.0,
                  progress: Callable[[str], None] | None = None) -> dict:
    """Why samples are not one gesture, per class, leave-one-person-out (``social-touch eval skin-ending``).

    The cause is the first cut's (:data:`CAUSES`); ``prefixes`` counts the strokes taken for a whole
    gesture by the class traced, the strokes so far and the class named; ``bound_pauses`` counts the
    cutting lifts of the two pause causes by length (s). With ``file_strokes`` (sample key -> strokes
    in the trace file), ``rendering`` counts per class the samples the virtual skin traced with fewer or
    more strokes than the file. ``waits_after`` counts per class the whole samples after which the
    segmenter still waited, up to the bound or the limit.
    """
    per_class: dict[str, dict[str, int]] = {}
    prefixes: dict[str, int] = {}
    rendering: dict[str, dict[str, int]] = {}
    waits_after: dict[str, dict[str, int]] = {}
    bins = (0.0, 3.0, 5.0, 10.0, np.inf)
    pauses = [0] * (len(bins) - 1)
    for subject, recogniser, held_out in _folds(pieces, make, codebook_gap_s):
        ending = GestureEnd(recogniser, **RULES[rule]) if rule and wait_s else None  # type: ignore[arg-type]
        for r in held_out:
            row = per_class.setdefault(r.label, {c: 0 for c in ('samples', 'whole', *CAUSES)})
            row['samples'] += 1
            if file_strokes is not None:
                traced, written = sum(p.strokes for p in r.gestures), file_strokes[(r.subject, r.variant, r.label,
                                                                                     r.sample)]
                fault = 'strokes joined' if traced < written else 'stroke broken' if traced > written else None
                if fault:
                    counts = rendering.setdefault(r.label, {'strokes joined': 0, 'stroke broken': 0})
                    counts[fault] += 1
            all_cuts = list(cut_pieces(r.gestures, gap_s, wait_s, ending))
            cuts = _kept(all_cuts)
            if len(cuts) == 1:
                row['whole'] += 1
                wait = {Verdict.PREFIX: 'bound', Verdict.UNFINISHED: 'limit'}.get(cuts[0].verdict)  # type: ignore[arg-type]
                if wait:
                    counts = waits_after.setdefault(r.label, {'bound': 0, 'limit': 0})
                    counts[wait] += 1
                continue
            if not cuts:
                row['no gesture'] += 1
                continue
            first = cuts[0]
            if first.verdict is Verdict.WHOLE and first.lift_s < wait_s - 1e-9:  # type: ignore[operator]
                row['ended as whole'] += 1
                taken = recogniser.predict(first.gesture).nearest
                key = f'{r.label}: {first.gesture.strokes} of its strokes taken for {taken}'
                prefixes[key] = prefixes.get(key, 0) + 1
            else:   # a whole verdict at a lift of the bound or more: cut by the bound as well
                row[_CAUSE_OF_REASON['bound' if first.verdict is Verdict.WHOLE else first.reason]] += 1
                if first.reason in ('bound', 'limit', 'gap'):
                    pauses[int(np.searchsorted(bins, first.lift_s, side='right')) - 1] += 1
        if progress is not None:
            progress(f'causes: fold {subject} done')
    totals = {c: sum(row[c] for row in per_class.values()) for c in ('samples', 'whole', *CAUSES)}
    return {'gap_s': gap_s, 'wait_s': wait_s, 'rule': rule, 'per_class': dict(sorted(per_class.items())),
            'totals': totals, 'prefixes': dict(sorted(prefixes.items(), key=lambda kv: -kv[1])),
            'bound_pauses': {f'{lo:g}-{hi:g} s': k for lo, hi, k in zip(bins[:-1], bins[1:], pauses, strict=True)},
            'rendering': dict(sorted(rendering.items())), 'waits_after': dict(sorted(waits_after.items()))}
