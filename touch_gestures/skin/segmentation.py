"""Cut the skin's frame stream into gestures (cirillo2017 3.2, Fig. 5).

A gesture runs from the first contact until the contact ends. :class:`GestureSegmenter` does this
one calibrated frame at a time, with what the paper leaves open:

- **strokes and the gap**: a lift shorter than ``gap_s`` starts a new stroke of the same gesture
  (each point keeps its stroke index); a lift of ``gap_s`` ends it. Multi-stroke vocabularies use
  :data:`MULTISTROKE_GAP_S` (the codebook file carries its gap).
- **the vocabulary's end of a gesture** (``is_complete``, ``wait_s``): with a rule that tells
  whether the strokes so far are a whole gesture (:class:`~.ending.GestureEnd`, asked once per lift
  when it reaches ``gap_s``), a complete gesture ends at ``gap_s``, one that looks like the start of
  a longer one waits up to ``wait_s``, and strokes that can be no whole gesture
  (:attr:`Verdict.UNFINISHED`) wait until ``max_duration_s`` after the start (at least ``wait_s``).
- **a limit**: a touch that never ends is cut at ``max_duration_s`` with ``truncated=True``, and
  the segmenter waits for the release before it starts another. State is bounded by
  ``max_frames`` preallocated rows.
- **two fingers**: a frame whose thresholded map has two or more blobs more than
  ``merge_gap_taxels`` empty taxels apart is multi-contact; a gesture with at least
  ``min_multi_frames`` such frames, and ``multi_fraction`` of its frames, is flagged
  ``multi_contact`` (its pressure-weighted contact point lies between the fingers).

Bad input is counted in ``stats``, not raised: NaN pressures count as 0 (``nan_frames``), a frame
whose time goes backwards is skipped (``time_reversals``), a contact without a finite point adds to
the map but not the trajectory (``missing_points``), and a contact frame whose highest pressure is
below ``map_threshold`` gives no trajectory point (``faint_points``: with almost no load, noise and
hysteresis pull the contact point anywhere).
"""

from __future__ import annotations

import enum
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .blobs import count_blobs
from .gesture import GRID, TouchGesture

__all__ = ['ENDING_GAP_S', 'ENDING_WAIT_S', 'MULTISTROKE_GAP_S', 'SINGLE_STROKE_GAP_S', 'GestureSegmenter',
           'SegmenterStats', 'Verdict', 'default_gap_s', 'verdict_of']

#: Gap (s) for vocabularies of single-stroke gestures: joins a finger skipping between taxels.
SINGLE_STROKE_GAP_S = 0.15
#: Gap (s) for vocabularies with multi-stroke gestures: the knee of `social-touch eval skin --gap-table`
#: (a longer gap keeps hardly more samples whole, and every command waits it after the last lift).
MULTISTROKE_GAP_S = 1.5
#: With the vocabulary's end of a gesture (:class:`~.ending.GestureEnd`): the lift (s) that ends
#: strokes that make a whole gesture, and the longest one that still continues strokes that look
#: like the beginning of a longer gesture.
ENDING_GAP_S = 1.0
ENDING_WAIT_S = 3.0


def default_gap_s(max_strokes: int) -> float:
    """The gap for a vocabulary whose templates have at most ``max_strokes`` strokes.

    >>> default_gap_s(1), default_gap_s(3)
    (0.15, 1.5)
    """
    return MULTISTROKE_GAP_S if max_strokes > 1 else SINGLE_STROKE_GAP_S


class Verdict(enum.Enum):
    """What the strokes so far are, asked when a lift reaches the gap (:class:`~.ending.GestureEnd`)."""

    WHOLE = 'whole'            # a whole gesture of the vocabulary: the lift ends it
    PREFIX = 'prefix'          # maybe the beginning of a longer one: wait for a next stroke up to wait_s
    UNFINISHED = 'unfinished'  # no whole gesture at all: wait until max_duration_s after its start


def verdict_of(answer: bool | Verdict) -> Verdict:
    """A rule's answer as a :class:`Verdict`: ``True`` is whole, ``False`` a prefix.

    >>> verdict_of(True), verdict_of(False), verdict_of(Verdict.UNFINISHED)
    (<Verdict.WHOLE: 'whole'>, <Verdict.PREFIX: 'prefix'>, <Verdict.UNFINISHED: 'unfinished'>)
    """
    if isinstance(answer, Verdict):
        return answer
    return Verdict.WHOLE if answer else Verdict.PREFIX


#: Lifts are differences of float64 seconds made from integer-nanosecond stamps (float64's spacing
#: near today's epoch is a fraction of a microsecond): a lift of exactly gap_s frames could come out a
#: rounding short and wait one more frame. The tolerance covers that rounding and is far below any
#: frame period.
_LIFT_TOLERANCE_S = 1e-6


@dataclass
class SegmenterStats:
    """Counters since the segmenter was made."""

    frames: int = 0             # frames fed
    gestures: int = 0           # gestures emitted (including truncated ones)
    too_short: int = 0          # contacts shorter than min_frames, dropped
    truncated: int = 0          # gestures cut at max_duration_s / max_frames
    multi_contact: int = 0      # gestures flagged multi_contact
    nan_frames: int = 0         # frames with NaN pressure (treated as 0)
    missing_points: int = 0     # contact frames without a finite contact point
    faint_points: int = 0       # contact frames too faint (peak < map_threshold) for a trusted point
    time_reversals: int = 0     # frames whose time was before the previous one, skipped
    waited: int = 0             # lifts of gap_s whose strokes looked incomplete: kept waiting
    waited_continued: int = 0   # ...that a next stroke then continued
    ended_at_bound: int = 0     # gestures ended by a lift of wait_s, never complete
    ended_unfinished: int = 0   # ...of them, strokes that could be no whole gesture, ended at max_duration_s


class GestureSegmenter:
    """Feed calibrated frames, get completed :class:`TouchGesture` objects.

    Args:
        gap_s: a lift must last this long (s) to end the gesture; shorter lifts separate
            strokes (:data:`SINGLE_STROKE_GAP_S`, :data:`MULTISTROKE_GAP_S`).
        max_duration_s: a touch is cut after this long (s).
        min_frames: contacts with fewer frames are dropped as taps or noise.
        map_threshold: pressure (1 = full scale) a taxel must reach to enter the binary map
            (cirillo2017 3.1); 0.02 is twice the calibration's contact threshold.
        map_relative: a taxel must also reach this fraction of the frame's highest pressure,
            so the map shows the finger's pad whatever the force.
        merge_gap_taxels: blobs separated by at most this many empty taxels are one contact.
        min_multi_frames: multi-blob frames needed to flag a gesture multi_contact...
        multi_fraction: ...and the fraction of its contact frames they must make up.
        max_frames: capacity of the per-gesture buffers; the gesture is cut when full.
        wait_s: with ``is_complete``, the longest lift (s) that may still continue a gesture
            whose strokes look incomplete; must be >= ``gap_s``. None: ``gap_s`` ends every gesture.
        is_complete: ``is_complete(gesture_so_far) -> bool | Verdict``: are these strokes a whole
            gesture of the vocabulary (:class:`~.ending.GestureEnd`)? ``True``/``WHOLE``: the lift ends
            it; ``False``/``PREFIX``: wait up to ``wait_s``; ``UNFINISHED``: wait until ``max_duration_s``
            after its start (at least ``wait_s``). None: every lift of ``gap_s`` ends it.

    >>> seg = GestureSegmenter(gap_s=0.05, min_frames=2)
    >>> touch = np.zeros((12, 12), np.float32); touch[3, 4] = 1.0
    >>> out = [seg.update(touch, True, np.array([17.0, 13.7]), i / 150) for i in range(5)]
    >>> out += [seg.update(np.zeros((12, 12), np.float32), False, None, (5 + i) / 150) for i in range(10)]
    >>> [g for batch in out for g in batch]
    [TouchGesture(points=5, frames=5, duration_s=0.027, taxels=1, strokes=1)]
    """

    def __init__(self, gap_s: float = SINGLE_STROKE_GAP_S, max_duration_s: float = 10.0, min_frames: int = 3,
                 map_threshold: float = 0.02, map_relative: float = 0.3, merge_gap_taxels: int = 2,
                 min_multi_frames: int = 3, multi_fraction: float = 0.25, max_frames: int = 3000,
                 wait_s: float | None = None,
                 is_complete: Callable[[TouchGesture], bool | Verdict] | None = None) -> None:
        if not gap_s >= 0:
            raise ValueError(f'gap_s must be >= 0 s, got {gap_s}')
        if not max_duration_s > 0:
            raise ValueError(f'max_duration_s must be > 0 s, got {max_duration_s}')
        if min_frames < 1 or max_frames < 1 or min_multi_frames < 1:
            raise ValueError(f'min_frames, min_multi_frames and max_frames must be >= 1; got {min_frames}, '
                             f'{min_multi_frames}, {max_frames}')
        if not (np.isfinite(map_threshold) and map_threshold > 0):
            raise ValueError(f'map_threshold must be a finite pressure > 0, got {map_threshold}')
        if not 0 <= map_relative < 1:
            raise ValueError(f'map_relative must be in [0, 1), got {map_relative}')
        if not 0 <= multi_fraction <= 1 or merge_gap_taxels < 0:
            raise ValueError(f'need 0 <= multi_fraction <= 1 and merge_gap_taxels >= 0; got {multi_fraction}, '
                             f'{merge_gap_taxels}')
        if wait_s is not None and not (np.isfinite(wait_s) and wait_s >= gap_s):
            raise ValueError(f'wait_s must be a finite lift >= gap_s ({gap_s} s) or None, got {wait_s}')
        self.gap_s = float(gap_s)
        self.wait_s = None if wait_s is None else float(wait_s)
        self.is_complete = is_complete
        self.max_duration_s = float(max_duration_s)
        self.min_frames = int(min_frames)
        self.map_threshold = float(map_threshold)
        self.map_relative = float(map_relative)
        self.merge_gap_taxels = int(merge_gap_taxels)
        self.min_multi_frames = int(min_multi_frames)
        self.multi_fraction = float(multi_fraction)
        self.max_frames = int(max_frames)
        self.stats = SegmenterStats()
        self._points = np.empty((self.max_frames, 2), dtype=np.float32)
        self._times = np.empty(self.max_frames, dtype=np.float64)
        self._strokes = np.empty(self.max_frames, dtype=np.int16)
        self._peak = np.zeros((GRID, GRID), dtype=np.float32)
        self._binary = np.zeros((GRID, GRID), dtype=bool)
        self._last_t = -np.inf
        self.reset()

    def reset(self) -> None:
        """Forget any gesture in progress (the counters are kept)."""
        self._active = False          # a gesture is being collected
        self._suppressed = False      # cut at the limit: wait for the release
        self._n = 0                   # trajectory points
        self._frames = 0              # contact frames
        self._multi_frames = 0
        self._stroke = 0
        self._start_t = 0.0
        self._last_contact_t = 0.0
        self._lifted = False
        self._verdict: Verdict | None = None   # the rule's answer for the lift under way
        self._peak.fill(0.0)
        self._binary.fill(False)

    def restart(self) -> None:
        """Forget the gesture in progress and the time of the last frame (a replay looped, a clock
        restarted): the next frame may have any time. The counters are kept."""
        self.reset()
        self._last_t = -np.inf

    @property
    def active(self) -> bool:
        """True while a gesture is being collected (including its hysteresis tail)."""
        return self._active

    def update(self, pressure: np.ndarray, contact: bool, contact_xy_mm: np.ndarray | None,
             t: float) -> list[TouchGesture]:
        """Add one frame; return the gestures it completes (usually none, at most one).

        Args:
            pressure: (12, 12) (or (144,)) pressure map, 1 = full scale; NaN counts as 0.
            contact: the calibration's contact flag for the frame.
            contact_xy_mm: (2,) contact point, mm, NaN (or None) when there is none.
            t: frame time, s, non-decreasing.

        Raises:
            ValueError: ``pressure`` does not hold 144 values (a wiring mistake, not bad data).
        """
        pressure = np.asarray(pressure, dtype=np.float32)
        if pressure.size != GRID * GRID:
            raise ValueError(f'pressure must be ({GRID}, {GRID}) or ({GRID * GRID},); got shape {pressure.shape}')
        self.stats.frames += 1
        t = float(t)
        if not t >= self._last_t:  # also catches NaN
            self.stats.time_reversals += 1
            return []
        self._last_t = t
        pressure = pressure.reshape(GRID, GRID)
        if np.isnan(pressure).any():
            self.stats.nan_frames += 1
            pressure = np.nan_to_num(pressure, nan=0.0)
        out: list[TouchGesture] = []
        if not contact:
            if self._suppressed:
                self._suppressed = False
            elif self._active:
                self._lifted = True
                lift = t - self._last_contact_t + _LIFT_TOLERANCE_S
                if lift >= self.gap_s and self._ends(lift, t):
                    self._finish(out, truncated=False)
            return out
        if self._suppressed:
            return out
        if not self._active:
            self._active, self._start_t, self._stroke = True, t, 0
        elif self._lifted:
            self._stroke += 1
            self.stats.waited_continued += self._verdict not in (None, Verdict.WHOLE)
        self._lifted, self._verdict = False, None
        self._last_contact_t = t
        self._add(pressure, contact_xy_mm, t)
        if t - self._start_t >= self.max_duration_s or self._n >= self.max_frames \
                or self._frames >= self.max_frames:
            self._finish(out, truncated=True)
            self._suppressed = True
        return out

    def _ends(self, lift: float, t: float) -> bool:
        """Whether a lift of ``lift`` s (>= gap_s) at frame time ``t`` ends the gesture (module doc)."""
        if self.is_complete is None or self.wait_s is None:
            return True
        if self._verdict is None:
            so_far = self.partial()
            self._verdict = Verdict.WHOLE if so_far is None else verdict_of(self.is_complete(so_far))
            self.stats.waited += self._verdict is not Verdict.WHOLE
        if self._verdict is Verdict.WHOLE:
            return True
        if lift < self.wait_s:
            return False
        if self._verdict is Verdict.UNFINISHED:
            # As long as a gesture may last: a next stroke after that would be cut as truncated anyway.
            if t - self._start_t + _LIFT_TOLERANCE_S < self.max_duration_s:
                return False
            self.stats.ended_unfinished += 1
        self.stats.ended_at_bound += 1
        return True

    def partial(self) -> TouchGesture | None:
        """The gesture under way so far (a copy), for decisions before the finger lifts; None when
        no gesture is under way or it has no trajectory point yet."""
        if not self._active or self._suppressed or self._n == 0:
            return None
        n = self._n
        return TouchGesture(
            binary_map=self._binary.copy(), peak_map=self._peak.copy(), trajectory=self._points[:n].copy(),
            times=self._times[:n].copy(), stroke=self._strokes[:n].copy(), frames=self._frames,
            start_s=self._start_t, duration_s=self._last_contact_t - self._start_t, strokes=self._stroke + 1)

    def flush(self) -> list[TouchGesture]:
        """End any gesture in progress as if the finger had lifted (e.g. at the end of a recording)."""
        out: list[TouchGesture] = []
        if self._active:
            self._finish(out, truncated=False)
        self._suppressed = False
        return out

    def _add(self, pressure: np.ndarray, xy: np.ndarray | None, t: float) -> None:
        self._frames += 1
        np.maximum(self._peak, pressure, out=self._peak)
        peak = float(pressure.max())
        above = pressure >= max(self.map_threshold, self.map_relative * peak)
        self._binary |= above
        if above.any() and self._count_blobs(above) >= 2:
            self._multi_frames += 1
        if peak < self.map_threshold:
            self.stats.faint_points += 1
            return
        if xy is None or not np.all(np.isfinite(xy)) or np.size(xy) != 2:
            self.stats.missing_points += 1
            return
        self._points[self._n] = np.asarray(xy, dtype=np.float32).reshape(2)
        self._times[self._n] = t
        self._strokes[self._n] = self._stroke
        self._n += 1

    def _count_blobs(self, above: np.ndarray) -> int:
        # Growing each blob by half the allowed gap joins blobs at most merge_gap_taxels apart.
        return count_blobs(above, grow=(self.merge_gap_taxels + 1) // 2)

    def _finish(self, out: list[TouchGesture], truncated: bool) -> None:
        if self._frames < self.min_frames and not truncated:
            self.stats.too_short += 1
            self.reset()
            return
        n = self._n
        gesture = TouchGesture(
            binary_map=self._binary.copy(), peak_map=self._peak.copy(), trajectory=self._points[:n].copy(),
            times=self._times[:n].copy(), stroke=self._strokes[:n].copy(), frames=self._frames,
            start_s=self._start_t, duration_s=self._last_contact_t - self._start_t, strokes=self._stroke + 1,
            multi_contact=self._multi_frames >= max(self.min_multi_frames, self.multi_fraction * self._frames),
            truncated=truncated)
        self.stats.gestures += 1
        self.stats.truncated += int(truncated)
        self.stats.multi_contact += int(gesture.multi_contact)
        out.append(gesture)
        self.reset()
