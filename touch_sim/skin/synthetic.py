"""Synthetic traced gestures and random touches (labelled synthetic wherever reported).

:func:`synthetic_traces` draws gesture sets of cirillo2017 (Fig. 7 and 8) and the digits, traced by
simulated performers who differ in size and position (box 18-42 mm anywhere on the skin), slant
and aspect, speed (slowing at corners, sometimes pausing), wobble and tremor, and corner style.
Traces are :class:`~touch_sim.skin.traces.TraceSample` in **mm on the skin** (x along columns, y
along rows) with ``t_ms``, sampled at ``rate_hz``. :func:`random_touches` draws scribbles, wiggles
and dabs that are no gesture at all.
"""

from __future__ import annotations

import math

import numpy as np

from touch_gestures.skin.gesture import ACTIVE_MM
from touch_sim.skin.traces import TraceSample

__all__ = ['DIGITS', 'LETTERS', 'LETTER_SHAPES', 'PAPER_CENTROID_SET', 'PAPER_MAP_SET', 'SHAPES', 'VOCABULARIES',
           'gesture_list', 'random_touches', 'shape_points', 'synthetic_traces']

# Unistroke shapes as waypoint polylines in a unit box, y downward (as on a screen and the skin).
SHAPES: dict[str, list[tuple[float, float]]] = {
    'diagonal_down': [(0, 0), (1, 1)],                  # cirillo2017 Fig. 8 a: upper-left to bottom-right
    'diagonal_up': [(1, 1), (0, 0)],                    # Fig. 8 b: bottom-right to upper-left
    'line_right': [(0, 0.5), (1, 0.5)],                 # Fig. 8 c: horizontal, left to right
    'line_left': [(1, 0.5), (0, 0.5)],                  # Fig. 8 d: horizontal, right to left
    'one': [(0.25, 0.25), (0.6, 0), (0.6, 1)],          # Fig. 7 d / 8 e: the number 1
    'secondary_diagonal': [(1, 0), (0, 1)],             # Fig. 7 b
    'line_down': [(0.5, 0), (0.5, 1)],
    'line_up': [(0.5, 1), (0.5, 0)],
    'two': [(0.05, 0.25), (0.3, 0.02), (0.7, 0.02), (0.95, 0.25), (0.9, 0.45), (0, 1), (1, 1)],  # Fig. 7 e
    'zero': [(0.5, 0), (0.1, 0.2), (0, 0.5), (0.1, 0.8), (0.5, 1), (0.9, 0.8), (1, 0.5), (0.9, 0.2), (0.5, 0)],
    'three': [(0.05, 0.1), (0.5, 0), (0.9, 0.15), (0.85, 0.38), (0.45, 0.5), (0.9, 0.62), (0.95, 0.85),
              (0.5, 1), (0.05, 0.9)],
    'four': [(0.7, 1), (0.7, 0), (0, 0.7), (1, 0.7)],
    'five': [(0.9, 0), (0.15, 0), (0.1, 0.45), (0.6, 0.4), (0.95, 0.65), (0.7, 0.95), (0.05, 0.9)],
    'six': [(0.85, 0), (0.3, 0.2), (0.05, 0.65), (0.3, 1), (0.75, 0.95), (0.85, 0.65), (0.5, 0.45), (0.1, 0.6)],
    'seven': [(0, 0), (1, 0), (0.35, 1)],
    'eight': [(0.5, 0.48), (0.9, 0.2), (0.5, 0), (0.1, 0.2), (0.5, 0.48), (0.95, 0.75), (0.5, 1), (0.05, 0.75),
              (0.5, 0.48)],
    'nine': [(0.9, 0.25), (0.5, 0), (0.1, 0.2), (0.4, 0.5), (0.9, 0.25), (0.9, 1)],
}
#: cirillo2017 Fig. 7 (map-based method; direction does not matter there).
PAPER_MAP_SET = ('diagonal_down', 'secondary_diagonal', 'line_right', 'one', 'two')
#: cirillo2017 Fig. 8 (centroid-based method; a and b, c and d differ only in direction).
PAPER_CENTROID_SET = ('diagonal_down', 'diagonal_up', 'line_right', 'line_left', 'one')
DIGITS = ('zero', 'one', 'two', 'three', 'four', 'five', 'six', 'seven', 'eight', 'nine')
#: Capital letters in one stroke each, as a finger writes them on a small pad: where paper needs a second
#: stroke the finger goes back along the first (E, F, H, T, Y) or leaves it out (A without its bar, as in
#: Graffiti). Synthetic shapes for simulated recordings; a live vocabulary is whatever people trace.
LETTER_SHAPES: dict[str, list[tuple[float, float]]] = {
    'A': [(0, 1), (0.5, 0), (1, 1)],
    'B': [(0, 1), (0, 0), (0.7, 0.05), (0.85, 0.25), (0.6, 0.48), (0, 0.5), (0.8, 0.55), (0.95, 0.8), (0.7, 1),
          (0, 1)],
    'C': [(0.95, 0.15), (0.6, 0), (0.2, 0.1), (0, 0.5), (0.2, 0.9), (0.6, 1), (0.95, 0.85)],
    'D': [(0, 1), (0, 0), (0.6, 0.05), (0.95, 0.4), (0.9, 0.75), (0.55, 1), (0, 1)],
    'E': [(0.95, 0), (0, 0), (0, 0.5), (0.7, 0.5), (0, 0.5), (0, 1), (0.95, 1)],
    'F': [(0.95, 0), (0, 0), (0, 0.5), (0.7, 0.5), (0, 0.5), (0, 1)],
    'G': [(0.95, 0.15), (0.6, 0), (0.2, 0.1), (0, 0.5), (0.2, 0.9), (0.6, 1), (0.95, 0.8), (0.95, 0.55),
          (0.55, 0.55)],
    'H': [(0, 0), (0, 1), (0, 0.5), (1, 0.5), (1, 0), (1, 1)],
    'I': [(0.5, 0), (0.5, 1)],
    'J': [(0.8, 0), (0.8, 0.8), (0.6, 1), (0.25, 1), (0.05, 0.8)],
    'K': [(0, 0), (0, 1), (0, 0.55), (0.85, 0), (0.25, 0.4), (0.9, 1)],
    'L': [(0, 0), (0, 1), (0.9, 1)],
    'M': [(0, 1), (0, 0), (0.5, 0.6), (1, 0), (1, 1)],
    'N': [(0, 1), (0, 0), (1, 1), (1, 0)],
    'O': [(0.5, 0), (0.1, 0.2), (0, 0.5), (0.1, 0.8), (0.5, 1), (0.9, 0.8), (1, 0.5), (0.9, 0.2), (0.5, 0)],
    'P': [(0, 1), (0, 0), (0.7, 0.02), (0.95, 0.25), (0.7, 0.5), (0, 0.5)],
    'Q': [(0.5, 0), (0.1, 0.2), (0, 0.5), (0.1, 0.8), (0.5, 1), (0.9, 0.8), (1, 0.5), (0.9, 0.2), (0.5, 0),
          (0.6, 0.6), (1, 1)],
    'R': [(0, 1), (0, 0), (0.7, 0.02), (0.95, 0.25), (0.7, 0.5), (0, 0.5), (0.95, 1)],
    'S': [(0.95, 0.1), (0.5, 0), (0.05, 0.2), (0.2, 0.45), (0.8, 0.55), (0.95, 0.8), (0.5, 1), (0.05, 0.9)],
    'T': [(0, 0), (1, 0), (0.5, 0), (0.5, 1)],
    'U': [(0, 0), (0, 0.75), (0.25, 1), (0.75, 1), (1, 0.75), (1, 0)],
    'V': [(0, 0), (0.5, 1), (1, 0)],
    'W': [(0, 0), (0.25, 1), (0.5, 0.4), (0.75, 1), (1, 0)],
    'X': [(0, 0), (1, 1), (1, 0), (0, 1)],
    'Y': [(0, 0), (0.5, 0.5), (1, 0), (0.5, 0.5), (0.5, 1)],
    'Z': [(0, 0), (1, 0), (0, 1), (1, 1)],
}
SHAPES.update(LETTER_SHAPES)
LETTERS = tuple(LETTER_SHAPES)
#: Vocabularies named in place of a list of gestures (``--gestures digits``).
VOCABULARIES: dict[str, tuple[str, ...]] = {'digits': DIGITS, 'letters': LETTERS}


def gesture_list(text: str) -> list[str]:
    """Gesture names from a comma-separated list in which a vocabulary's name stands for its gestures.

    >>> gesture_list('digits')[:3]
    ['zero', 'one', 'two']
    >>> gesture_list('line_right, A,B')
    ['line_right', 'A', 'B']
    """
    names: list[str] = []
    for name in (n.strip() for n in text.split(',')):
        names += list(VOCABULARIES.get(name, (name,) if name else ()))
    return names


def shape_points(name: str) -> np.ndarray:
    """(k, 2) float64 waypoints of a shape in a unit box (KeyError lists the names)."""
    try:
        return np.asarray(SHAPES[name], dtype=np.float64)
    except KeyError:
        raise KeyError(f'unknown shape {name!r}; known: {", ".join(SHAPES)}') from None


def _densify(way: np.ndarray, step: float) -> np.ndarray:
    seg = np.hypot(*np.diff(way, axis=0).T)
    cum = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.linspace(0.0, cum[-1], max(2, int(cum[-1] / step) + 1))
    return np.column_stack([np.interp(s, cum, way[:, 0]), np.interp(s, cum, way[:, 1])])


def _round_corners(path: np.ndarray, width: int) -> np.ndarray:
    if width < 2:
        return path
    kernel = np.ones(width) / width
    pad = np.pad(path, ((width, width), (0, 0)), mode='edge')
    out = np.column_stack([np.convolve(pad[:, i], kernel, mode='same') for i in range(2)])[width:-width]
    out[0], out[-1] = path[0], path[-1]
    return out


def _trace(way_mm: np.ndarray, rng: np.random.Generator, style: dict, rate_hz: float) -> tuple[np.ndarray, ...]:
    """Time-stamp a path (mm waypoints) the way the performer ``style`` moves: (x, y, t_ms)."""
    path = _round_corners(_densify(way_mm, 0.25), style['rounding'])
    step = np.hypot(*np.diff(path, axis=0).T)
    # Turning angle per arc step -> slow down at corners (people do; Fitts/2/3 power law in spirit).
    heading = np.unwrap(np.arctan2(np.diff(path[:, 1]), np.diff(path[:, 0])))
    turn = np.abs(np.gradient(heading)) if len(heading) > 1 else np.zeros_like(heading)
    turn = np.convolve(turn, np.ones(9) / 9, mode='same')
    speed = style['speed'] * rng.uniform(0.7, 1.4) / (1.0 + style['corner_slowing'] * 40.0 * turn)
    dt = np.where(step > 0, step / np.maximum(speed, 1e-3), 0.0)
    t = np.concatenate([[0.0], np.cumsum(dt)])
    if rng.random() < style['pause_prob'] and len(t) > 10:  # a hesitation mid-stroke
        k = int(rng.integers(len(t) // 4, 3 * len(t) // 4))
        t[k:] += rng.uniform(0.1, 0.35)
    # Shake: a slow wobble across the path and a tremor, in mm.
    normal = np.column_stack([-np.gradient(path[:, 1]), np.gradient(path[:, 0])])
    normal /= np.maximum(np.hypot(*normal.T), 1e-9)[:, None]
    wobble = style['wobble'] * np.sin(2 * np.pi * style['wobble_hz'] * t + rng.uniform(0, 2 * np.pi))
    path = path + normal * wobble[:, None] + rng.normal(0.0, style['tremor'], path.shape)
    ts = np.arange(0.0, t[-1] + 1e-9, 1.0 / rate_hz)
    if len(ts) < 2:
        ts = np.array([0.0, t[-1]])
    x, y = np.interp(ts, t, path[:, 0]), np.interp(ts, t, path[:, 1])
    return x, y, ts * 1000.0


def _performer_style(rng: np.random.Generator, slant_deg: float = 6.0) -> dict:
    return {
        'size': rng.uniform(18.0, 42.0), 'slant': rng.normal(0.0, math.radians(slant_deg)),
        'aspect': rng.normal(1.0, 0.1),
        'speed': rng.uniform(40.0, 160.0), 'corner_slowing': rng.uniform(0.0, 1.0), 'pause_prob': rng.uniform(0, 0.2),
        'wobble': rng.uniform(0.0, 1.0), 'wobble_hz': rng.uniform(1.5, 5.0), 'tremor': rng.uniform(0.0, 0.25),
        'rounding': int(rng.integers(0, 12)),
    }


def _place(unit: np.ndarray, rng: np.random.Generator, style: dict, margin_mm: float) -> np.ndarray:
    """Unit-box waypoints -> mm on the skin: performer size, slant, aspect, a random position."""
    pts = unit - 0.5
    pts = pts * np.array([style['aspect'] * rng.normal(1.0, 0.05), 1.0])
    angle = style['slant'] + rng.normal(0.0, math.radians(3))
    c, s = math.cos(angle), math.sin(angle)
    pts = pts @ np.array([[c, s], [-s, c]])
    size = style['size'] * rng.uniform(0.85, 1.15)
    span = max(float(np.ptp(pts, axis=0).max()), 1e-9)
    pts = pts * (min(size, ACTIVE_MM - 2 * margin_mm) / span)
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    room_lo = margin_mm - lo
    room_hi = ACTIVE_MM - margin_mm - hi
    offset = np.array([rng.uniform(room_lo[i], max(room_lo[i], room_hi[i])) for i in range(2)])
    return pts + offset


def synthetic_traces(shapes: tuple[str, ...] | list[str] = PAPER_CENTROID_SET, performers: int = 5,
                     repetitions: int = 10, seed: int = 0, rate_hz: float = 100.0, margin_mm: float = 4.0,
                     shake: float = 1.0, speed: float = 1.0, pauses: float = 1.0, slant_deg: float = 6.0
                     ) -> list[TraceSample]:
    """Synthetic traces of ``shapes`` by ``performers`` simulated people, ``repetitions`` each.

    Args:
        shapes: names from :data:`SHAPES`.
        performers: simulated people; each is a subject ``'synthetic<k>'`` with a style of its own.
        repetitions: samples per performer and shape.
        seed: everything is drawn from it.
        rate_hz: sampling rate of the logged points.
        margin_mm: the gesture stays this far from the edge of the 47 mm active area.
        shake: multiplies the wobble and tremor (2 = twice as shaky as the default people).
        speed: multiplies every performer's speed.
        pauses: multiplies the chance of a hesitation mid-stroke (a performer's is 0-20 %).
        slant_deg: standard deviation of a performer's slant, degrees.

    Returns: samples with x, y in mm on the skin (see the module doc), variant ``'synthetic'``.
    """
    if performers < 1 or repetitions < 1:
        raise ValueError(f'need performers >= 1 and repetitions >= 1, got {performers}, {repetitions}')
    units = {name: shape_points(name) for name in shapes}
    rng = np.random.default_rng(seed)
    out = []
    for p in range(performers):
        style = _performer_style(rng, slant_deg)
        style['pause_prob'] = min(1.0, style['pause_prob'] * pauses)
        style['wobble'] *= shake
        style['tremor'] *= shake
        style['speed'] *= speed
        for name, unit in units.items():
            for r in range(repetitions):
                x, y, t_ms = _trace(_place(unit, rng, style, margin_mm), rng, style, rate_hz)
                out.append(TraceSample(f'synthetic{p}', 'synthetic', name, str(r), x=x, y=y, t_ms=t_ms,
                                       stroke=np.zeros(len(x), dtype=np.int32)))
    return out


def random_touches(count: int = 100, seed: int = 0, rate_hz: float = 100.0, margin_mm: float = 4.0
                   ) -> list[TraceSample]:
    """Touches that are no gesture (synthetic): random smooth scribbles, zigzags and dabs, in mm.

    A third each: a smooth random curve (a few random Fourier terms), a zigzag of 3-8 random
    corners, and a short dab that wanders a few mm (a brush of the hand). Durations 0.2-3 s.
    """
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        kind = i % 3
        size = rng.uniform(10.0, ACTIVE_MM - 2 * margin_mm)
        if kind == 0:
            u = np.linspace(0, 1, 200)
            x = sum(rng.normal(0, 1 / (k + 1)) * np.sin(np.pi * (k + 1) * u + rng.uniform(0, 6)) for k in range(4))
            y = sum(rng.normal(0, 1 / (k + 1)) * np.sin(np.pi * (k + 1) * u + rng.uniform(0, 6)) for k in range(4))
            way = np.column_stack([x, y])
        elif kind == 1:
            way = rng.uniform(0, 1, (int(rng.integers(4, 9)), 2))
        else:
            way = np.cumsum(rng.normal(0, 1, (6, 2)), axis=0)
            size = rng.uniform(2.0, 6.0)
        span = max(float(np.ptp(way, axis=0).max()), 1e-9)
        way = (way - way.min(axis=0)) * (size / span)
        offset = rng.uniform(margin_mm, ACTIVE_MM - margin_mm - np.maximum(way.max(axis=0), 0) + 1e-9)
        duration = rng.uniform(0.2, 3.0)
        path = _densify(way + offset, 0.25)
        t = np.linspace(0.0, duration, len(path))
        ts = np.arange(0.0, duration + 1e-9, 1.0 / rate_hz)
        x, y = np.interp(ts, t, path[:, 0]), np.interp(ts, t, path[:, 1])
        out.append(TraceSample('random', 'synthetic', 'random', str(i), x=x, y=y, t_ms=ts * 1000.0,
                               stroke=np.zeros(len(x), dtype=np.int32)))
    return out
