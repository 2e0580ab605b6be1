"""``touch_state``: the Robotic Touch API (knight2009 VII) on the graph.

Subscribes to what the recognisers publish (``/touch/sensor_level``, ``/touch/symbolic``,
``/touch/subtype``, ``/touch/gesture``, ``/patch/panels``, ``/skin/frame``) and

- serves ``/touch/get_state`` (``social_touch_msgs/srv/GetTouchState``): the state now, optionally
  for one bear body region; an unknown region gets ``success: false``, an empty state and a message
  naming the regions there are (never an exception);
- publishes ``/touch/state`` (``TouchState``, reliable, TRANSIENT_LOCAL depth 1: a late subscriber
  gets the latest) when something changes (at most ``max_rate_hz``) and every ``1 / rate_hz`` s.

Only the parts of the scene that run appear: a part runs while its topics have a publisher
(``count_publishers``, across processes too); when it stops, what it had under way is forgotten.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from touch_driver.bear.body_map import BodyMap
from touch_graph.compat import Node, ParameterDescriptor, get_message, get_service, latched_qos, sensor_data_qos
from touch_graph.errors import ParameterError
from touch_graph.node_main import run_node

from .tracker import Running, TouchStateTracker

__all__ = ['PART_TOPICS', 'TouchStateNode', 'main']

SensorLevel = get_message('social_touch_msgs/msg/SensorLevel')
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
PanelContact = get_message('social_touch_msgs/msg/PanelContact')
SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
TouchState = get_message('social_touch_msgs/msg/TouchState')
Header = get_message('std_msgs/msg/Header')
GetTouchState = get_service('social_touch_msgs/srv/GetTouchState')

#: A part of the scene runs while one of its topics has a publisher.
PART_TOPICS = {'bear': ('/touch/sensor_level',), 'patch': ('/touch/gesture', '/patch/panels'),
               'skin': ('/skin/frame',)}
_NS = 1_000_000_000


class TouchStateNode(Node):
    """Serves ``/touch/get_state`` and publishes ``/touch/state`` from the perception topics.

    Attributes:
        tracker: the :class:`TouchStateTracker` holding the latest of everything.
        published: ``/touch/state`` messages published.
        queries: ``/touch/get_state`` requests answered (unknown regions included).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('touch_state', **kwargs)
        path = self._param('body_map', '', 'body map YAML for regions and centroids (default: config/bear_body.yaml)')
        self.rate_hz = self._param('rate_hz', 2.0, '/touch/state at least this often, Hz')
        self.max_rate_hz = self._param('max_rate_hz', 10.0, '/touch/state at most this often on changes, Hz')
        fqn = self.get_fully_qualified_name()
        for name in ('rate_hz', 'max_rate_hz'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ParameterError(f"parameter '{name}' of {fqn} must be a positive number of Hz; got {value!r}")
        if path and not Path(path).is_file():
            raise ParameterError(f"parameter 'body_map' of {fqn} must name an existing file; no such file: {path}")
        body = BodyMap.load(path) if path else BodyMap.default()
        self.get_logger().info(f'body map {body.source}')
        self.tracker = TouchStateTracker(body)
        self.published = 0
        self.queries = 0
        self._running = Running()
        self._sent_version = -1
        self._sent_ns = 0
        t = self.tracker
        self.create_subscription(SensorLevel, '/touch/sensor_level', t.on_sensor_level, 10)
        self.create_subscription(SymbolicGesture, '/touch/symbolic', t.on_symbolic, 50)
        self.create_subscription(TouchSubtype, '/touch/subtype', t.on_subtype, 200)
        self.create_subscription(GestureEvent, '/touch/gesture', t.on_patch_gesture, 50)
        self.create_subscription(PanelContact, '/patch/panels', t.on_panels, sensor_data_qos(10))
        self.create_subscription(SkinFrame, '/skin/frame', t.on_skin, sensor_data_qos(10))
        self.state_pub = self.create_publisher(TouchState, '/touch/state', latched_qos(1))
        self.create_service(GetTouchState, '/touch/get_state', self._on_get_state)
        self.create_timer(1.0 / max(self.rate_hz, self.max_rate_hz), self._tick)

    def _param(self, name: str, default: Any, description: str) -> Any:
        return self.declare_parameter(name, default, ParameterDescriptor(description=description,
                                                                         read_only=True)).value

    def running(self) -> Running:
        """Which parts run now; a part that stopped since the last look is forgotten."""
        now = Running(**{part: any(self.count_publishers(topic) > 0 for topic in topics)
                         for part, topics in PART_TOPICS.items()})
        for part in PART_TOPICS:
            if getattr(self._running, part) and not getattr(now, part):
                self.tracker.forget(part)
                self.get_logger().info(f'the {part} stopped publishing: its part of the state is empty now')
        self._running = now
        return now

    def _header(self) -> Any:
        return Header(stamp=self.get_clock().now().to_msg(), frame_id=self.tracker.body_map.frame_id)

    def _on_get_state(self, request: Any, response: Any) -> Any:
        self.queries += 1
        region = request.region.strip()
        problem = self.tracker.check_region(region)
        response.state = self.tracker.state(self.running(), region, self._header())
        response.success = not problem
        response.message = problem or f'{len(response.state.sensors)} active sensors, ' \
                                      f'{len(response.state.gestures)} gestures under way'
        return response

    def _tick(self) -> None:
        """Publish on a change (at most max_rate_hz: the timer's period) or when 1/rate_hz has passed."""
        running_before = self._running
        running = self.running()
        now_ns = self.get_clock().now().nanoseconds
        changed = self.tracker.version != self._sent_version or running != running_before
        if not changed and now_ns - self._sent_ns < _NS / self.rate_hz:
            return
        self._sent_version, self._sent_ns = self.tracker.version, now_ns
        self.state_pub.publish(self.tracker.state(running, '', self._header()))
        self.published += 1


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch touch_state`` / the console script."""
    return run_node(TouchStateNode, args)
