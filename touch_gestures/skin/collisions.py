"""Collisions told apart from touches, frame by frame: :class:`CollisionDetector`.

Each calibrated frame gives a :class:`ContactState` (contact point in m, force vector summed over
the modules in N, the normal force's rise rate in N/s) and a collision when the normal force reaches
``force_n`` or rises faster than ``rate_n_s`` over the last ``rate_frames`` frames at the skin's
frame rate (frames, not header stamps, which may be nearly equal in a burst), on the frame that
crosses, once per contact. The node drops the gesture under way when a collision fires.

>>> det = CollisionDetector(force_n=5.0, rate_n_s=80.0)
>>> f = np.zeros((36, 3), np.float32)
>>> states = []
>>> for k, fz in enumerate([0.0, 0.5, 1.0, 1.5, 1.5, 6.0, 6.0, 0.0]):
...     f[0, 2] = fz
...     states.append(det.update(fz > 0, (10.0, 20.0), f, k / 150))
>>> [(s.start, s.end, s.collision) for s in states if s is not None][:2]
[(True, False, None), (False, False, None)]
>>> states[5].collision, round(states[5].x_m, 3), states[-1].end
('force,rate', 0.01, True)
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

__all__ = ['COLLISION_FORCE_N', 'COLLISION_RATE_N_S', 'CollisionDetector', 'ContactState']

#: Default normal force (N) that makes a contact a collision: above the hardest finger presses.
COLLISION_FORCE_N = 6.0
#: Default normal force rise rate (N/s) that makes a contact a collision.
COLLISION_RATE_N_S = 120.0


@dataclass(frozen=True, slots=True)
class ContactState:
    """One frame of a contact (or the frame that ends it).

    Attributes:
        start, end: first frame in contact / first frame without (point and force: the last contact's).
        x_m, y_m: contact point in the skin's frame, m (NaN when the frame has none).
        force_n: (3,) float64 force vector, N, summed over the modules.
        force_rate_n_s: rise rate of the normal force, N/s.
        duration_s: since the contact's first frame, s.
        frames: frames since the contact's first frame (0 on the first).
        collision: None, or what crossed on this frame: ``'force'``, ``'rate'`` or ``'force,rate'``.
    """

    start: bool
    end: bool
    x_m: float
    y_m: float
    force_n: np.ndarray
    force_rate_n_s: float
    duration_s: float
    frames: int
    collision: str | None = None


class CollisionDetector:
    """Contacts and collisions from calibrated frames (module doc).

    Args:
        force_n: normal force threshold, N (inf: never on force).
        rate_n_s: normal force rise-rate threshold, N/s (inf: never on rate).
        rate_frames: the rate is the rise over this many frames (>= 1)...
        frame_rate_hz: ...at this frame rate (the skin's 150 Hz).
    """

    def __init__(self, force_n: float = COLLISION_FORCE_N, rate_n_s: float = COLLISION_RATE_N_S,
                 rate_frames: int = 3, frame_rate_hz: float = 150.0) -> None:
        for name, value in (('force_n', force_n), ('rate_n_s', rate_n_s)):
            if math.isnan(value) or value <= 0:
                raise ValueError(f'{name} must be > 0 (inf: never), got {value}')
        if int(rate_frames) < 1 or not (math.isfinite(frame_rate_hz) and frame_rate_hz > 0):
            raise ValueError(f'need rate_frames >= 1 and a frame rate > 0 Hz; got {rate_frames}, {frame_rate_hz}')
        self.force_n, self.rate_n_s = float(force_n), float(rate_n_s)
        self.rate_frames, self.frame_rate_hz = int(rate_frames), float(frame_rate_hz)
        self.collisions = 0
        self._history: deque[float] = deque(maxlen=self.rate_frames + 1)   # fz of the last frames, N
        self._in_contact = False
        self._last: ContactState | None = None

    @property
    def in_collision(self) -> bool:
        """True from a collision's frame to the end of its contact."""
        return self._in_contact and self._fired

    def update(self, contact: bool, point_mm: tuple[float, float] | np.ndarray | None, force: np.ndarray,
               t: float) -> ContactState | None:
        """One calibrated frame: the contact flag, the contact point (mm, NaN/None when none), the
        (36, 3) or (108,) module forces (N; NaN counts as 0) and the time (s). Returns the frame's
        state while in contact and on the frame that ends it, None otherwise."""
        if not contact:
            if not self._in_contact:
                return None
            self._in_contact = False
            self._history.clear()
            last = self._last
            return ContactState(False, True, last.x_m, last.y_m, last.force_n, 0.0, last.duration_s, last.frames + 1)
        f = np.nan_to_num(np.asarray(force, dtype=np.float64).reshape(-1, 3)).sum(axis=0)
        start = not self._in_contact
        if start:
            self._in_contact, self._fired, self._t0, self._frames = True, False, float(t), 0
            self._history.clear()
            self._history.extend([0.0] * self.rate_frames)   # a contact rises from nothing
        else:
            self._frames += 1
        self._history.append(float(f[2]))
        rate = (self._history[-1] - self._history[0]) * self.frame_rate_hz / (len(self._history) - 1)
        xy = np.full(2, np.nan) if point_mm is None else np.asarray(point_mm, dtype=np.float64).reshape(2) / 1000.0
        reasons = [name for name, hit in (('force', f[2] >= self.force_n), ('rate', rate >= self.rate_n_s)) if hit]
        collision = None
        if reasons and not self._fired:
            self._fired, collision = True, ','.join(reasons)
            self.collisions += 1
        self._last = ContactState(start, False, float(xy[0]), float(xy[1]), f, rate, float(t) - self._t0,
                                  self._frames, collision)
        return self._last
