"""Where the view draws the bear's sensors: the body map joined with ``touch_view/bear_layout.yaml``.

>>> from touch_driver.bear.body_map import BodyMap
>>> sensors = sensor_layout(BodyMap.default())
>>> len(sensors), sensors[1]['name'], sensors[1]['view'], sensors[1]['x'], sensors[1]['y']
(56, 'head2', 'front', 100.0, 28.0)
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path
from typing import Any

from touch_graph.yamlconf import YamlDict, check_keys, load_yaml, typed

__all__ = ['VIEWS', 'sensor_layout']

VIEWS = ('front', 'back')
#: Each view is VIEW_SIZE units (width, height).
VIEW_SIZE = (200, 290)
FORMAT_VERSION = 1


def _point(mapping: YamlDict, key: str) -> tuple[str, float, float]:
    value = mapping[key]
    if not (isinstance(value, list) and len(value) == 3 and value[0] in VIEWS and
            all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value[1:])):
        raise mapping.error(f"'{key}' must be [view, x, y] with view one of {', '.join(VIEWS)}; got {value!r}", key)
    view, x, y = value
    if not (0 <= x <= VIEW_SIZE[0] and 0 <= y <= VIEW_SIZE[1]):
        raise mapping.error(f"'{key}' is at ({x}, {y}), outside the {VIEW_SIZE[0]} x {VIEW_SIZE[1]} view", key)
    return view, float(x), float(y)


def load_layout(path: str | Path | None = None) -> tuple[dict[str, tuple], dict[str, tuple]]:
    """(sensor name -> (view, x, y), region -> (view, x, y)) from a layout file (default: the package's)."""
    if path is None:
        with resources.as_file(resources.files('touch_view').joinpath('bear_layout.yaml')) as file:
            doc = load_yaml(file)
    else:
        doc = load_yaml(path)
    check_keys(doc, required=('sensors', 'regions'), optional=('format',), what='bear view layout')
    version = typed(doc, 'format', int, 'bear view layout', default=FORMAT_VERSION)
    if version != FORMAT_VERSION:
        raise doc.error(f'layout format {version} is not supported; this code reads format {FORMAT_VERSION}', 'format')
    out = []
    for key in ('sensors', 'regions'):
        table = doc[key]
        if not isinstance(table, YamlDict):
            raise doc.error(f"'{key}' must map names to [view, x, y]", key)
        out.append({name: _point(table, name) for name in table})
    return out[0], out[1]


def sensor_layout(body_map: Any, path: str | Path | None = None) -> list[dict[str, Any]]:
    """The body map's sensors with where to draw them: ``[{channel, name, location, region, side, size, view, x, y}]``.

    A sensor the layout does not list goes on a small circle around its region's anchor (the
    middle of the torso when the region has none), so another bear's body map still draws.
    """
    positions, anchors = load_layout(path)
    unplaced: dict[str, int] = {}
    out = []
    for sensor in body_map:
        if sensor.name in positions:
            view, x, y = positions[sensor.name]
        else:
            view, x, y = anchors.get(sensor.region, ('front', VIEW_SIZE[0] / 2, VIEW_SIZE[1] / 2))
            k = unplaced[sensor.region] = unplaced.get(sensor.region, 0) + 1
            x, y = x + 9 * math.cos(2.4 * k), y + 9 * math.sin(2.4 * k)  # golden-angle spiral: no overlaps
        out.append({'channel': sensor.channel, 'name': sensor.name, 'location': sensor.location,
                    'region': sensor.region, 'side': sensor.side, 'size': sensor.size,
                    'view': view, 'x': round(x, 1), 'y': round(y, 1)})
    return out
