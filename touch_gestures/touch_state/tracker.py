"""Fold the perception topics into one ``TouchState`` (msg/TouchState.msg), filtered by bear region.

The tracker keeps only the latest of each thing (bounded: one entry per bear sensor and per
gesture name), so a long run holds no history:

- bear: the last ``SensorLevel`` (active sensors, centroid), the ``SymbolicGesture`` START of every
  gesture under way (removed at its END), the last non-"none" ``TouchSubtype`` of every sensor;
- patch: the last ``GestureEvent`` and the last ``PanelContact``;
- skin: the last ``SkinFrame``'s contact, contact point and net force (not its arrays).

:meth:`TouchStateTracker.state` builds the message for the parts that run (the caller says which)
and a region (the body map's), or reports an unknown region without raising.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from touch_driver.bear.body_map import BodyMap
from touch_graph.compat import get_message
from touch_graph.yamlconf import did_you_mean

__all__ = ['Running', 'TouchStateTracker']

TouchState = get_message('social_touch_msgs/msg/TouchState')
Point = get_message('geometry_msgs/msg/Point')
Vector3 = get_message('geometry_msgs/msg/Vector3')
START, END = 1, 2
_NAN_POINT = {'x': math.nan, 'y': math.nan, 'z': math.nan}


@dataclass(frozen=True)
class Running:
    """Which parts of the scene run (their topics have a publisher)."""

    bear: bool = False
    patch: bool = False
    skin: bool = False


class TouchStateTracker:
    """The latest perception messages, and the ``TouchState`` they make.

    Args:
        body_map: the bear's body map: sensor regions for the region filter and the centroid of a
            filtered set of sensors.
    """

    def __init__(self, body_map: BodyMap) -> None:
        self.body_map = body_map
        self.regions = tuple(sorted({s.region for s in body_map.sensors}))
        self._region_of = {s.name: s.region for s in body_map.sensors}
        self._channel_of = {s.name: s.channel for s in body_map.sensors}
        self.sensor_level: Any = None
        self.gestures: dict[str, Any] = {}       # gesture name -> its START message
        self.subtypes: dict[str, Any] = {}       # sensor name -> its latest change (not to 'none')
        self.patch_gesture: Any = None
        self.panels: Any = None
        self.skin: Any = None                    # the last SkinFrame (kept whole: it is replaced every frame)
        self.version = 0                         # bumped when something a subscriber would notice changed

    # ------------------------------------------------------------------ updates
    def on_sensor_level(self, msg: Any) -> None:
        before = self._names(self.sensor_level)
        self.sensor_level = msg
        if self._names(msg) != before:
            self.version += 1

    def on_symbolic(self, msg: Any) -> None:
        if msg.state not in (START, END):     # a CANDIDATE or WITHDRAWN: gestures under way are decided ones
            return
        if msg.state == START:
            self.gestures[msg.gesture] = msg
        elif msg.state == END:
            self.gestures.pop(msg.gesture, None)
        self.version += 1

    def on_subtype(self, msg: Any) -> None:
        if msg.subtype == 'none':
            self.subtypes.pop(msg.sensor, None)
        else:
            self.subtypes[msg.sensor] = msg
        self.version += 1

    def on_patch_gesture(self, msg: Any) -> None:
        self.patch_gesture = msg
        self.version += 1

    def on_panels(self, msg: Any) -> None:
        changed = self.panels is None or list(msg.contact) != list(self.panels.contact)
        self.panels = msg
        if changed:
            self.version += 1

    def on_skin(self, msg: Any) -> None:
        changed = self.skin is None or bool(msg.contact) != bool(self.skin.contact)
        self.skin = msg
        if changed:
            self.version += 1

    @staticmethod
    def _names(msg: Any) -> tuple[str, ...]:
        return tuple(s.name for s in msg.sensors) if msg is not None else ()

    # ------------------------------------------------------------------ the state
    def check_region(self, region: str) -> str:
        """'' when ``region`` is empty or one of the body map's; otherwise why not (for the answer's message)."""
        if not region or region in self.regions:
            return ''
        return (f"unknown region '{region}'{did_you_mean(region, self.regions)}; the body map "
                f'({self.body_map.source or "code"}) has: {", ".join(self.regions)}')

    def state(self, running: Running, region: str = '', header: Any = None) -> Any:
        """The ``TouchState`` of the parts that run, limited to the bear ``region`` ('' = all).

        An unknown region gives an empty state naming the region (check it with :meth:`check_region`).
        """
        out = TouchState(region=region, bear=running.bear, patch=running.patch, skin=running.skin,
                         frame_id=self.body_map.frame_id, skin_contact_point=Point(**_NAN_POINT))
        if header is not None:
            out.header = header
        if self.check_region(region):
            return out
        if running.bear:
            self._fill_bear(out, region)
        if not region:
            if running.patch:
                self._fill_patch(out)
            if running.skin:
                self._fill_skin(out)
        return out

    def _in(self, region: str, sensor: str) -> bool:
        return not region or self._region_of.get(sensor) == region

    def _fill_bear(self, out: Any, region: str) -> None:
        level = self.sensor_level
        if level is not None:
            out.sensors = [s for s in level.sensors if self._in(region, s.name)]
            if not region:
                out.has_centroid, out.centroid = level.has_centroid, level.centroid
            else:
                point = self.body_map.centroid([s.channel for s in out.sensors], [s.level for s in out.sensors])
                if point is not None:
                    out.has_centroid, out.centroid = True, Point(x=point[0], y=point[1], z=point[2])
        out.gestures = [g for g in self.gestures.values() if any(self._in(region, s) for s in g.sensors)]
        out.subtypes = [m for name, m in sorted(self.subtypes.items(), key=lambda kv: self._channel_of.get(kv[0], 0))
                        if self._in(region, name)]

    def _fill_patch(self, out: Any) -> None:
        if self.patch_gesture is not None:
            out.has_patch_gesture, out.patch_gesture = True, self.patch_gesture
        if self.panels is not None:
            out.panels = self.panels

    def _fill_skin(self, out: Any) -> None:
        skin = self.skin
        if skin is None:
            return
        out.skin_contact = bool(skin.contact)
        out.skin_contact_point = skin.contact_point
        out.skin_net_force = skin.net_force
        out.skin_frame_id = skin.header.frame_id

    def forget(self, part: str) -> None:
        """``part`` ('bear', 'patch', 'skin') stopped running: nothing of it is under way any more."""
        if part == 'bear':
            self.sensor_level, self.gestures, self.subtypes = None, {}, {}
        elif part == 'patch':
            self.patch_gesture = self.panels = None
        elif part == 'skin':
            self.skin = None
        else:
            raise ValueError(f"part must be 'bear', 'patch' or 'skin', got {part!r}")
        self.version += 1
