"""``SkinFrame`` messages in, segmented gestures out: what the skin node and the codebook recorder share.

:class:`SkinFrameStream` feeds the calibrated frames of ``skin_driver`` (``/skin/frame``:
``pressure`` float32[144] row-major, ``contact``, ``contact_x``/``contact_y`` mm, NaN without
contact) to a :class:`~.segmentation.GestureSegmenter`, with time taken from the header
stamps (so a replayed bag cuts the same gestures as the live run). It has no graph code:
it takes message objects, whoever delivers them (a subscription, a bridge tap, a bag).

Bad input is counted in :attr:`SkinFrameStream.skipped` and skipped, never raised:

- ``'wrong_size'``: ``pressure`` does not hold 144 values (another sensor's frame on the topic);
- ``'non_finite'``: NaN or infinite pressures (a calibrated frame never has any).

A stamp earlier than the previous frame's (a looped bag, a restarted driver) drops the gesture
under way and starts time afresh at that frame (counted in :attr:`restarts`).

A gap longer than ``max_gap_s`` between frames (the driver stalled or was unplugged) with a
gesture under way drops that gesture (counted in :attr:`interrupted`): what the finger did in
the gap is unknown.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import numpy as np

from .gesture import GRID, TouchGesture
from .segmentation import GestureSegmenter

__all__ = ['SkinFrameStream']

_NS = 1_000_000_000


class SkinFrameStream:
    """Cut a stream of ``SkinFrame`` messages into :class:`TouchGesture` objects.

    Args:
        segmenter: does the cutting (its parameters: hysteresis, limit, two fingers).
        max_gap_s: a longer gap between frame stamps drops the gesture under way (s).

    Attributes:
        frames: frames fed to the segmenter.
        skipped: reason -> frames skipped (module doc).
        interrupted: gestures dropped because frames stopped for longer than ``max_gap_s``.
        restarts: times the stamps went back and time started afresh.
        t0_ns: stamp of the first frame since the last restart (the segmenter's time 0), or None.
    """

    def __init__(self, segmenter: GestureSegmenter | None = None, max_gap_s: float = 0.5) -> None:
        if not (math.isfinite(max_gap_s) and max_gap_s > 0):
            raise ValueError(f'max_gap_s must be a positive number of seconds, got {max_gap_s}')
        self.segmenter = segmenter if segmenter is not None else GestureSegmenter()
        self.max_gap_ns = round(max_gap_s * _NS)
        self.frames = 0
        self.skipped: Counter[str] = Counter()
        self.interrupted = 0
        self.restarts = 0
        self.t0_ns: int | None = None
        self._last_ns: int | None = None

    def update(self, msg: Any) -> list[TouchGesture]:
        """Add one ``SkinFrame``; returns the gestures it completes (usually none)."""
        pressure = np.asarray(msg.pressure, dtype=np.float32)
        if pressure.size != GRID * GRID:
            self.skipped['wrong_size'] += 1
            return []
        if not np.isfinite(pressure).all():
            self.skipped['non_finite'] += 1
            return []
        stamp_ns = int(msg.header.stamp.sec) * _NS + int(msg.header.stamp.nanosec)
        last = self._last_ns
        if last is not None and stamp_ns < last:
            self.restarts += 1
            self.restart()
        elif last is not None and stamp_ns - last > self.max_gap_ns and self.segmenter.active:
            self.interrupted += 1
            self.segmenter.reset()
        if self.t0_ns is None:
            self.t0_ns = stamp_ns
        self._last_ns = stamp_ns
        self.frames += 1
        contact = bool(msg.contact)
        xy = np.array([msg.contact_x, msg.contact_y], dtype=np.float32) if contact else None
        return self.segmenter.update(pressure, contact, xy, (stamp_ns - self.t0_ns) / _NS)

    def flush(self) -> list[TouchGesture]:
        """End the gesture under way as if the finger had lifted (the end of a recording)."""
        return self.segmenter.flush()

    def restart(self) -> None:
        """Drop the gesture under way and start time afresh at the next frame."""
        self.segmenter.restart()
        self.t0_ns = self._last_ns = None

    def stamp_ns(self, t_s: float) -> int:
        """Header time (ns) of segmenter time ``t_s`` (s since :attr:`t0_ns`)."""
        if self.t0_ns is None:
            raise ValueError('no frame has been fed yet: there is no time base')
        return self.t0_ns + round(t_s * _NS)

    def end_stamp_ns(self, gesture: TouchGesture) -> int:
        """Header time (ns) of the gesture's last contact frame: when it ended."""
        return self.stamp_ns(gesture.start_s + gesture.duration_s)
