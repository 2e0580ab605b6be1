"""``foxglove_server``: every topic of the graph over the Foxglove WebSocket protocol (foxglove-sdk).

A Foxglove client (subprotocol ``foxglove.sdk.v1`` or ``foxglove.websocket.v1``) connecting to
``ws://host:port`` sees:

- every topic with a publisher, as a channel with message encoding ``cdr`` (the wire bytes, passed
  through) and a ``ros2msg`` schema (the ``.msg`` text rosbag2 stores in MCAP);
- ``/patch/activation_image`` and ``/skin/pressure_image``: the maps as ``foxglove.RawImage`` (rgb8,
  8 px per cell), at most ``image_rate_hz`` per second.

The layout ``touch_view/layouts/social_touch.json`` opens the web page's views. Every
``discovery_period_s`` (and at once when a publisher appears in this process) the node subscribes to
new topics with the QoS their publishers offer (:mod:`touch_graph.offered_qos`). Nothing is sent
before a client subscribes; the per-client queue (``backlog``) drops the oldest message for a slow
client, so the graph never waits. A client that subscribes the instant a channel is advertised may
be answered ``Unknown channel ID: N`` and must subscribe again.

Parameters: ``host`` ('127.0.0.1'), ``port`` (8765; 0: any free port), ``image_rate_hz`` (20),
``discovery_period_s`` (1.0), ``backlog`` (messages per client, 1024), ``allowed_origins`` (web pages
allowed to connect besides the Foxglove app, comma-separated; ''). Pages of other sites are refused
(:mod:`touch_view.origins`); no request changes the graph.
"""

from __future__ import annotations

import re
import time
from typing import Any

import foxglove
from foxglove.channels import RawImageChannel
from foxglove.messages import RawImage, Timestamp

from touch_graph import messages
from touch_graph.compat import Node, get_message
from touch_graph.node_main import run_node
from touch_graph.offered_qos import OfferedQosSubscriptions

from .colormap import heat_rgb
from .errors import bind_error
from .parameters import declare_listen_parameters, declare_read_only
from .ws_front import SubprotocolFront

__all__ = ['IMAGE_TOPICS', 'FoxgloveServerNode', 'main', 'ros2msg_schema']

#: frame topic -> (image topic, rows, cols, values field, mask field or None)
IMAGE_TOPICS = {
    '/patch/frame': ('/patch/activation_image', 16, 16, 'activation', 'in_outline'),
    '/skin/frame': ('/skin/pressure_image', 12, 12, 'pressure', None),
}
IMAGE_SCALE = 8
_LOOPBACK = '127.0.0.1'


def ros2msg_schema(type_name: str) -> foxglove.Schema:
    """The ``ros2msg`` schema of a type: its definition with nested types, as rosbag2 stores it in MCAP."""
    text, _digest = messages.typestore.generate_msgdef(type_name, ros_version=2)
    return foxglove.Schema(name=type_name, encoding='ros2msg', data=text.encode())


class FoxgloveServerNode(Node):
    """Serves the graph's topics to Foxglove.

    Attributes:
        server: the foxglove-sdk ``WebSocketServer`` (on a loopback port of its own).
        front: the :class:`~touch_view.ws_front.SubprotocolFront` clients connect to (``port``).
        channels: topic -> foxglove ``Channel``.
        forwarded: topic -> messages passed to the server (whether or not a client took them).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('foxglove_server', **kwargs)
        host, port = declare_listen_parameters(self, 8765)
        image_rate_hz = self._param('image_rate_hz', 20.0, 'images per second per map, at most')
        discovery_period_s = self._param('discovery_period_s', 1.0, 'how often to look for new topics, s')
        backlog = self._param('backlog', 1024, 'messages queued per client before its oldest are dropped')
        allowed_origins = tuple(o.strip() for o in str(self._param(
            'allowed_origins', '', 'web pages allowed to connect besides the Foxglove app, comma-separated '
            '(e.g. https://lichtblick.example)')).split(',') if o.strip())
        if not image_rate_hz > 0 or not discovery_period_s > 0 or backlog < 1:
            raise ValueError(f'{self.get_fully_qualified_name()}: image_rate_hz and discovery_period_s must be > 0 '
                             f'and backlog >= 1; got {image_rate_hz}, {discovery_period_s}, {backlog}')
        self._image_period_s = 1.0 / image_rate_hz
        self.fox = foxglove.Context()
        self.channels: dict[str, foxglove.Channel] = {}
        self.forwarded: dict[str, int] = {}
        self._images: dict[str, tuple[Any, float]] = {}
        self.subscriptions_by_offer = OfferedQosSubscriptions(self)  # the QoS each topic's publishers offer
        # The SDK's server on a loopback port of its own; clients connect to the front, which also serves
        # those asking for the protocol's older name (touch_view.ws_front).
        try:
            self.server = foxglove.start_server(name='social_touch', host=_LOOPBACK, port=0, context=self.fox,
                                                message_backlog_size=backlog)
        except RuntimeError as err:  # foxglove-sdk reports a bind failure as text with the OS error number
            found = re.search(r'os error (\d+)', str(err))
            if found is None:
                raise
            raise bind_error('the Foxglove server', _LOOPBACK, 0, OSError(int(found.group(1)), str(err)),
                             '--port') from err
        try:
            self.front = SubprotocolFront(host, port, self.server.port, allowed_origins)
        except OSError as err:
            self.server.stop()
            raise bind_error('the Foxglove server', host, port, err, '--port') from err
        self.create_timer(discovery_period_s, self.discover)
        if hasattr(self.context, 'add_graph_listener'):  # the shim tells at once; rclpy is polled only
            self.context.add_graph_listener(self._on_graph)
        self.discover()
        self.get_logger().info(f'Foxglove: open ws://{host}:{self.port} (Foxglove app: Open connection > '
                               'Foxglove WebSocket); layout: touch_view/layouts/social_touch.json')

    def _param(self, name: str, default: Any, description: str) -> Any:
        return declare_read_only(self, name, default, description)

    @property
    def port(self) -> int:
        """The port clients connect to."""
        return self.front.port

    # ------------------------------------------------------------------ topics
    def _on_graph(self, event: str, endpoint: Any) -> None:
        if event == 'publisher_added' and self.executor is not None:  # may run in any thread
            self.executor.call_soon_threadsafe(self.discover)

    def discover(self) -> None:
        """Subscribe to every topic with a publisher that is not served yet."""
        for name, types in self.get_topic_names_and_types():
            if name in self.channels or not types or self.count_publishers(name) == 0:
                continue
            type_name = types[0]
            try:
                msg_type = get_message(type_name)
            except Exception as err:  # a type this process does not know: say so once, serve the rest
                self.get_logger().warning(f"not serving '{name}': {err}", once=True)
                continue
            self.channels[name] = foxglove.Channel(name, schema=ros2msg_schema(type_name),
                                                   message_encoding='cdr', context=self.fox)
            self.forwarded[name] = 0
            self.subscriptions_by_offer.create_subscription(msg_type, name, self._forwarder(name), 100, raw=True)
            if name in IMAGE_TOPICS:
                image_topic = IMAGE_TOPICS[name][0]
                self._images[name] = (RawImageChannel(image_topic, context=self.fox), 0.0)
                self.subscriptions_by_offer.create_subscription(msg_type, name, self._imager(name), 5)

    def _forwarder(self, name: str) -> Any:
        channel, clock = self.channels[name], self.get_clock()

        def forward(data: bytes) -> None:
            self.forwarded[name] += 1
            if channel.has_sinks():
                channel.log(bytes(data), log_time=clock.now().nanoseconds)
        return forward

    def _imager(self, name: str) -> Any:
        _, rows, cols, field, mask_field = IMAGE_TOPICS[name]

        def image(msg: Any) -> None:
            channel, last = self._images[name]
            wall = time.monotonic()
            if wall - last < self._image_period_s or not channel.has_sinks():
                return  # throttled to the display rate; nothing to do without a viewer
            self._images[name] = (channel, wall)
            pixels = heat_rgb(getattr(msg, field), rows, cols, IMAGE_SCALE,
                              getattr(msg, mask_field) if mask_field else None)
            height, width, _ = pixels.shape
            channel.log(RawImage(timestamp=Timestamp(msg.header.stamp.sec, msg.header.stamp.nanosec),
                                 frame_id=msg.header.frame_id, width=width, height=height, encoding='rgb8',
                                 step=width * 3, data=pixels.tobytes()),
                        log_time=self.get_clock().now().nanoseconds)
        return image

    def destroy_node(self) -> None:
        if hasattr(self.context, 'remove_graph_listener'):
            self.context.remove_graph_listener(self._on_graph)
        self.front.close()
        self.server.stop()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    """``ros2 run social_touch foxglove_server`` / the ``foxglove_server`` console script."""
    return run_node(FoxgloveServerNode, args)
