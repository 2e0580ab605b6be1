"""Sensor-level touch (knight2009 V.A, V.C): a ring buffer of the last N cycles and the active set.

The paper keeps, per sensor, "a buffer of sensor values reflecting the last twenty cycles, an
activation state boolean that indicates whether the signal is over 30% on, and a location. Buffer
size and activation thresholds are configurable" (V.A). Here one :class:`LevelBuffer` holds all 64
wire channels at once as a float32 array, so features are computed for every sensor in one
vectorised pass; :func:`active_sensors` names the active ones through the body map.

>>> buf = LevelBuffer(buffer_len=3)
>>> for value in (0.1, 0.5, 0.9, 0.2):
...     buf.update(np.full(64, value, dtype=np.float32))
>>> buf.window()[:, 0].tolist()   # oldest first, the first value has left the ring
[0.5, 0.8999999761581421, 0.20000000298023224]
>>> bool(buf.active()[0]), buf.count
(False, 4)
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

__all__ = ['ACTIVATION_THRESHOLD', 'BUFFER_LEN', 'N_CHANNELS', 'ActiveSensor', 'BodyMapLike', 'LevelBuffer',
           'active_sensors']

#: Wire channels of the bear: 8 Midplanes x 8 inputs (knight2009 IV.A).
N_CHANNELS = 64
#: Cycles kept per sensor: "a buffer of sensor values reflecting the last twenty cycles" (knight2009 V.A).
BUFFER_LEN = 20
#: A sensor is active when "the signal is over 30% on" (knight2009 V.A); levels are in [0, 1].
ACTIVATION_THRESHOLD = 0.3


class BodySensorLike(Protocol):
    channel: int
    name: str
    location: str
    region: str
    side: str


class BodyMapLike(Protocol):
    """What the recognisers need of ``touch_driver.bear.body_map.BodyMap``."""

    sensors: tuple[BodySensorLike, ...]

    def by_channel(self, channel: int) -> BodySensorLike | None: ...

    def fitted_mask(self) -> np.ndarray: ...


@dataclass(frozen=True, slots=True)
class ActiveSensor:
    """One active sensor this cycle, as published on /touch/sensor_level (msg/SensorState.msg)."""

    channel: int
    name: str
    location: str
    region: str
    level: float


class LevelBuffer:
    """The last ``buffer_len`` calibrated levels of all channels, oldest first.

    Memory is fixed: a (2 * buffer_len, n_channels) float32 array in which every sample is
    written twice (at ``i`` and ``i + buffer_len``), so the chronological window is always one
    contiguous slice and :meth:`window` costs no copy.

    Bad input is counted and skipped, never raised on: a non-finite level (NaN, inf) is stored as
    0.0 (no touch) and counted per channel in :attr:`invalid_counts`; levels outside [0, 1] are
    clipped. Channels flagged faulty (dead or stuck, see :meth:`update`) are stored as 0.0 so a
    stuck-at-full-scale sensor does not look like an endless hold.

    Args:
        buffer_len: cycles kept, N >= 1 (knight2009 V.A: 20).
        n_channels: channels per cycle (64 wire channels).
        threshold: activation threshold on the level, in [0, 1] (knight2009 V.A: 0.3).
    """

    def __init__(self, buffer_len: int = BUFFER_LEN, n_channels: int = N_CHANNELS,
                 threshold: float = ACTIVATION_THRESHOLD) -> None:
        if not isinstance(buffer_len, (int, np.integer)) or buffer_len < 1:
            raise ValueError(f'buffer_len must be an integer >= 1 (cycles); got {buffer_len!r}')
        if not isinstance(n_channels, (int, np.integer)) or n_channels < 1:
            raise ValueError(f'n_channels must be an integer >= 1; got {n_channels!r}')
        if not 0.0 < float(threshold) <= 1.0:
            raise ValueError(f'threshold must be in (0, 1] (a level fraction, the paper uses 0.3); got {threshold!r}')
        self.buffer_len = int(buffer_len)
        self.n_channels = int(n_channels)
        self.threshold = float(threshold)
        self._ring = np.zeros((2 * self.buffer_len, self.n_channels), dtype=np.float32)
        self.invalid_counts = np.zeros(self.n_channels, dtype=np.int64)
        self.count = 0  # cycles pushed since the last reset

    def reset(self) -> None:
        """Forget every sample (after a reconnect); keep the invalid-input counters."""
        self._ring.fill(0.0)
        self.count = 0

    def update(self, levels: np.ndarray, faulty: np.ndarray | None = None) -> None:
        """Add one cycle.

        Args:
            levels: (n_channels,) calibrated levels in [0, 1], any float dtype.
            faulty: optional (n_channels,) bool, channels to treat as untouched this cycle (the
                calibrator's dead/stuck flags).

        Raises:
            ValueError: when ``levels`` has the wrong shape (a programming error, not bad data).
        """
        row = np.asarray(levels, dtype=np.float32)
        if row.shape != (self.n_channels,):
            raise ValueError(f'levels must have shape ({self.n_channels},); got {row.shape}')
        bad = ~np.isfinite(row)
        if bad.any():
            self.invalid_counts += bad
            row = np.where(bad, np.float32(0.0), row)
        row = np.clip(row, 0.0, 1.0)
        if faulty is not None:
            row = np.where(faulty, np.float32(0.0), row)
        i = self.count % self.buffer_len
        self._ring[i] = row
        self._ring[i + self.buffer_len] = row
        self.count += 1

    @property
    def filled(self) -> int:
        """Cycles held, ``min(count, buffer_len)``."""
        return min(self.count, self.buffer_len)

    def window(self) -> np.ndarray:
        """(filled, n_channels) float32 view of the held cycles, oldest first (no copy; do not modify)."""
        n = self.filled
        if n == 0:
            return self._ring[:0]
        start = self.count % self.buffer_len  # oldest sample once the ring is full
        if self.count < self.buffer_len:
            start = 0
        return self._ring[start:start + n]

    def latest(self) -> np.ndarray:
        """(n_channels,) float32 levels of the last cycle (zeros before the first update)."""
        if self.count == 0:
            return np.zeros(self.n_channels, dtype=np.float32)
        return self._ring[(self.count - 1) % self.buffer_len]

    def active(self) -> np.ndarray:
        """(n_channels,) bool, latest level >= threshold (knight2009 V.A activation state)."""
        return self.latest() >= self.threshold


def active_sensors(levels: np.ndarray, body_map: BodyMapLike, threshold: float = ACTIVATION_THRESHOLD,
                   channels: Iterable[int] | None = None) -> list[ActiveSensor]:
    """The fitted sensors whose level is >= ``threshold``, in channel order, named by the body map.

    Args:
        levels: (64,) levels in [0, 1]; NaN counts as inactive.
        body_map: a ``BodyMap``; unfitted channels are never reported.
        threshold: activation threshold (knight2009 V.A: 0.3).
        channels: restrict to these channels (default: all).
    """
    levels = np.asarray(levels, dtype=np.float32)
    with np.errstate(invalid='ignore'):
        hot = np.flatnonzero(levels >= threshold)
    wanted = None if channels is None else set(int(c) for c in channels)
    out = []
    for ch in hot:
        ch = int(ch)
        if wanted is not None and ch not in wanted:
            continue
        sensor = body_map.by_channel(ch)
        if sensor is None:
            continue
        out.append(ActiveSensor(ch, sensor.name, sensor.location, sensor.region, float(levels[ch])))
    return out
