"""What one touch on the skin leaves behind: :class:`TouchGesture`, and the skin's geometry.

The optoelectronic skin (cirillo2017 2.2) is a 12x12 taxel map over an active area of
about 47 x 47 mm. Maps are row-major ``(row, col)``; the contact point is in mm from
the corner of taxel (0, 0), ``x`` along the columns and ``y`` along the rows, so taxel
``(r, c)`` is centred on ``((c + 0.5) * pitch, (r + 0.5) * pitch)``.

:func:`ideal_frame` renders the frame a perfect sensor would give for a finger at a
point; the evaluation uses it for the "before sensor" figures, where the trajectory is
the true finger path and the map a disc under it.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ['ACTIVE_MM', 'GRID', 'PITCH_MM', 'TouchGesture', 'ideal_frame', 'taxel_centres_mm']

#: Taxels per side of the map (cirillo2017 2.2: 36 modules of 2x2 taxels = 12x12).
GRID = 12
#: Side of the active area, mm (cirillo2017 2.2: "about 47 x 47 mm^2").
ACTIVE_MM = 47.0
#: Taxel pitch, mm.
PITCH_MM = ACTIVE_MM / GRID


def taxel_centres_mm(grid: int = GRID, active_mm: float = ACTIVE_MM) -> tuple[np.ndarray, np.ndarray]:
    """``(x, y)`` centres of the taxels, each (grid, grid) float32 mm, indexed ``[row, col]``.

    >>> x, y = taxel_centres_mm(2, 4.0)
    >>> x.tolist(), y.tolist()
    ([[1.0, 3.0], [1.0, 3.0]], [[1.0, 1.0], [3.0, 3.0]])
    """
    centres = (np.arange(grid, dtype=np.float32) + 0.5) * np.float32(active_mm / grid)
    return np.meshgrid(centres, centres)


_CENTRES = taxel_centres_mm()


def ideal_frame(point_mm: np.ndarray | None, radius_mm: float = 4.0) -> np.ndarray:
    """The (12, 12) float32 pressure map of a perfect sensor under a fingertip.

    Pressure is 1 at the contact point and falls linearly to 0 at ``radius_mm`` (a
    fingertip pad is about 8 mm across); ``None`` or a NaN point gives an empty map. The
    taxel nearest to the point is always at least 0.5, so a contact is never lost between
    taxels.

    >>> m = ideal_frame(np.array([1.9, 1.9]))
    >>> bool(m[0, 0] > 0.9), bool(m[5, 5] == 0)
    (True, True)
    """
    out = np.zeros((GRID, GRID), dtype=np.float32)
    if point_mm is None or not np.all(np.isfinite(point_mm)):
        return out
    dist = np.hypot(_CENTRES[0] - np.float32(point_mm[0]), _CENTRES[1] - np.float32(point_mm[1]))
    np.maximum(out, 1.0 - dist / np.float32(radius_mm), out=out)
    r, c = np.unravel_index(int(np.argmin(dist)), dist.shape)
    out[r, c] = max(out[r, c], 0.5)
    return out


@dataclass(eq=False)
class TouchGesture:
    """One gesture: from the first contact to the end of the last contact (cirillo2017 Fig. 5).

    Attributes:
        binary_map: (12, 12) bool, the thresholded frames OR-accumulated over the gesture
            (cirillo2017 3.2.1, Algorithm 1 line 4).
        peak_map: (12, 12) float32, the highest pressure of each taxel during the gesture
            (unitless, 1 = full scale).
        trajectory: (n, 2) float32, the contact points in mm (x along columns, y along rows),
            frames without a contact point left out (cirillo2017 3.2.2, g_x and g_y).
        times: (n,) float64, seconds, the time of each trajectory point.
        stroke: (n,) int16, the stroke each point belongs to (strokes are contacts joined
            across a lift shorter than the segmenter's hysteresis).
        frames: number of frames from the first to the last contact.
        start_s: time of the first contact frame, s.
        duration_s: time from the first to the last contact frame, s.
        strokes: number of strokes joined into the gesture.
        multi_contact: two or more separate blobs were seen at once (two fingers).
        truncated: the touch lasted longer than the segmenter's limit and was cut.
    """

    binary_map: np.ndarray
    peak_map: np.ndarray
    trajectory: np.ndarray
    times: np.ndarray
    stroke: np.ndarray = field(default=None)  # type: ignore[assignment]
    frames: int = 0
    start_s: float = 0.0
    duration_s: float = 0.0
    strokes: int = 1
    multi_contact: bool = False
    truncated: bool = False

    def __post_init__(self) -> None:
        self.binary_map = np.asarray(self.binary_map, dtype=bool)
        self.peak_map = np.asarray(self.peak_map, dtype=np.float32)
        self.trajectory = np.asarray(self.trajectory, dtype=np.float32).reshape(-1, 2)
        self.times = np.asarray(self.times, dtype=np.float64).reshape(-1)
        if self.binary_map.shape != (GRID, GRID) or self.peak_map.shape != (GRID, GRID):
            raise ValueError(f'binary_map and peak_map must be ({GRID}, {GRID}); got {self.binary_map.shape} '
                             f'and {self.peak_map.shape}')
        if len(self.times) != len(self.trajectory):
            raise ValueError(f'times has {len(self.times)} entries for {len(self.trajectory)} trajectory points')
        if self.stroke is None:
            self.stroke = np.zeros(len(self.trajectory), dtype=np.int16)
        self.stroke = np.asarray(self.stroke, dtype=np.int16).reshape(-1)
        if len(self.stroke) != len(self.trajectory):
            raise ValueError(f'stroke has {len(self.stroke)} entries for {len(self.trajectory)} trajectory points')

    @classmethod
    def from_trajectory(cls, points_mm: np.ndarray, times_s: np.ndarray | None = None,
                        radius_mm: float = 4.0, threshold: float = 0.3) -> TouchGesture:
        """A gesture as a perfect sensor would see it (map rendered by :func:`ideal_frame`).

        Args:
            points_mm: (n, 2) contact points, mm.
            times_s: (n,) seconds; default 150 Hz from 0.
            radius_mm: fingertip radius for the maps.
            threshold: pressure above which a taxel enters the binary map.
        """
        pts = np.asarray(points_mm, dtype=np.float32).reshape(-1, 2)
        times = np.arange(len(pts)) / 150.0 if times_s is None else np.asarray(times_s, dtype=np.float64)
        peak = np.zeros((GRID, GRID), dtype=np.float32)
        for p in pts:
            np.maximum(peak, ideal_frame(p, radius_mm), out=peak)
        return cls(binary_map=peak >= threshold, peak_map=peak, trajectory=pts, times=times, frames=len(pts),
                   start_s=float(times[0]) if len(times) else 0.0,
                   duration_s=float(times[-1] - times[0]) if len(times) else 0.0)

    @property
    def contact_s(self) -> float:
        """Time in contact, s: each stroke's first to last point, summed (the lifts between strokes
        left out; :attr:`duration_s` for a gesture of one stroke)."""
        times, stroke = self.times, self.stroke
        if len(times) == 0:
            return 0.0
        # The span less each lift between strokes (a stroke's last point to the next one's first).
        lifts = np.flatnonzero(stroke[1:] != stroke[:-1])
        span = float(times[-1] - times[0])
        if not len(lifts):
            return span
        return max(0.0, span - float((times[lifts + 1] - times[lifts]).sum()))   # >= 0 whatever the rounding

    def __repr__(self) -> str:
        flags = ''.join(f', {name}' for name in ('multi_contact', 'truncated') if getattr(self, name))
        return (f'TouchGesture(points={len(self.trajectory)}, frames={self.frames}, duration_s={self.duration_s:.3f}, '
                f'taxels={int(self.binary_map.sum())}, strokes={self.strokes}{flags})')
