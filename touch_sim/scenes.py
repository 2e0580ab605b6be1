"""Stimuli that drive the virtual bear and patch: who touches which sensors, how and when (synthetic).

A *stimulus* is what a scene does to a sensor as a function of time; the virtual devices
(:mod:`touch_sim.bear.device`, :mod:`touch_sim.patch.device`) sample it at frame time and add the
sensor physics. This module gives the protocols and a scripted stimulus, a timeline of touches
that can be written in YAML.

YAML timeline (``sensor: bear``)::

    sensor: bear
    touches:
      - {sensors: [head1, head2], start: 1.0, duration: 3.0, level: 1.0, envelope: pulse, freq_hz: 1.5}
      - {region: left_foot, start: 5.0, duration: 4.0, level: 0.9, envelope: sine, freq_hz: 1.0}

and (``sensor: patch``; cells are (row, col), fractional allowed)::

    sensor: patch
    touches:
      - {at: [8, 3], to: [8, 12], radius: 1.5, pressure: 2.5, start: 1.0, duration: 1.5}
    panels:
      - {panels: [0, 1], start: 6.0, duration: 2.0, level: 1.0}

or a generated scene: ``generator`` names a function registered in the
``social_touch.scene_generators`` entry point group (:data:`GENERATOR_GROUP`), called with ``options``::

    sensor: bear
    generator: bear_people
    options: {n_people: 2, seed: 7, gestures: [hug, head_pat]}

Envelopes (``u`` = seconds since the touch started, ramped in and out over ``ramp_s``):
``constant`` (``level``), ``sine`` (``level * (1 - cos(2 pi f u)) / 2``), ``pulse`` (``level``
for the first ``duty`` of every ``1/f`` period).

>>> script = BearScript([BearTouch(channels=(1,), start=1.0, duration=2.0, level=0.8)])
>>> script.proximity(0.5)[1].item(), round(script.proximity(2.0)[1].item(), 6)
(0.0, 0.8)
"""

from __future__ import annotations

import inspect
import math
import threading
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np

from touch_graph.errors import ConfigError
from touch_graph.yamlconf import YamlDict, YamlList, check_keys, did_you_mean, load_yaml, typed

__all__ = ['ENVELOPES', 'BearScript', 'BearStimulus', 'BearTouch', 'IdleBear', 'IdlePatch', 'PanelTouch',
           'PatchScript', 'PatchStimulus', 'PatchTouch', 'envelope', 'generated_stimulus', 'load_stimulus',
           'register_stimulus', 'registered_stimuli', 'unregister_stimulus']

N_BEAR_CHANNELS = 64
PATCH_GRID = (16, 16)
N_PANELS = 11
ENVELOPES = ('constant', 'sine', 'pulse')


@runtime_checkable
class BearStimulus(Protocol):
    """What touches the bear (synthetic)."""

    def proximity(self, t: float) -> np.ndarray:
        """(64,) float32 in [0, 1] by wire channel at time ``t`` seconds: 0 nothing near, 1 full direct contact.

        knight2009 IV.D: the capacitive level grows with proximity, contact area and
        conductivity, and saturates on direct touch; the device maps this to counts.
        """


@runtime_checkable
class PatchStimulus(Protocol):
    """What touches the textile patch and the capacitive panels (synthetic)."""

    def pressure(self, t: float) -> np.ndarray:
        """(16, 16) float32 >= 0, force per cell in N/cm^2, row-major (sympartner2018 5.3: the
        matrix resolves best below ~400 g/cm^2, about 3.9 N/cm^2)."""

    def panels(self, t: float) -> np.ndarray:
        """(11,) float32 in [0, 1]: hand proximity/contact per capacitive panel (1 = firm hand contact)."""


def envelope(u: float, duration: float, kind: str = 'constant', freq_hz: float = 1.0, duty: float = 0.5,
             ramp_s: float = 0.1) -> float:
    """Shape of a touch at ``u`` seconds after its start, in [0, 1]; 0 outside [0, duration).

    >>> envelope(0.5, 1.0), envelope(1.0, 1.0), envelope(0.05, 1.0)
    (1.0, 0.0, 0.5)
    >>> round(envelope(0.25, 2.0, 'sine', freq_hz=2.0, ramp_s=0), 3), envelope(0.3, 2.0, 'pulse', 2.0, 0.5, 0)
    (1.0, 0.0)
    """
    if not 0.0 <= u < duration:
        return 0.0
    if kind == 'constant':
        shape = 1.0
    elif kind == 'sine':
        shape = 0.5 * (1.0 - math.cos(2.0 * math.pi * freq_hz * u))
    elif kind == 'pulse':
        shape = 1.0 if (u * freq_hz) % 1.0 < duty else 0.0
    else:
        raise ValueError(f'envelope must be one of {", ".join(ENVELOPES)}; got {kind!r}')
    if ramp_s > 0:  # soft onset and release, as a hand arrives and leaves
        shape *= min(1.0, u / ramp_s, (duration - u) / ramp_s)
    return shape


@dataclass(frozen=True)
class _Timing:
    start: float
    duration: float
    envelope: str = 'constant'
    freq_hz: float = 1.0
    duty: float = 0.5
    ramp_s: float = 0.1

    def shape(self, t: float) -> float:
        return envelope(t - self.start, self.duration, self.envelope, self.freq_hz, self.duty, self.ramp_s)

    @property
    def end(self) -> float:
        return self.start + self.duration


@dataclass(frozen=True)
class BearTouch(_Timing):
    """A hand on some of the bear's sensors: ``channels`` reach ``level`` (0..1) shaped by the envelope."""

    channels: tuple[int, ...] = ()
    level: float = 1.0


@dataclass(frozen=True)
class PatchTouch(_Timing):
    """A contact on the patch: a Gaussian pressure blob of ``pressure`` N/cm^2 at its centre and
    standard deviation ``radius`` cells, centred at ``at`` (row, col), moving linearly to ``to``."""

    at: tuple[float, float] = (7.5, 7.5)
    to: tuple[float, float] | None = None
    radius: float = 1.0
    pressure: float = 2.0

    def centre(self, t: float) -> tuple[float, float]:
        if self.to is None or self.duration <= 0:
            return self.at
        f = min(max((t - self.start) / self.duration, 0.0), 1.0)
        return (self.at[0] + f * (self.to[0] - self.at[0]), self.at[1] + f * (self.to[1] - self.at[1]))


@dataclass(frozen=True)
class PanelTouch(_Timing):
    """A hand on capacitive panels ``panels`` (0..10) reaching ``level`` (0..1)."""

    panels: tuple[int, ...] = ()
    level: float = 1.0


class BearScript:
    """A timeline of :class:`BearTouch`; overlapping touches on a channel take the larger level."""

    def __init__(self, touches: Iterable[BearTouch]) -> None:
        self.touches = tuple(touches)
        for touch in self.touches:
            if any(not 0 <= c < N_BEAR_CHANNELS for c in touch.channels):
                raise ValueError(f'bear channels are 0..63; got {touch.channels}')
        self._channels = [np.asarray(t.channels, dtype=np.intp) for t in self.touches]

    @property
    def duration(self) -> float:
        """End of the last touch, seconds."""
        return max((t.end for t in self.touches), default=0.0)

    def proximity(self, t: float) -> np.ndarray:
        out = np.zeros(N_BEAR_CHANNELS, dtype=np.float32)
        for touch, channels in zip(self.touches, self._channels, strict=True):
            value = touch.level * touch.shape(t)
            if value > 0:
                np.maximum.at(out, channels, np.float32(value))
        return np.clip(out, 0.0, 1.0, out=out)


class PatchScript:
    """A timeline of :class:`PatchTouch` (pressures add up) and :class:`PanelTouch` (largest wins)."""

    def __init__(self, touches: Iterable[PatchTouch] = (), panel_touches: Iterable[PanelTouch] = ()) -> None:
        self.touches = tuple(touches)
        self.panel_touches = tuple(panel_touches)
        for touch in self.panel_touches:
            if any(not 0 <= p < N_PANELS for p in touch.panels):
                raise ValueError(f'panels are 0..{N_PANELS - 1}; got {touch.panels}')
        rows, cols = np.indices(PATCH_GRID, dtype=np.float32)
        self._rows, self._cols = rows, cols

    @property
    def duration(self) -> float:
        return max((t.end for t in (*self.touches, *self.panel_touches)), default=0.0)

    def pressure(self, t: float) -> np.ndarray:
        out = np.zeros(PATCH_GRID, dtype=np.float32)
        for touch in self.touches:
            shape = touch.shape(t)
            if shape <= 0:
                continue
            r0, c0 = touch.centre(t)
            d2 = (self._rows - r0) ** 2 + (self._cols - c0) ** 2
            blob = np.exp(-d2 / (2.0 * max(touch.radius, 1e-3) ** 2))
            blob[blob < 0.01] = 0.0  # a finger presses a patch, not the whole matrix
            out += (touch.pressure * shape) * blob
        return out

    def panels(self, t: float) -> np.ndarray:
        out = np.zeros(N_PANELS, dtype=np.float32)
        for touch in self.panel_touches:
            value = touch.level * touch.shape(t)
            for p in touch.panels:
                out[p] = max(out[p], value)
        return np.clip(out, 0.0, 1.0, out=out)


class IdleBear:
    """Nobody touches the bear."""

    duration = 0.0

    def proximity(self, t: float) -> np.ndarray:
        return np.zeros(N_BEAR_CHANNELS, dtype=np.float32)


class IdlePatch:
    """Nobody touches the patch or the panels."""

    duration = 0.0

    def pressure(self, t: float) -> np.ndarray:
        return np.zeros(PATCH_GRID, dtype=np.float32)

    def panels(self, t: float) -> np.ndarray:
        return np.zeros(N_PANELS, dtype=np.float32)


# ---------------------------------------------------------------------- registry
_registry: dict[str, Any] = {}
_lock = threading.Lock()
_BUILTIN = {('idle', 'bear'): IdleBear, ('idle', 'patch'): IdlePatch}


def register_stimulus(name: str, stimulus: BearStimulus | PatchStimulus) -> None:
    """Make ``stimulus`` reachable by ``name`` from a device URL (``bearsim://x?scene=NAME``).

    Registering a name again replaces the earlier object.
    """
    if not isinstance(stimulus, (BearStimulus, PatchStimulus)):
        raise TypeError(f'a stimulus has proximity(t) (bear) or pressure(t) and panels(t) (patch); '
                        f'got {type(stimulus).__name__}')
    with _lock:
        _registry[name] = stimulus


def unregister_stimulus(name: str) -> None:
    """Forget a registered stimulus (no error when absent)."""
    with _lock:
        _registry.pop(name, None)


def registered_stimuli() -> tuple[str, ...]:
    with _lock:
        return tuple(sorted(_registry))


def load_stimulus(path_or_name: str | Path, sensor: str | None = None, body_map: Any = None) -> Any:
    """A registered stimulus, a built-in one (``'idle'``), or a YAML timeline file.

    Args:
        path_or_name: registered name, ``'idle'``, or path of a YAML scene.
        sensor: ``'bear'`` or ``'patch'``: the kind of stimulus wanted (checked).
        body_map: :class:`~touch_driver.bear.body_map.BodyMap` for sensor names (default map).

    Raises:
        ConfigError: unknown name and no such file, a malformed file, or a stimulus of the other sensor.
    """
    if sensor not in (None, 'bear', 'patch'):
        raise ValueError(f"sensor must be 'bear', 'patch' or None; got {sensor!r}")
    key = str(path_or_name)
    with _lock:
        stimulus = _registry.get(key)
    if stimulus is None and (key, sensor) in _BUILTIN:
        stimulus = _BUILTIN[key, sensor]()
    if stimulus is None:
        path = Path(key)
        if not path.suffix and not path.exists():
            known = (*registered_stimuli(), 'idle')
            raise ConfigError(f'no registered stimulus {key!r}{did_you_mean(key, known)} and no such file; '
                              f'registered: {", ".join(known)}; or give the path of a YAML scene')
        stimulus = _load_yaml_script(path, sensor, body_map)
    want = {'bear': BearStimulus, 'patch': PatchStimulus}.get(sensor)
    if want is not None and not isinstance(stimulus, want):
        raise ConfigError(f'stimulus {key!r} is a {type(stimulus).__name__}, not a {sensor} stimulus')
    return stimulus


# ---------------------------------------------------------------------- YAML
_TIMING_KEYS = ('start', 'duration', 'envelope', 'freq_hz', 'duty', 'ramp_s')


def _timing(item: YamlDict, what: str) -> dict:
    out = {'start': typed(item, 'start', float, what), 'duration': typed(item, 'duration', float, what)}
    if out['start'] < 0 or out['duration'] <= 0:
        raise item.error(f'{what}: start must be >= 0 and duration > 0 seconds', 'duration')
    kind = typed(item, 'envelope', str, what, default='constant')
    if kind not in ENVELOPES:
        raise item.error(f'{what}: envelope {kind!r} is not one of {", ".join(ENVELOPES)}'
                         f'{did_you_mean(kind, ENVELOPES)}', 'envelope')
    out['envelope'] = kind
    for key, default in (('freq_hz', 1.0), ('duty', 0.5), ('ramp_s', 0.1)):
        out[key] = typed(item, key, float, what, default=default)
        if out[key] < 0:
            raise item.error(f'{what}: {key} must be >= 0', key)
    return out


def _level(item: YamlDict, key: str, what: str, default: float, top: float | None) -> float:
    value = typed(item, key, float, what, default=default)
    if not math.isfinite(value) or value < 0 or (top is not None and value > top):
        raise item.error(f'{what}: {key} must be in 0..{top if top is not None else "inf"}; got {value}', key)
    return value


def _items(doc: YamlDict, key: str) -> list[tuple[YamlDict, str]]:
    items = doc.get(key, YamlList())
    if not isinstance(items, list):
        raise doc.error(f'{key} must be a list of touches', key)
    out = []
    for i, item in enumerate(items):
        if not isinstance(item, YamlDict):
            raise items.error(f'{key} #{i + 1} must be a mapping; got {item!r}', i)
        out.append((item, f'{key} #{i + 1}'))
    return out


def _pair(item: YamlDict, key: str, what: str) -> tuple[float, float]:
    value = item[key]
    if (not isinstance(value, list) or len(value) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)):
        raise item.error(f'{what}: {key} must be [row, col] (cells, 0..15); got {value!r}', key)
    return float(value[0]), float(value[1])


#: The entry point group of scene generators: ``name = module:function`` (pyproject.toml). A scene file
#: names a generator, never a module: a config file imports no code of its own choosing.
GENERATOR_GROUP = 'social_touch.scene_generators'


def scene_generators() -> dict[str, Any]:
    """``name -> entry point`` of every installed scene generator."""
    return {ep.name: ep for ep in entry_points(group=GENERATOR_GROUP)}


def generated_stimulus(doc: YamlDict, what: str, is_stimulus: Callable[[Any], bool], example: str,
                       body_map: Any = None) -> Any:
    """The stimulus returned by the scene's ``generator`` called with its ``options`` (lists become tuples).

    Shared by every sensor's scene files. ``generator`` is the name of a function registered in
    the :data:`GENERATOR_GROUP` entry point group (``bear_people``, ``patch_people``, ``skin_people``);
    unknown names, unknown options, options the function rejects and a result that ``is_stimulus``
    refuses are ConfigErrors naming the file and line. A ``body_map`` is passed to functions that
    take one.
    """
    spec = typed(doc, 'generator', str, what)
    generators = scene_generators()
    if spec not in generators:
        known = sorted(generators)
        raise doc.error(f'no scene generator {spec!r}{did_you_mean(spec, known)}; installed: '
                        f'{", ".join(known) or "none (is the package installed?)"}, e.g. {example}', 'generator')
    try:
        func = generators[spec].load()
    except (ImportError, AttributeError) as err:
        raise doc.error(f'cannot load generator {spec!r} ({generators[spec].value}): {err}', 'generator') from None
    options = doc.get('options', YamlDict())
    if not isinstance(options, YamlDict):
        raise doc.error(f'options must be a mapping of keyword arguments of {spec}', 'options')
    parameters = inspect.signature(func).parameters
    accepted = [n for n in parameters if n != 'body_map']
    for key in options:
        if key not in accepted:
            raise options.error(f'{spec} takes no option {key!r}{did_you_mean(str(key), accepted)}; options: '
                                f'{", ".join(accepted)}', key)
    kwargs = {k: tuple(v) if isinstance(v, list) else v for k, v in options.items()}
    if body_map is not None and 'body_map' in parameters:
        kwargs['body_map'] = body_map
    try:
        stimulus = func(**kwargs)
    except (TypeError, ValueError) as err:
        raise doc.error(f'{spec} rejected the options: {err}', 'options' if 'options' in doc else 'generator') from None
    if not is_stimulus(stimulus):
        raise doc.error(f'{spec} returned a {type(stimulus).__name__}, not a {what} stimulus', 'generator')
    return stimulus


def _load_yaml_script(path: Path, sensor: str | None, body_map: Any) -> Any:
    doc = load_yaml(path)
    check_keys(doc, required=('sensor',), optional=('touches', 'panels', 'description', 'generator', 'options'),
               what='stimulus scene')
    kind = typed(doc, 'sensor', str, 'stimulus scene')
    if kind not in ('bear', 'patch'):
        raise doc.error(f"sensor must be 'bear' or 'patch'; got {kind!r}", 'sensor')
    if sensor is not None and kind != sensor:
        raise doc.error(f'this scene is for the {kind}, not the {sensor}', 'sensor')
    if 'generator' in doc:
        scripted = [k for k in ('touches', 'panels') if k in doc]
        if scripted:
            raise doc.error(f"a scene has a generator or a timeline, not both: remove '{scripted[0]}'", scripted[0])
        want = BearStimulus if kind == 'bear' else PatchStimulus
        return generated_stimulus(doc, f'{kind} scene', lambda s: isinstance(s, want),
                                  'bear_people', body_map)
    if 'options' in doc:
        raise doc.error("'options' are the keyword arguments of a 'generator'; this scene has none", 'options')
    if kind == 'bear':
        if 'panels' in doc:
            raise doc.error("'panels' belong to a patch scene", 'panels')
        return BearScript(_bear_touch(item, what, body_map) for item, what in _items(doc, 'touches'))
    touches = []
    for item, what in _items(doc, 'touches'):
        check_keys(item, required=('at', 'start', 'duration'),
                   optional=('to', 'radius', 'pressure', *_TIMING_KEYS), what=what)
        to = _pair(item, 'to', what) if 'to' in item else None
        touches.append(PatchTouch(at=_pair(item, 'at', what), to=to, **_timing(item, what),
                                  radius=_level(item, 'radius', what, 1.0, None) or 1e-3,
                                  pressure=_level(item, 'pressure', what, 2.0, None)))
    panels = []
    for item, what in _items(doc, 'panels'):
        check_keys(item, required=('panels', 'start', 'duration'), optional=('level', *_TIMING_KEYS), what=what)
        ids = item['panels']
        if not isinstance(ids, list) or not all(isinstance(p, int) and 0 <= p < N_PANELS for p in ids):
            raise item.error(f'{what}: panels must be a list of panel numbers 0..{N_PANELS - 1}; got {ids!r}',
                             'panels')
        panels.append(PanelTouch(panels=tuple(ids), **_timing(item, what), level=_level(item, 'level', what, 1.0, 1.0)))
    return PatchScript(touches, panels)


def _bear_touch(item: YamlDict, what: str, body_map: Any) -> BearTouch:
    check_keys(item, required=('start', 'duration'), optional=('sensors', 'region', 'level', *_TIMING_KEYS),
               what=what)
    if 'sensors' not in item and 'region' not in item:
        raise item.error(f'{what} needs sensors: [names] and/or region: NAME')
    if body_map is None:
        from touch_driver.bear.body_map import BodyMap  # scenes must not need the bear unless they use it
        body_map = BodyMap.default()
    channels: list[int] = []
    names = item.get('sensors', [])
    if not isinstance(names, list):
        raise item.error(f'{what}: sensors must be a list of sensor names or channels', 'sensors')
    for i, name in enumerate(names):
        try:
            channels.append(name if isinstance(name, int) and 0 <= name < N_BEAR_CHANNELS
                            else body_map.by_name(name).channel)
        except ConfigError as err:
            raise names.error(f'{what}: {err.bare_message}', i) from None
    if 'region' in item:
        try:
            channels.extend(s.channel for s in body_map.region(typed(item, 'region', str, what)))
        except ConfigError as err:
            raise item.error(f'{what}: {err.bare_message}', 'region') from None
    return BearTouch(channels=tuple(dict.fromkeys(channels)), **_timing(item, what),
                     level=_level(item, 'level', what, 1.0, 1.0))
