"""Input frame screening: a recogniser keeps to the frames of its own driver when others arrive too.

A callback is not told which publisher sent a message, so :class:`FrameScreen` follows one
*source* by what frames carry and screens out a frame that names another ``header.frame_id``
(``'other_frame_id'``), is stamped before the last frame taken (``'stamp_back'``), or, once the
source's ``sequence`` counts, is behind it or more than ``max_sequence_gap`` ahead (``'sequence_jump'``).
Screened frames that continue each other for ``switch_after`` frames, with none of the source
between, become the new source (a looped bag, a restarted driver) and are handed back in order.
A counting source's forward step of more than one counts the frames in between as *missed*: sent,
never handed to this node (lost on the way, or dropped from the queue of a node that falls behind);
real rclpy has no counter of a subscription's queue drops, so this is how a starved recogniser says
so on either backend.

>>> from types import SimpleNamespace as NS
>>> def frame(t, seq, fid='skin'):
...     return NS(header=NS(stamp=NS(sec=t, nanosec=0), frame_id=fid), sequence=seq)
>>> screen = FrameScreen('/skin/frame')
>>> [len(screen.admit(frame(t, t))) for t in (10, 11)]
[1, 1]
>>> screen.admit(frame(0, 0, ''))      # a stray, stamped 0, without frame_id
[]
>>> len(screen.admit(frame(12, 12))), dict(screen.screened)
(1, {'other_frame_id': 1})
"""

from __future__ import annotations

from collections import Counter
from typing import Any

__all__ = ['CAUSES', 'ERROR', 'OK', 'WARN', 'FrameScreen']

OK, WARN, ERROR = 0, 1, 2
_NS = 1_000_000_000
_SEQ_MOD = 1 << 16   # the drivers' wire counters are uint16
#: What each screening reason means, for logs and /diagnostics.
CAUSES = {
    'other_frame_id': 'another header.frame_id than the driver\'s',
    'stamp_back': 'stamped before the frame in use (stale or stamped 0)',
    'sequence_jump': 'sequence counter out of step with the driver\'s',
}


def _stamp_ns(msg: Any) -> int:
    return int(msg.header.stamp.sec) * _NS + int(msg.header.stamp.nanosec)


class _Source:
    """The last frame of one source: frame_id, stamp (ns), sequence, and whether its sequence counts."""

    def __init__(self, msg: Any) -> None:
        self.frame_id = str(msg.header.frame_id)
        self.stamp_ns = _stamp_ns(msg)
        self.sequence = int(getattr(msg, 'sequence', 0))
        self.counting = False   # seen +1 steps: then the counter is the driver's and is checked

    def why_not(self, msg: Any, max_gap: int) -> str | None:
        """Why ``msg`` is not this source's next frame (a key of CAUSES), or None."""
        if str(msg.header.frame_id) != self.frame_id:
            return 'other_frame_id'
        if _stamp_ns(msg) < self.stamp_ns:
            return 'stamp_back'
        if self.counting and not 0 <= (int(getattr(msg, 'sequence', 0)) - self.sequence) % _SEQ_MOD <= max_gap:
            return 'sequence_jump'
        return None

    def continued_by(self, msg: Any) -> bool:
        """``msg`` moves this source forward: same frame_id, stamp later, or same stamp and counter + 1."""
        if str(msg.header.frame_id) != self.frame_id:
            return False
        stamp, seq = _stamp_ns(msg), int(getattr(msg, 'sequence', 0))
        return stamp > self.stamp_ns or (stamp == self.stamp_ns and seq == (self.sequence + 1) % _SEQ_MOD)

    def take(self, msg: Any) -> int:
        """Make ``msg`` this source's last frame; the frames its counter skipped (0 unless counting)."""
        seq = int(getattr(msg, 'sequence', 0))
        skipped = (seq - self.sequence - 1) % _SEQ_MOD if self.counting else 0
        if seq == (self.sequence + 1) % _SEQ_MOD:
            self.counting = True
        self.frame_id, self.stamp_ns, self.sequence = str(msg.header.frame_id), _stamp_ns(msg), seq
        return skipped if skipped < _SEQ_MOD - 1 else 0   # the same counter again (a repeat) skips nothing


class FrameScreen:
    """Follow one source of frames on ``topic`` and screen out the others (see the module doc).

    Args:
        topic: the input topic, for messages.
        switch_after: consecutive frames of another source, with none of the followed one in
            between, that make it the new source (a restart). At least 2.
        max_sequence_gap: largest forward step of a counting source's ``sequence`` (frames the
            driver may have lost in between).
        logger: an rclpy-style logger: screened frames are logged at WARN (at most every 5 s), a change
            of source at WARN each time.

    Attributes:
        admitted: frames handed to the node. screened: reason -> frames screened out (CAUSES).
        missed: frames the followed source's counter skipped (sent, never handed to the node).
        malformed: reason -> frames the node found unusable (:meth:`malformed`).
        source_changes: times a new source was followed (a restart, a looped bag).
    """

    def __init__(self, topic: str, switch_after: int = 3, max_sequence_gap: int = 1000, logger: Any = None) -> None:
        if switch_after < 2:
            raise ValueError(f'switch_after must be >= 2 frames, got {switch_after}')
        if max_sequence_gap < 1:
            raise ValueError(f'max_sequence_gap must be >= 1, got {max_sequence_gap}')
        self.topic = topic
        self.logger = logger
        self.switch_after = int(switch_after)
        self.max_sequence_gap = int(max_sequence_gap)
        self.admitted = 0
        self.missed = 0
        self.screened: Counter[str] = Counter()
        self.malformed_: Counter[str] = Counter()
        self.source_changes = 0
        self._source: _Source | None = None
        self._candidate: _Source | None = None
        self._held: list[Any] = []
        self._seen = (0, Counter(), Counter(), 0)   # admitted, screened, malformed, missed at the last status()

    @property
    def source(self) -> str:
        """The followed source, for messages: its frame_id and last sequence."""
        s = self._source
        return 'none yet' if s is None else f"frame_id '{s.frame_id}', sequence {s.sequence}"

    def malformed(self, reason: str) -> None:
        """Count a frame the node could not use (``reason``: e.g. ``'wrong_size'``, ``'non_finite'``)."""
        self.malformed_[reason] += 1

    def admit(self, msg: Any) -> list[Any]:
        """The frames to use now, in order: ``[msg]``, ``[]`` (screened out), or on a change of source
        the frames held for it ending with ``msg``."""
        src = self._source
        if src is None:
            self._source = _Source(msg)
            self.admitted += 1
            return [msg]
        reason = src.why_not(msg, self.max_sequence_gap)
        if reason is None:
            if src.continued_by(msg):   # the followed source moves on: whatever was building up is a stray
                self._candidate, self._held = None, []
            self.missed += src.take(msg)
            self.admitted += 1
            return [msg]
        self.screened[reason] += 1
        if self.logger is not None:
            self.logger.warning(f'screened out a frame on {self.topic}: {CAUSES[reason]} (following {self.source}; '
                                f'screened so far: {dict(self.screened)})', throttle_duration_sec=5.0)
        cand = self._candidate
        if cand is not None and cand.continued_by(msg):
            cand.take(msg)
            self._held.append((msg, reason))
        else:
            self._candidate, self._held = _Source(msg), [(msg, reason)]
        if len(self._held) < self.switch_after:
            return []
        # A source of its own, with the followed one silent meanwhile: a restart. Follow it, losing nothing.
        held, self._source, self._candidate, self._held = self._held, self._candidate, None, []
        self.screened -= Counter(why for _, why in held)   # not screened after all
        self.admitted += len(held)
        self.source_changes += 1
        if self.logger is not None:
            self.logger.warning(f'the frames on {self.topic} now come from another source ({self.source}; '
                                f'{len(held)} frames in a row, none from the one before): a restarted driver or '
                                'a looped bag; following it')
        return [m for m, _ in held]

    def counters(self) -> dict[str, int]:
        """Totals for /diagnostics: ``frames_admitted``, ``frames_missed``, ``frames_screened_<reason>``,
        ``frames_malformed_<reason>``, ``frame_source_changes``."""
        return {'frames_admitted': self.admitted, 'frames_missed': self.missed,
                **{f'frames_screened_{k}': v for k, v in sorted(self.screened.items())},
                **{f'frames_malformed_{k}': v for k, v in sorted(self.malformed_.items())},
                'frame_source_changes': self.source_changes}

    def status(self) -> tuple[int, str] | None:
        """(level, message) about the frames since the previous call, or None when all were usable."""
        admitted0, screened0, malformed0, missed0 = self._seen
        admitted = self.admitted - admitted0
        screened = self.screened - screened0
        malformed = self.malformed_ - malformed0
        missed = self.missed - missed0
        self._seen = (self.admitted, Counter(self.screened), Counter(self.malformed_), self.missed)
        bad = sum(screened.values()) + sum(malformed.values())
        if not bad:
            if not missed:
                return None
            return WARN, (f'{missed} frames on {self.topic} missed ({admitted} taken): the sensor sent them and this '
                          'node never had them (lost on the way, or dropped by a node that falls behind)')
        parts = [f'{n} {k} ({CAUSES[k]})' for k, n in sorted(screened.items())]
        parts += [f'{n} malformed: {k}' for k, n in sorted(malformed.items())]
        causes = ', '.join(parts)
        if not admitted:
            return ERROR, f'no usable frame on {self.topic}: {bad} received, {causes}'
        who = ('another publisher on the topic interleaves its frames with the driver\'s' if screened
               else 'the driver sends unusable frames')
        lost = f'; {missed} more missed' if missed else ''
        return WARN, (f'{bad} of {bad + admitted} frames on {self.topic} not used: {causes}; {who}; '
                      f'following {self.source}{lost}')
