"""The end of a gesture, measured: samples rendered once into pieces, joined per rule and codebook.

Whether a lift ends a gesture depends, with :class:`~touch_gestures.skin.ending.GestureEnd`,
on the codebook of the fold, so a sample cannot be rendered once per rule and fold (rendering
is the slow part). It is rendered once with a short gap (:data:`PIECE_GAP_S`, ``min_frames``
1): every lift of that length or more splits it into *pieces*. :func:`join_pieces` then does
what :class:`~touch_gestures.skin.segmentation.GestureSegmenter` does at each of those lifts:
shorter than ``gap_s`` joins, ``gap_s`` or more ends a complete gesture, an incomplete one
waits up to ``wait_s``. Joining is exact for what the recognisers read (trajectory, times,
strokes, the OR of the maps, the maximum of the peaks, frames, duration), the lifts are read
at frame times as the segmenter reads them; only ``multi_contact`` is approximate (any piece
flagged) and a joined gesture longer than ``max_duration_s`` is marked truncated rather than cut.

Each gesture comes with its **latency**: the lift after its last contact at which it ended
(``gap_s`` for a complete one, ``wait_s`` for one that never was). :func:`ending_table`
measures whole samples, accuracy and latency per (gap, bound), the table the defaults of
:mod:`touch_gestures.skin.segmentation` are chosen on.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.ending import GestureEnd
from touch_gestures.skin.gesture import TouchGesture
from touch_sim.skin.render import RenderedSample

__all__ = ['ENDING_CONFIGS', 'FRAME_PERIOD_S', 'PIECE_GAP_S', 'ending_table', 'join_pieces', 'merge_pieces']

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


def join_pieces(pieces: Sequence[TouchGesture], gap_s: float, wait_s: float | None = None,
                is_complete: Callable[[TouchGesture], bool] | None = None, min_frames: int = 3,
                max_duration_s: float = 10.0) -> tuple[list[TouchGesture], list[float]]:
    """The gestures a segmenter with ``gap_s``, ``wait_s`` and ``is_complete`` cuts from a sample's
    pieces (time order), and the latency (s) of each (module doc). Gestures of fewer than
    ``min_frames`` frames are dropped, as the segmenter drops them.

    Raises:
        ValueError: ``gap_s`` below :data:`PIECE_GAP_S` (the pieces cannot show shorter lifts).
    """
    if gap_s < PIECE_GAP_S - 1e-9:
        raise ValueError(f'pieces rendered at a {PIECE_GAP_S} s gap cannot be joined at a shorter one ({gap_s} s)')
    waits = is_complete is not None and wait_s is not None

    def complete(current: list[TouchGesture]) -> bool:
        return not waits or bool(is_complete(merge_pieces(current, max_duration_s)))  # type: ignore[misc]

    out: list[TouchGesture] = []
    latencies: list[float] = []

    def emit(current: list[TouchGesture], latency: float) -> None:
        gesture = merge_pieces(current, max_duration_s)
        if gesture.frames >= min_frames or gesture.truncated:
            out.append(gesture)
            latencies.append(latency)

    current: list[TouchGesture] = []
    for piece in pieces:
        if current:
            end = current[-1].start_s + current[-1].duration_s
            lift = piece.start_s - end - FRAME_PERIOD_S   # the longest lift a no-contact frame saw
            if lift >= gap_s - 1e-9:
                if complete(current):
                    emit(current, gap_s)
                    current = []
                elif lift >= wait_s - 1e-9:  # type: ignore[operator]
                    emit(current, wait_s)    # type: ignore[arg-type]
                    current = []
        current.append(piece)
    if current:
        emit(current, gap_s if complete(current) else wait_s)  # type: ignore[arg-type]
    return out, latencies


#: (gap_s, wait_s) the report compares: the fixed gaps of before and the rule at a few bounds.
ENDING_CONFIGS: tuple[tuple[float, float | None], ...] = ((1.0, None), (1.5, None), (3.0, None), (0.75, 3.0),
                                                           (1.0, 3.0), (1.0, 5.0))


def ending_table(pieces: Sequence[RenderedSample], make: Callable[[], TemplateRecogniser],
                 configs: Sequence[tuple[float, float | None]] = ENDING_CONFIGS, codebook_gap_s: float = 3.0,
                 progress: Callable[[str], None] | None = None) -> list[dict[str, float | None]]:
    """Leave-one-person-out, per (gap_s, wait_s) of ``configs`` (wait None: a fixed gap): the samples
    cut into one gesture (``whole``), the nearest class right over all samples (``accuracy``, rejection
    off) and the mean and median latency (s) of the whole ones. The codebook of a fold is the other
    people's samples cut at ``codebook_gap_s``, the same for every row."""
    subjects = sorted({r.subject for r in pieces})
    counts = {c: [0, 0, []] for c in configs}   # whole, correct, latencies
    for subject in subjects:
        train = []
        for r in pieces:
            if r.subject != subject:
                cut = join_pieces(r.gestures, codebook_gap_s)[0]
                if len(cut) == 1 and not cut[0].multi_contact and not cut[0].truncated:
                    train.append((cut[0], r.label))
        recogniser = make().fit([g for g, _ in train], [y for _, y in train])
        rule = GestureEnd(recogniser)
        for r in pieces:
            if r.subject != subject:
                continue
            for gap_s, wait_s in configs:
                cut, latency = join_pieces(r.gestures, gap_s, wait_s, rule if wait_s else None)
                if len(cut) == 1:
                    row = counts[(gap_s, wait_s)]
                    row[0] += 1
                    row[1] += recogniser.predict(cut[0]).nearest == r.label
                    row[2] += latency
        if progress is not None:
            progress(f'end of gesture: fold {subject} done')
    n = len(pieces)
    return [{'gap_s': g, 'wait_s': w, 'whole': whole / n, 'accuracy': correct / n,
             'latency_mean_s': float(np.mean(lat)) if lat else None,
             'latency_median_s': float(np.median(lat)) if lat else None}
            for (g, w), (whole, correct, lat) in counts.items()]
