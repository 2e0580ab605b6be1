"""``touch_view``: a node that shows what the robot feels on a live web page.

It subscribes to the perception topics like any other node and serves a page on
``http://host:port/`` (:mod:`touch_view.server`) showing, live:

- the bear: every sensor's level, the active symbolic gestures' regions and the touch subtypes
  (``/bear/frame``, ``/touch/symbolic``, ``/touch/subtype``);
- the patch: the activation map, the panels, the class posteriors over the last 10 s with the
  events marked (``/patch/frame``, ``/patch/panels``, ``/patch/posteriors``, ``/touch/gesture``);
- the skin: the 12x12 map, the current and last gesture's trace, the force vector, the last command
  (``/skin/frame``, ``/touch/haptic_command``);
- ``/diagnostics``, a log of events, and a ``social-touch collect`` prompt (``/touch/collect_prompt``).

Only sensors with publishers or frames are shown; one silent for ``stale_after_s`` wall seconds is
marked SILENT. Callbacks only store references (:mod:`touch_view.state`); snapshots are built in the
server's threads at ``rate_hz`` at most, so the graph never waits for a page.

Parameters: ``host`` ('127.0.0.1'; '0.0.0.0' serves other machines too), ``port`` (8080; 0 picks a
free one), ``rate_hz`` (20), ``stale_after_s`` (1.0), ``max_clients`` (32), ``body_map`` and
``panels`` (config files; default the package's).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from touch_driver.bear.body_map import BodyMap
from touch_driver.patch.panels import PanelCalibrator
from touch_graph.compat import Node, get_message
from touch_graph.node_main import run_node
from touch_graph.offered_qos import OfferedQosSubscriptions

from .body_layout import VIEW_SIZE, sensor_layout
from .parameters import declare_listen_parameters, declare_read_only
from .server import ViewServer
from .state import POSTERIOR_WINDOW_S, SENSORS, ViewState

__all__ = ['TouchViewNode', 'main']

BearFrame = get_message('social_touch_msgs/msg/BearFrame')
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
PatchFrame = get_message('social_touch_msgs/msg/PatchFrame')
PanelContact = get_message('social_touch_msgs/msg/PanelContact')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
GesturePosteriors = get_message('social_touch_msgs/msg/GesturePosteriors')
SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
DiagnosticArray = get_message('diagnostic_msgs/msg/DiagnosticArray')
String = get_message('std_msgs/msg/String')
#: The prompt of a running ``social-touch collect`` session (latched; empty when it ends).
PROMPT_TOPIC = '/touch/collect_prompt'

#: How often the node asks the graph which sensors have publishers, s of ROS time.
PRESENCE_PERIOD_S = 0.5


class TouchViewNode(Node):
    """Subscribes to the perception topics and serves them as a live page.

    Attributes:
        state: the :class:`~touch_view.state.ViewState` the callbacks feed.
        server: the running :class:`~touch_view.server.ViewServer` (``server.url``).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('touch_view', **kwargs)
        host, port = declare_listen_parameters(self, 8080)
        rate_hz = self._param('rate_hz', 20.0, 'snapshots per second sent to each page, at most')
        stale_after_s = self._param('stale_after_s', 1.0, 'a sensor with no frame for this long (wall s) is SILENT')
        max_clients = self._param('max_clients', 32, 'pages served at once')
        body_path = self._param('body_map', '', "the bear's body map YAML (default: the package's)")
        panels_path = self._param('panels', '', "the patch's panels YAML (default: the package's)")
        allowed_origins = tuple(o.strip() for o in str(self._param(
            'allowed_origins', '', 'web pages allowed to open the view besides its own, comma-separated '
            '(e.g. https://dashboard.example)')).split(',') if o.strip())
        body = BodyMap.load(body_path) if body_path else BodyMap.default()
        sensors = sensor_layout(body)
        panel_names = PanelCalibrator.from_yaml(Path(panels_path) if panels_path else None).names or ()
        start_s = self.get_clock().now().nanoseconds * 1e-9
        self.state = ViewState(sensors, panel_names, stale_after_s=stale_after_s, start_s=start_s)
        config = {'bear': {'sensors': sensors, 'view_size': VIEW_SIZE, 'source': str(body.source or 'code')},
                  'patch': {'grid': [16, 16], 'panel_names': list(panel_names),
                            'posterior_window_s': POSTERIOR_WINDOW_S},
                  'skin': {'grid': [12, 12], 'side_mm': 47.0},
                  'rate_hz': rate_hz, 'stale_after_s': stale_after_s, 'node': self.get_fully_qualified_name()}
        self.server = ViewServer(self.state.snapshot, config, tick=self.state.check_silence, host=host, port=port,
                                 rate_hz=rate_hz, max_clients=max_clients, on_error=self._on_server_error,
                                 allowed_origins=allowed_origins)
        self._subscribe()
        self.create_timer(PRESENCE_PERIOD_S, self._poll_presence)
        self._poll_presence()
        self.server.start()
        self.get_logger().info(f'the touch view is on {self.server.url} (open it in a browser)')

    def _param(self, name: str, default: Any, description: str) -> Any:
        return declare_read_only(self, name, default, description)

    def _subscribe(self) -> None:
        # Every subscription takes the QoS its publishers offer (best effort for the sensors' frames, latched
        # for the prompt), so frames from a graph in another process or on real rclpy arrive.
        state, subs = self.state, OfferedQosSubscriptions(self)
        start = SymbolicGesture.START
        subs.create_subscription(BearFrame, SENSORS['bear'], state.on_bear_frame, 5)
        decided = (start, SymbolicGesture.END)           # candidates are not shown
        subs.create_subscription(SymbolicGesture, '/touch/symbolic',
                                 lambda m: state.on_symbolic(m, start) if m.state in decided else None, 50)
        subs.create_subscription(TouchSubtype, '/touch/subtype', state.on_subtype, 200)
        subs.create_subscription(PatchFrame, SENSORS['patch'], state.on_patch_frame, 5)
        subs.create_subscription(PanelContact, '/patch/panels', state.on_panels, 50)
        subs.create_subscription(GesturePosteriors, '/patch/posteriors', state.on_posteriors, 50)
        subs.create_subscription(GestureEvent, '/touch/gesture', state.on_gesture, 50)
        subs.create_subscription(SkinFrame, SENSORS['skin'], state.on_skin_frame, 20)
        subs.create_subscription(HapticCommand, '/touch/haptic_command', state.on_command, 50)
        subs.create_subscription(DiagnosticArray, '/diagnostics', state.on_diagnostics, 50)
        subs.create_subscription(String, PROMPT_TOPIC, state.on_prompt, 1)
        self.subscriptions_by_offer = subs

    def _poll_presence(self) -> None:
        for sensor, topic in SENSORS.items():
            self.state.set_publishers(sensor, self.count_publishers(topic))

    def _on_server_error(self, text: str) -> None:
        self.get_logger().error(text, throttle_duration_sec=5.0)

    @property
    def url(self) -> str:
        return self.server.url

    def destroy_node(self) -> None:
        self.server.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch touch_view`` / the ``touch_view`` console script."""
    return run_node(TouchViewNode, args)
