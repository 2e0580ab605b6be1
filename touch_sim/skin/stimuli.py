"""Scripted skin stimuli for tests and demos: no touch, a static press, a straight line, a timeline.

Every stimulus implements :class:`~touch_sim.skin.contact.SkinStimulus` (``contacts(t)``) and has
``duration_s``. Forces ramp linearly over ``ramp_s`` before the touch starts and after it ends
(touch-down and lift), with the finger still at its first and last point meanwhile.

A timeline is also a YAML scene, read with :func:`load_scene`::

    skin_scene: 1                     # format version
    duration_s: 6.0                   # optional; default: end of the last event + 0.5 s
    events:
      - press: {x_mm: 23.5, y_mm: 23.5, force_n: 2.0, at_s: 1.0, for_s: 2.0}
      - line: {from_mm: [6, 6], to_mm: [41, 41], at_s: 3.5, for_s: 1.0, force_n: 1.5}
      - trace: {points: [[0, 0, 0], [10, 0, 200], [10, 10, 400]], at_s: 5.0}

or a generated scene: ``generator`` names a scene generator registered in the
``social_touch.scene_generators`` entry point group, as for the bear and patch scenes of
:mod:`touch_sim.scenes`, a function that returns the stimulus, called with ``options``::

    skin_scene: 1
    generator: skin_people
    options: {n_people: 2, seed: 7}

``at_s`` is when full force is reached (the touch-down ramp comes before it) and ``for_s`` how
long it lasts. ``press`` and ``line`` also take ``radius_mm`` and ``ramp_s``; ``trace`` takes
``force_n``, ``radius_mm``, ``ramp_s``, ``margin_mm``, ``time_scale`` and ``stroke`` (one id per
point) as :meth:`~touch_sim.skin.traces.TraceStimulus.from_points` does (points are x, y in
screen pixels and t in ms; the bounding box is scaled onto the active area).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from touch_graph.yamlconf import YamlDict, check_keys, load_yaml, typed
from touch_sim.scenes import generated_stimulus
from touch_sim.skin.contact import Contact, SkinStimulus
from touch_sim.skin.traces import TraceStimulus

__all__ = ['SCENE_FORMAT_VERSION', 'LineStroke', 'NoTouch', 'StaticPress', 'Timeline', 'envelope', 'load_scene',
           'scene_from_mapping']

SCENE_FORMAT_VERSION = 1
_TAIL_S = 0.5


def envelope(t: float, t_on: float, t_off: float, ramp_s: float) -> float:
    """Force factor in [0, 1]: ramps up over ``ramp_s`` ending at ``t_on``, down over ``ramp_s`` from ``t_off``.

    >>> [envelope(t, 1.0, 2.0, 0.5) for t in (0.5, 0.75, 1.5, 2.25, 2.5)]
    [0.0, 0.5, 1.0, 0.5, 0.0]
    """
    if t < t_on - ramp_s or t > t_off + ramp_s:
        return 0.0
    if t < t_on:
        return (t - (t_on - ramp_s)) / ramp_s
    if t > t_off:
        return ((t_off + ramp_s) - t) / ramp_s
    return 1.0


def _check_finite(**values: float) -> None:
    for name, value in values.items():
        if not isinstance(value, (int, float)) or not math.isfinite(value):
            raise ValueError(f'{name} must be a finite number, got {value!r}')


class NoTouch:
    """Nobody touches the skin."""

    def __init__(self, duration_s: float = 1.0) -> None:
        self.duration_s = float(duration_s)

    def contacts(self, t: float) -> list[Contact]:
        return []


@dataclass(frozen=True)
class StaticPress:
    """A finger pressing still at (x_mm, y_mm) with ``force_n`` from ``at_s`` for ``for_s`` seconds."""

    x_mm: float
    y_mm: float
    force_n: float
    at_s: float = 0.5
    for_s: float = 1.0
    radius_mm: float = 4.0
    ramp_s: float = 0.05

    def __post_init__(self) -> None:
        _check_finite(x_mm=self.x_mm, y_mm=self.y_mm, force_n=self.force_n, at_s=self.at_s, for_s=self.for_s,
                      radius_mm=self.radius_mm, ramp_s=self.ramp_s)
        if self.force_n < 0 or self.for_s < 0 or self.radius_mm < 0 or self.ramp_s <= 0 or self.at_s < self.ramp_s:
            raise ValueError(f'a press needs force_n, for_s, radius_mm >= 0, ramp_s > 0 and at_s >= ramp_s; got {self}')

    @property
    def duration_s(self) -> float:
        return self.at_s + self.for_s + self.ramp_s

    def contacts(self, t: float) -> list[Contact]:
        k = envelope(t, self.at_s, self.at_s + self.for_s, self.ramp_s)
        return [Contact(self.x_mm, self.y_mm, self.force_n * k, self.radius_mm)] if k > 0 else []


@dataclass(frozen=True)
class LineStroke:
    """A finger tracing a straight line from ``from_mm`` to ``to_mm`` at constant speed over ``for_s``."""

    from_mm: tuple[float, float]
    to_mm: tuple[float, float]
    force_n: float
    at_s: float = 0.5
    for_s: float = 1.0
    radius_mm: float = 4.0
    ramp_s: float = 0.05

    def __post_init__(self) -> None:
        _check_finite(x0=self.from_mm[0], y0=self.from_mm[1], x1=self.to_mm[0], y1=self.to_mm[1],
                      force_n=self.force_n, at_s=self.at_s, for_s=self.for_s, radius_mm=self.radius_mm,
                      ramp_s=self.ramp_s)
        if self.force_n < 0 or self.for_s <= 0 or self.radius_mm < 0 or self.ramp_s <= 0 or self.at_s < self.ramp_s:
            raise ValueError(f'a line needs force_n, radius_mm >= 0, for_s > 0, ramp_s > 0 and at_s >= ramp_s; '
                             f'got {self}')

    @property
    def duration_s(self) -> float:
        return self.at_s + self.for_s + self.ramp_s

    def position(self, t: float) -> tuple[float, float]:
        """Finger position at ``t``, mm (held at the ends outside the stroke)."""
        a = min(max((t - self.at_s) / self.for_s, 0.0), 1.0)
        return (self.from_mm[0] + a * (self.to_mm[0] - self.from_mm[0]),
                self.from_mm[1] + a * (self.to_mm[1] - self.from_mm[1]))

    def contacts(self, t: float) -> list[Contact]:
        k = envelope(t, self.at_s, self.at_s + self.for_s, self.ramp_s)
        if k <= 0:
            return []
        x, y = self.position(t)
        moving = self.at_s <= t <= self.at_s + self.for_s
        vx = (self.to_mm[0] - self.from_mm[0]) / self.for_s if moving else 0.0
        vy = (self.to_mm[1] - self.from_mm[1]) / self.for_s if moving else 0.0
        return [Contact(x, y, self.force_n * k, self.radius_mm, vx, vy)]


class Timeline:
    """Several stimuli at once: the contacts at ``t`` are those of every part (e.g. two fingers)."""

    def __init__(self, parts: Sequence[SkinStimulus], duration_s: float | None = None) -> None:
        for part in parts:
            if not callable(getattr(part, 'contacts', None)):
                raise ValueError(f'timeline parts must have contacts(t); got {part!r}')
        self.parts = list(parts)
        ends = [float(getattr(p, 'duration_s', 0.0)) for p in self.parts]
        self.duration_s = float(duration_s) if duration_s is not None else max(ends, default=0.0) + _TAIL_S

    def contacts(self, t: float) -> list[Contact]:
        out: list[Contact] = []
        for part in self.parts:
            out.extend(part.contacts(t))
        return out


# ---------------------------------------------------------------------- YAML scenes
_EVENT_KEYS = {
    'press': (('x_mm', 'y_mm', 'force_n'), ('at_s', 'for_s', 'radius_mm', 'ramp_s')),
    'line': (('from_mm', 'to_mm', 'force_n'), ('at_s', 'for_s', 'radius_mm', 'ramp_s')),
    'trace': (('points',), ('at_s', 'force_n', 'radius_mm', 'ramp_s', 'margin_mm', 'time_scale', 'stroke')),
}


def _pair(node: YamlDict, key: str, what: str) -> tuple[float, float]:
    value = node[key]
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise node.error(f"'{key}' in {what} must be [x_mm, y_mm]; got {value!r}", key)
    return float(value[0]), float(value[1])


def _event(node: Any, where: Any, index: int) -> SkinStimulus:
    if not isinstance(node, dict) or len(node) != 1:
        raise where.error(f'each event is a mapping with one key ({", ".join(_EVENT_KEYS)}); got {node!r}', index)
    (kind, params), = node.items()
    check_keys(node, optional=tuple(_EVENT_KEYS), what=f'event {index}')
    if not isinstance(params, dict):
        raise node.error(f'{kind} event {index} needs a mapping of parameters, e.g. {{x_mm: 10, ...}}; '
                         f'got {params!r}', kind)
    required, optional = _EVENT_KEYS[kind]
    what = f'{kind} event {index}'
    check_keys(params, required=required, optional=optional, what=what)
    kw: dict[str, Any] = {}
    for key in required + optional:
        if key not in params or key in ('from_mm', 'to_mm', 'points', 'stroke'):
            continue
        kw[key] = typed(params, key, float, what)
    try:
        if kind == 'press':
            return StaticPress(**kw)
        if kind == 'line':
            return LineStroke(_pair(params, 'from_mm', what), _pair(params, 'to_mm', what), **kw)
        points = np.asarray(params['points'], dtype=np.float64)
        if points.ndim != 2 or points.shape[1] != 3:
            raise ValueError(f'points must be a list of [x, y, t_ms]; got shape {points.shape}')
        stroke = params.get('stroke')
        # at_s is when the first point is reached, as for press and line: the ramp comes before it.
        at_s = kw.pop('at_s', 0.55)
        lead_in = at_s - kw.get('ramp_s', 0.05)
        if lead_in < 0:
            raise ValueError(f'at_s={at_s} leaves no time for the touch-down ramp; make it >= ramp_s')
        return TraceStimulus.from_points(points[:, 0], points[:, 1], points[:, 2], stroke=stroke,
                                         lead_in_s=lead_in, **kw)
    except (ValueError, TypeError) as err:
        raise params.error(f'{what}: {err}') from err


def scene_from_mapping(doc: Any) -> SkinStimulus:
    """A :class:`Timeline` (or a generated stimulus) from a parsed YAML scene (see the module doc);
    ConfigError names the line."""
    check_keys(doc, required=('skin_scene',), optional=('events', 'duration_s', 'description', 'generator', 'options'),
               what='skin scene')
    version = typed(doc, 'skin_scene', int, 'skin scene')
    if version != SCENE_FORMAT_VERSION:
        raise doc.error(f'skin_scene format {version} is not supported; expected {SCENE_FORMAT_VERSION}', 'skin_scene')
    if 'generator' in doc:
        scripted = [k for k in ('events', 'duration_s') if k in doc]
        if scripted:
            raise doc.error(f"a scene has a generator or events, not both: remove '{scripted[0]}'", scripted[0])
        return generated_stimulus(doc, 'skin scene', lambda s: callable(getattr(s, 'contacts', None)),
                                  'skin_people')
    if 'options' in doc:
        raise doc.error("'options' are the keyword arguments of a 'generator'; this scene has none", 'options')
    if 'events' not in doc:
        raise doc.error("a skin scene needs 'events: [...]' or 'generator: NAME' (a registered scene generator)")
    events = doc['events']
    if not isinstance(events, list):
        raise doc.error(f"'events' must be a list of events; got {type(events).__name__}", 'events')
    duration = typed(doc, 'duration_s', float, 'skin scene', None)
    if duration is not None and not duration > 0:
        raise doc.error(f'duration_s must be > 0, got {duration}', 'duration_s')
    return Timeline([_event(node, events, i) for i, node in enumerate(events)], duration)


def load_scene(path: str | Path) -> SkinStimulus:
    """Read a YAML skin scene file into a :class:`Timeline` (or the stimulus its generator returns)."""
    return scene_from_mapping(load_yaml(path))
