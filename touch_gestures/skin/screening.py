"""Which segmented touches may become a command at all, before any recogniser looks at them.

The recognisers normalise position and size, so a resting finger's jitter becomes a random shape
of full size. :func:`screen_gesture` turns away touches that are no traced gesture, with a reason:

- ``'multi_contact'``: two fingers at once;
- ``'truncated'``: longer than the segmenter's limit (a resting hand);
- ``'too_few_points'``: fewer trajectory points than a shape needs;
- ``'too_small'``: the bounding box's longer side is below ``min_extent_mm`` (default two taxel
  pitches: the smallest extent the 12 x 12 map resolves as a stroke).

>>> import numpy as np
>>> from touch_gestures.skin.gesture import TouchGesture
>>> screen_gesture(TouchGesture.from_trajectory(np.array([[5.0, 20.0], [40.0, 20.0]])))
>>> screen_gesture(TouchGesture.from_trajectory(np.array([[20.0, 20.0], [21.0, 20.5]])))
'too_small'
"""

from __future__ import annotations

import math

import numpy as np

from .gesture import PITCH_MM, TouchGesture

__all__ = ['MIN_EXTENT_MM', 'MIN_POINTS', 'SCREEN_REASONS', 'gesture_extent_mm', 'screen_gesture']

#: Smallest bounding-box side (mm) of a traced gesture: two taxel pitches (module doc).
MIN_EXTENT_MM = 2 * PITCH_MM
#: Fewest trajectory points a shape needs (a start and an end).
MIN_POINTS = 2
#: Every reason :func:`screen_gesture` may give, in the order it checks them.
SCREEN_REASONS = ('multi_contact', 'truncated', 'too_few_points', 'too_small')


def gesture_extent_mm(gesture: TouchGesture) -> float:
    """Longer side of the bounding box of the gesture's trajectory, mm (0 without points).

    >>> gesture_extent_mm(TouchGesture.from_trajectory(np.array([[5.0, 20.0], [40.0, 30.0]])))
    35.0
    """
    traj = gesture.trajectory
    if len(traj) == 0:
        return 0.0
    return float(np.ptp(traj, axis=0).max())


def screen_gesture(gesture: TouchGesture, min_extent_mm: float = MIN_EXTENT_MM,
                   min_points: int = MIN_POINTS) -> str | None:
    """Why ``gesture`` cannot be a command (one of :data:`SCREEN_REASONS`), or None when it may be.

    Raises:
        ValueError: ``min_extent_mm`` is not a finite number >= 0 or ``min_points`` < 1.
    """
    if not (math.isfinite(min_extent_mm) and min_extent_mm >= 0) or min_points < 1:
        raise ValueError(f'need min_extent_mm >= 0 (mm) and min_points >= 1; got {min_extent_mm}, {min_points}')
    if gesture.multi_contact:
        return 'multi_contact'
    if gesture.truncated:
        return 'truncated'
    if len(gesture.trajectory) < min_points:
        return 'too_few_points'
    if gesture_extent_mm(gesture) < min_extent_mm:
        return 'too_small'
    return None
