"""The Sensate Bear's body map: wire channel -> sensor name, body location, region and position.

knight2009 V.C maps the incoming sensor ids to on-bear locations with an XML lookup table
("remaps data into human-readable labels, e.g. 'head2'"). Here the table is
``config/bear_body.yaml``; this module loads and validates it.

Wire channel = midplane * 8 + input, 0..63 (8 Midplane boards x 8 inputs, knight2009 IV.A).
The paper's bear has 56 fitted sensors; the other channels are unfitted.

Positions are metres in the body frame :attr:`BodyMap.frame_id` (REP 103: x forward, y left, z up),
approximate for the shipped bear (see the file's header); :meth:`BodyMap.centroid` gives the
level-weighted touch centroid a robot can look at.

>>> body = BodyMap.default()
>>> len(body), body.by_name('head2').location, body.by_channel(13) is None
(56, 'crown', True)
>>> body.channels(['head1', 'foot_left_sole']).tolist()
[0, 54]
>>> [s.name for s in body.region('left_foot')]
['foot_left_top', 'foot_left_sole', 'foot_left_toe']
>>> body.frame_id, body.by_name('head2').position
('bear_link', (0.0, 0.0, 0.415))
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from functools import cache
from pathlib import Path

import numpy as np

from touch_graph.errors import ConfigError
from touch_graph.paths import share_file
from touch_graph.yamlconf import YamlDict, YamlList, check_keys, did_you_mean, load_yaml, typed

__all__ = ['DEFAULT_FRAME_ID', 'N_CHANNELS', 'REGIONS', 'SIDES', 'SIZES', 'BodyMap', 'BodySensor', 'channel_of']

#: Channels on the wire: 8 Midplanes x 8 inputs (knight2009 IV.A).
N_CHANNELS = 64
#: Inputs per Midplane board (knight2009 IV.A, IV.D: one 33794 chip with eight channels).
INPUTS_PER_MIDPLANE = 8
REGIONS = ('head', 'face', 'neck', 'torso_front', 'torso_back', 'side_left', 'side_right',
           'left_arm', 'right_arm', 'left_leg', 'right_leg', 'left_foot', 'right_foot')
SIDES = ('left', 'right', 'center')
#: Sensor board sizes in inches (width, height), knight2009 IV.C.
SIZES = {'small': (1.5, 2.0), 'large': (3.0, 2.0)}
FORMAT_VERSION = 1
#: Body frame of the positions when the file names none: the bear driver's default ``frame_id``.
DEFAULT_FRAME_ID = 'bear_link'
#: A position further than this from the body origin is a typo (mm for m?), metres.
MAX_POSITION_M = 5.0

_NAME = re.compile(r'^[a-z][a-z0-9_]*$')
_SENSOR_KEYS = ('channel', 'name', 'location', 'region', 'side', 'size')
_OPTIONAL_SENSOR_KEYS = ('position',)
Position = tuple[float, float, float]


def channel_of(midplane: int, input_: int) -> int:
    """Wire channel of a Midplane input.

    >>> channel_of(6, 6)
    54
    """
    if not (0 <= midplane < N_CHANNELS // INPUTS_PER_MIDPLANE and 0 <= input_ < INPUTS_PER_MIDPLANE):
        raise ValueError(f'midplane must be 0..7 and input 0..7; got midplane={midplane}, input={input_}')
    return midplane * INPUTS_PER_MIDPLANE + input_


@dataclass(frozen=True)
class BodySensor:
    """One fitted capacitive sensor.

    Attributes:
        channel: wire channel, 0..63 (midplane * 8 + input).
        name: short label, e.g. ``'head2'``.
        location: human-readable body location, e.g. ``'left foot sole'``.
        region: one of :data:`REGIONS`.
        side: ``'left'``, ``'right'`` or ``'center'`` (the bear's own sides).
        size: ``'small'`` (1.5"x2") or ``'large'`` (3"x2"), knight2009 IV.C.
        position: ``(x, y, z)`` of the sensor's centre, metres, in the body frame (REP 103), or
            None when the map gives none.
    """

    channel: int
    name: str
    location: str
    region: str
    side: str
    size: str
    position: Position | None = None

    @property
    def midplane(self) -> int:
        return self.channel // INPUTS_PER_MIDPLANE

    @property
    def input(self) -> int:
        return self.channel % INPUTS_PER_MIDPLANE


class BodyMap:
    """The fitted sensors of a bear, with lookups by name, channel and region.

    Args:
        sensors: the fitted sensors, any order (kept in channel order).
        source: where they came from, for error messages.

    Raises:
        ConfigError: on duplicate names or channels, a channel outside 0..63, or an unknown
            region, side or size.
    """

    def __init__(self, sensors: Iterable[BodySensor], source: str | None = None,
                 frame_id: str = DEFAULT_FRAME_ID) -> None:
        self.source = source
        self.frame_id = frame_id
        ordered = sorted(sensors, key=lambda s: s.channel)
        by_name: dict[str, BodySensor] = {}
        by_channel: dict[int, BodySensor] = {}
        for sensor in ordered:
            _check_sensor_values(sensor, source)
            if sensor.name in by_name:
                raise ConfigError(f"sensor name '{sensor.name}' is used twice (channels "
                                  f'{by_name[sensor.name].channel} and {sensor.channel}); names must be unique', source)
            if sensor.channel in by_channel:
                raise ConfigError(f'channel {sensor.channel} is given to both '
                                  f"'{by_channel[sensor.channel].name}' and '{sensor.name}'", source)
            by_name[sensor.name] = sensor
            by_channel[sensor.channel] = sensor
        self.sensors: tuple[BodySensor, ...] = tuple(ordered)
        self._by_name = by_name
        self._by_channel = by_channel
        mask = np.zeros(N_CHANNELS, dtype=bool)
        mask[list(by_channel)] = True
        mask.setflags(write=False)
        self._fitted = mask
        # (64, 3) float64 positions and a (64,) mask of channels that have one, for centroid().
        positions = np.zeros((N_CHANNELS, 3), dtype=np.float64)
        placed = np.zeros(N_CHANNELS, dtype=bool)
        for sensor in ordered:
            if sensor.position is not None:
                positions[sensor.channel] = sensor.position
                placed[sensor.channel] = True
        self._positions, self._placed = positions, placed

    # ------------------------------------------------------------------ lookups
    def __len__(self) -> int:
        return len(self.sensors)

    def __iter__(self) -> Iterator[BodySensor]:
        return iter(self.sensors)

    def __repr__(self) -> str:
        return f'BodyMap({len(self)} sensors from {self.source or "code"})'

    @property
    def names(self) -> tuple[str, ...]:
        """Sensor names in channel order."""
        return tuple(s.name for s in self.sensors)

    def by_name(self, name: str) -> BodySensor:
        """The sensor called ``name``; ConfigError (with a did-you-mean) when there is none."""
        try:
            return self._by_name[name]
        except (KeyError, TypeError):
            raise ConfigError(f'unknown bear sensor {name!r}{did_you_mean(name, self._by_name)}; '
                              f'the body map ({self.source or "code"}) names: {", ".join(self._by_name)}') from None

    def by_channel(self, channel: int) -> BodySensor | None:
        """The sensor on wire ``channel``, or None when the channel is unfitted (or out of range)."""
        return self._by_channel.get(int(channel))

    def fitted_mask(self) -> np.ndarray:
        """(64,) bool, True where a sensor is fitted (read-only)."""
        return self._fitted

    def channels(self, names: Iterable[str]) -> np.ndarray:
        """(k,) intp channels of ``names``, in the given order; ConfigError on an unknown name."""
        if isinstance(names, str):
            names = [names]
        return np.array([self.by_name(n).channel for n in names], dtype=np.intp)

    def region(self, region: str) -> tuple[BodySensor, ...]:
        """The sensors of ``region`` in channel order; ConfigError when it is not one of :data:`REGIONS`."""
        if region not in REGIONS:
            raise ConfigError(f'unknown body region {region!r}{did_you_mean(region, REGIONS)}; '
                              f'regions are: {", ".join(REGIONS)}')
        return tuple(s for s in self.sensors if s.region == region)

    def side(self, side: str) -> tuple[BodySensor, ...]:
        """The sensors on ``side`` ('left', 'right', 'center'), channel order."""
        if side not in SIDES:
            raise ConfigError(f'unknown side {side!r}; sides are: {", ".join(SIDES)}')
        return tuple(s for s in self.sensors if s.side == side)

    def centroid(self, channels: Iterable[int], levels: Iterable[float]) -> Position | None:
        """Level-weighted mean position of ``channels`` (metres, body frame), or None.

        Args:
            channels: wire channels of the touched sensors.
            levels: their levels (0..1), same order; the weights.

        Returns None when no given channel has a position or the weights sum to 0 (nothing to
        look at); non-finite or negative levels weigh nothing.

        >>> body = BodyMap.default()
        >>> [round(v, 3) for v in body.centroid([1, 0], [0.5, 0.25])]   # head2 weighs twice head1
        [0.013, 0.0, 0.41]
        >>> body.centroid([], []) is None, body.centroid([13], [1.0]) is None
        (True, True)
        """
        index = np.fromiter((int(c) for c in channels), dtype=np.intp)
        weights = np.fromiter((float(v) for v in levels), dtype=np.float64, count=len(index))
        inside = (index >= 0) & (index < N_CHANNELS)
        index, weights = index[inside], weights[inside]
        weights = np.where(np.isfinite(weights) & (weights > 0) & self._placed[index], weights, 0.0)
        largest = float(weights.max(initial=0.0))
        if not largest > 0.0:
            return None
        # Scaled to the largest first: a subnormal weight alone would round its product with a position
        # to 0 (or a huge one overflow the sum), putting the mean outside the touched sensors.
        weights /= largest
        x, y, z = (weights @ self._positions[index]) / float(weights.sum())
        return float(x), float(y), float(z)

    # ------------------------------------------------------------------ files
    @classmethod
    def load(cls, path: str | Path) -> BodyMap:
        """Read and validate a body-map YAML file (format in ``config/bear_body.yaml``).

        Raises:
            ConfigError: naming file and line of the first problem.
        """
        doc = load_yaml(path)
        check_keys(doc, required=('sensors',), optional=('format', 'frame_id'), what='bear body map')
        version = typed(doc, 'format', int, 'bear body map', default=FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise doc.error(f'body map format {version} is not supported; this code reads format {FORMAT_VERSION}',
                            'format')
        frame_id = typed(doc, 'frame_id', str, 'bear body map', default=DEFAULT_FRAME_ID)
        if not frame_id or frame_id.startswith('/'):
            raise doc.error(f'frame_id must be a tf2 frame name without a leading slash; got {frame_id!r}',
                            'frame_id')
        items = doc['sensors']
        if not isinstance(items, YamlList) or not items:
            raise doc.error('sensors must be a non-empty list of {channel, name, location, region, side, size}',
                            'sensors')
        sensors: list[BodySensor] = []
        seen_names: dict[str, int] = {}
        seen_channels: dict[int, int] = {}
        for index, item in enumerate(items):
            what = f'sensor #{index + 1}'
            if not isinstance(item, YamlDict):
                raise items.error(f'{what} must be a mapping with keys {", ".join(_SENSOR_KEYS)}; got {item!r}', index)
            check_keys(item, required=_SENSOR_KEYS, optional=_OPTIONAL_SENSOR_KEYS, what=what)
            channel = typed(item, 'channel', int, what)
            name, location, region, side, size = (typed(item, k, str, what) for k in _SENSOR_KEYS[1:])
            if not 0 <= channel < N_CHANNELS:
                raise item.error(f'channel {channel} of {name!r} is outside 0..{N_CHANNELS - 1} '
                                 '(channel = midplane * 8 + input)', 'channel')
            if channel in seen_channels:
                raise item.error(f'channel {channel} is given twice (first on line {seen_channels[channel]})',
                                 'channel')
            if name in seen_names:
                raise item.error(f'sensor name {name!r} is used twice (first on line {seen_names[name]})', 'name')
            for key, value, allowed in (('region', region, REGIONS), ('side', side, SIDES), ('size', size, SIZES)):
                if value not in allowed:
                    raise item.error(f'{key} {value!r} of {name!r} is not one of: {", ".join(allowed)}'
                                     f'{did_you_mean(value, allowed)}', key)
            if not _NAME.match(name):
                raise item.error(f'sensor name {name!r} must be lower case letters, digits and _', 'name')
            seen_channels[channel] = item.line_of('channel')
            seen_names[name] = item.line_of('name')
            position = _position(item, name) if 'position' in item else None
            sensors.append(BodySensor(channel, name, location, region, side, size, position))
        return cls(sensors, source=str(path), frame_id=frame_id)

    @classmethod
    def default(cls) -> BodyMap:
        """The package's ``config/bear_body.yaml`` (the paper's 56-sensor bear), read once and shared."""
        if cls is BodyMap:
            return _default_map()
        return cls.load(share_file('config', 'bear_body.yaml'))


@cache
def _default_map() -> BodyMap:
    return BodyMap.load(share_file('config', 'bear_body.yaml'))


def _position(item: YamlDict, name: str) -> Position:
    """The ``position: [x, y, z]`` of a sensor entry, metres; ConfigError at its line when malformed."""
    value = item['position']
    numbers = isinstance(value, list) and len(value) == 3 and all(
        isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
    if not numbers or not all(np.isfinite(value)):
        raise item.error(f'position of {name!r} must be [x, y, z], three finite numbers in metres; got {value!r}',
                         'position')
    if float(np.linalg.norm(value)) > MAX_POSITION_M:
        raise item.error(f'position of {name!r} is {float(np.linalg.norm(value)):g} m from the body origin; '
                         f'positions are metres (more than {MAX_POSITION_M:g} m: millimetres by mistake?)', 'position')
    x, y, z = (float(v) for v in value)
    return x, y, z


def _check_sensor_values(sensor: BodySensor, source: str | None) -> None:
    if not isinstance(sensor.channel, (int, np.integer)) or not 0 <= sensor.channel < N_CHANNELS:
        raise ConfigError(f'channel {sensor.channel!r} of {sensor.name!r} is outside 0..{N_CHANNELS - 1}', source)
    for key, allowed in (('region', REGIONS), ('side', SIDES), ('size', SIZES)):
        value = getattr(sensor, key)
        if value not in allowed:
            raise ConfigError(f'{key} {value!r} of {sensor.name!r} is not one of: {", ".join(allowed)}'
                              f'{did_you_mean(value, allowed)}', source)
