"""The ``recorder`` node: records topics of the process's graph to a rosbag2, e.g. from a launch file.

A message's log time is the context's ROS time when its callback runs, its publish time when
it was sent. To record other processes' topics use ``social-touch record`` (or ``ros2 bag record``).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from ..errors import BagError
from ..node_main import run_node
from ..offered_qos import OfferedQosSubscriptions
from ..runtime import Node, ParameterDescriptor, ParameterType
from .recorder import BagRecorder

__all__ = ['RecorderNode', 'default_bag_name', 'main', 'read_at_start']


def default_bag_name() -> str:
    """``rosbag2_YYYY_MM_DD-HH_MM_SS``, the name ``ros2 bag record`` picks."""
    return time.strftime('rosbag2_%Y_%m_%d-%H_%M_%S')


def read_at_start(node: Node, name: str, default: Any, type_: ParameterType | None = None) -> Any:
    """Declare a parameter the node reads once at start: read-only, so a later set is refused, not ignored."""
    return node.declare_parameter(name, default, ParameterDescriptor(type=int(type_ or 0), read_only=True))


class RecorderNode(Node):
    """Records topics of the process's graph to a rosbag2 (MCAP).

    Parameters: ``output`` (bag directory; default ``rosbag2_<date>``), ``topics`` (string
    array; empty: every topic a non-hidden node publishes, including ones that appear
    later), ``flush_period`` (s, default 1.0).
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('recorder', **kwargs)
        output = read_at_start(self, 'output', '').value or default_bag_name()
        self.wanted: list[str] = list(read_at_start(self, 'topics', None, ParameterType.STRING_ARRAY).value or [])
        flush_period = read_at_start(self, 'flush_period', 1.0).value
        if not flush_period > 0:
            raise ValueError(f"parameter 'flush_period' of {self.get_fully_qualified_name()} must be > 0 s, "
                             f'got {flush_period}')
        self.wanted = [self.resolve_topic_name(t) for t in self.wanted]
        clock = 'sim' if self.context.time_source.simulated else 'wall'
        self.bag = BagRecorder(output, flush_period_s=flush_period,
                               custom_data={'social_touch.clock': clock}).open()
        self.write_errors = 0
        self._recording: dict[str, Any] = {}
        # The QoS each topic's publishers offer, as rosbag2 subscribes: a best-effort sensor topic is heard.
        self.subscriptions_by_offer = OfferedQosSubscriptions(self)
        self.context.add_graph_listener(self._on_graph)
        self.context.on_shutdown(self._close_bag)
        with self.context._lock:
            topics = list(self.context.topics.values())
        for topic in topics:
            if self._wants(topic.name, topic.publishers):
                self._subscribe(topic.name)
        self.get_logger().info(f'recording {", ".join(self.wanted) or "all topics"} to {self.bag.path}')

    def _wants(self, name: str, publishers: list) -> bool:
        if name in self._recording:
            return False
        if self.wanted:
            return name in self.wanted
        return any(not p.node.get_name().startswith('_') and p.node is not self for p in publishers)

    def _on_graph(self, event: str, endpoint: Any) -> None:
        if event != 'publisher_added' or self.bag.closed:
            return
        if not self._wants(endpoint.topic_name, [endpoint]):
            return
        if self.executor is None:
            self._subscribe(endpoint.topic_name)
        else:  # the listener may run in any thread; endpoints are made in the executor's
            self.executor.call_soon_threadsafe(self._subscribe, endpoint.topic_name)

    def _subscribe(self, name: str) -> None:
        topic = self.context.topics.get(name)
        if topic is None or name in self._recording or self.bag.closed:
            return
        qos = topic.publishers[0].qos_profile if topic.publishers else None
        self.bag.add_topic(name, topic.type_name, qos)
        self._recording[name] = self.subscriptions_by_offer.create_subscription(
            topic.msg_type, name, self._writer(name, topic.type_name), 1000, raw=True)

    def _writer(self, name: str, type_name: str) -> Callable[[bytes, dict], None]:
        now_ns = self.context.now_ns
        bag = self.bag

        def write(data: bytes, message_info: dict) -> None:
            if bag.closed:
                return
            try:
                bag.write(name, type_name, now_ns(), data, publish_ns=message_info['source_timestamp'])
            except BagError as err:
                self.write_errors += 1
                if bag.full is not None:  # the disk is full: the recording has ended; say it once
                    self.get_logger().error(str(err), once=True)
                else:
                    self.get_logger().error(str(err), throttle_duration_sec=1.0)
        return write

    def _close_bag(self) -> None:
        if self.bag.closed:
            return
        self.context.remove_graph_listener(self._on_graph)
        try:
            self.bag.close()
        except BagError as err:
            self.get_logger().error(str(err))
            return
        counts = ', '.join(f'{t}: {n}' for t, n in self.bag.counts.items()) or 'nothing'
        self.get_logger().info(f'closed {self.bag.path} ({counts})')

    def destroy_node(self) -> None:
        self._close_bag()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(RecorderNode, args)
