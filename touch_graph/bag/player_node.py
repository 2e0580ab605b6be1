"""The ``player`` node: replays a rosbag2 into the process's graph, e.g. from a launch file.

On a fast simulated clock replay takes no wall time and loses nothing: time jumps to the
next message only when every callback has run.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..errors import BagError, GraphError, MessageError
from ..messages import get_message
from ..node_main import run_node
from ..runtime import Node, ParameterType, QoSProfile
from .player import BagPlayer, BagTopic
from .recorder_node import read_at_start

__all__ = ['PlayerNode', 'main']



class PlayerNode(Node):
    """Republishes a bag on the graph with its recorded timing.

    Parameters: ``bag`` (required), ``rate`` (1.0), ``fast`` (false), ``fast_period``
    (s of ROS time between messages in fast mode, 0.0002), ``loop`` (false), ``topics``
    (string array; empty: all), ``start_offset`` (s, 0.0), ``wait_for_subscribers``
    (s, 0.0), ``check_definitions`` (true), ``autostart`` (true; else call :meth:`start`).

    Attributes:
        done: True once every message was published (never with ``loop``).
        published, errors, passes: counters.
    """

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('player', **kwargs)
        path = read_at_start(self, 'bag', '').value
        if not path:
            raise BagError(f"{self.get_fully_qualified_name()}: parameter 'bag' is required (the bag to play)")
        rate = read_at_start(self, 'rate', 1.0).value
        self.fast = read_at_start(self, 'fast', False).value
        fast_period = read_at_start(self, 'fast_period', 0.0002).value
        self.loop = read_at_start(self, 'loop', False).value
        topics = list(read_at_start(self, 'topics', None, ParameterType.STRING_ARRAY).value or [])
        offset = read_at_start(self, 'start_offset', 0.0).value
        self.wait_s = read_at_start(self, 'wait_for_subscribers', 0.0).value
        check = read_at_start(self, 'check_definitions', True).value
        autostart = read_at_start(self, 'autostart', True).value
        if not fast_period > 0:
            raise ValueError(f"parameter 'fast_period' must be > 0 s, got {fast_period}")
        self.player = BagPlayer(path, topics=topics or None, rate=rate, start_offset_s=offset,
                                check_definitions=check).open()
        self.done = False
        self.published = 0
        self.errors = 0
        self.passes = 0
        self._fast_period_ns = max(1, round(fast_period * 1e9))
        self._done_callbacks: list[Callable[[], None]] = []
        self._publishers = {}
        for topic in self.player.topics.values():
            msg_type = get_message(topic.type_name)
            self._publishers[topic.name] = self.create_publisher(msg_type, topic.name, QoSProfile(depth=topic.depth))
        self._iter = None
        self._next: tuple[BagTopic, int, bytes] | None = None
        self._origin_ns = 0
        self._wait_started_ns: int | None = None
        self._timer = None
        self.context.on_shutdown(self.player.close)
        if autostart:
            self.start()

    def start(self) -> None:
        """Begin replay (with ``autostart`` false, e.g. once a tool has seen its peers subscribe)."""
        if self._timer is None:
            self._timer = self.create_timer(0.001, self._tick)

    def on_done(self, callback: Callable[[], None]) -> None:
        """Call ``callback()`` when the last message was published."""
        self._done_callbacks.append(callback)

    def subscribers_ready(self) -> bool:
        return all(pub.get_subscription_count() > 0 for pub in self._publishers.values())

    def _tick(self) -> None:
        now = self.context.now_ns()
        if self._iter is None:
            if self._wait_started_ns is None:
                self._wait_started_ns = now
            if not self.subscribers_ready() and now - self._wait_started_ns < self.wait_s * 1e9:
                return  # the 1 ms startup timer polls again
            self._begin_pass(now)
        while self._next is not None:
            topic, stamp, data = self._next
            if not self.fast and self.player.play_time(stamp, self._origin_ns) > now:
                break
            self._publish(topic, data)
            self._next = next(self._iter, None)
            if self.fast:
                break
        if self._next is None:
            if not self.loop or self.published == 0:
                self._finish()
                return
            self._begin_pass(now + 1_000_000)  # a 1 ms gap between passes
        due = now + self._fast_period_ns if self.fast else self.player.play_time(self._next[1], self._origin_ns)
        self._timer.timer_period_ns = max(1, due - now)
        self._timer.reset()

    def _begin_pass(self, origin_ns: int) -> None:
        self.passes += 1
        self._iter = self.player.messages()
        self._next = next(self._iter, None)
        self._origin_ns = origin_ns

    def _publish(self, topic: BagTopic, data: bytes) -> None:
        try:
            self._publishers[topic.name].publish(data)
            self.published += 1
        except (MessageError, GraphError) as err:
            self.errors += 1
            self.get_logger().error(f"skipped a message on '{topic.name}': {err}", throttle_duration_sec=1.0)

    def _finish(self) -> None:
        self._timer.cancel()
        self.done = True
        self.get_logger().info(f'played {self.published} messages from {self.player.path}'
                               + (f' ({self.errors} unreadable, skipped)' if self.errors else ''))
        for callback in self._done_callbacks:
            callback()

    def destroy_node(self) -> None:
        self.player.close()
        super().destroy_node()


def main(args: list[str] | None = None) -> int:
    return run_node(PlayerNode, args)
