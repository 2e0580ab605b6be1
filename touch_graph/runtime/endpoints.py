"""Publishers, subscriptions and timers of the graph.

Delivery in the process is a direct queue append: ``publish`` walks the topic's
subscriptions whose QoS it matches (:func:`~.qos.incompatible_policy`, as DDS matches
them) and puts the message on each one's bounded queue (the oldest dropped and
counted when full), then tells the subscription's executor it has work. A message
published from another thread is handed to the executor's thread-safe inbox instead, so
queues are only ever touched by the thread that spins them. On a networked context each
publisher also has a DDS writer (``_dds``), which sends the message to the remote
readers, if there are any, and each subscription a DDS reader, which its executor takes
from in its own thread (:mod:`touch_graph.dds.waker`).

A subscription callback may take one argument (the message) or two (the message and a
``message_info`` dict with ``source_timestamp`` and ``received_timestamp`` in ns), as in
rclpy; the source timestamp is the publishing context's ROS time.
"""

from __future__ import annotations

import inspect
import itertools
import threading
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from .. import messages
from ..errors import GraphError
from .qos import DurabilityPolicy, QoSProfile, incompatible_policy

if TYPE_CHECKING:
    from .context import Topic
    from .executors import Executor
    from .node import Node

__all__ = ['Publisher', 'QueuedEntity', 'Subscription', 'Timer', 'warn_incompatible']

_get_ident = threading.get_ident
# Timers due at the same instant run in the order they were created (deterministic scenes).
_timer_order = itertools.count()


class Publisher:
    """``node.create_publisher(MsgType, 'topic', qos)``; ``publish(msg)`` or ``publish(cdr_bytes)``."""

    def __init__(self, node: Node, topic: Topic, qos: QoSProfile) -> None:
        self.node = node
        self.msg_type = topic.msg_type
        self.qos_profile = qos
        self._topic = topic
        self.published = 0
        self._latched: deque | None = deque(maxlen=qos.queue_bound) \
            if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL else None
        self._destroyed = False
        self._dds: Any = None  # the DDS writer, on a networked context
        self._subs_seen: tuple = ()   # the topic's subscriptions when _matched was made
        self._matched: tuple = ()     # those whose requested QoS this publisher offers

    @property
    def topic_name(self) -> str:
        return self._topic.name

    @property
    def topic(self) -> str:
        return self._topic.name

    def publish(self, msg: Any) -> None:
        """Queue ``msg`` on every subscription of the topic.

        Raises:
            TypeError: ``msg`` is neither this publisher's message type nor CDR bytes.
        """
        raw = None
        topic = self._topic
        if type(msg) is not self.msg_type:
            if not isinstance(msg, (bytes, bytearray, memoryview)):
                raise TypeError(f'{self.node.get_fully_qualified_name()} publishes {topic.type_name} on '
                                f"'{topic.name}', not {type(msg).__name__}")
            raw = msg if type(msg) is bytes else bytes(msg)  # a copy of a mutable buffer
            # Decoded only for whom needs a message: a remote reader takes the bytes as they are.
            needs_message = self._latched is not None or len(topic.subscriptions) > topic.raw_subscriptions
            msg = messages.deserialize(raw, topic.type_name) if needs_message else None
        if self._destroyed:
            raise GraphError(f"publisher on '{topic.name}' was destroyed")
        self.published += 1
        if self._latched is not None:
            self._latched.append(msg)
        if topic.subscriptions:  # in-process delivery (a node talking only to the network skips all this)
            if topic.raw_subscriptions and raw is None:
                raw = messages.serialize(msg, topic.type_name)
            node = self.node
            info = None
            if topic.info_subscriptions:
                now = node.context.now_ns()
                info = {'source_timestamp': now, 'received_timestamp': now}
            subs = topic.subscriptions
            if subs is not self._subs_seen:  # a subscription came or went: match again (DDS's rule)
                self._subs_seen, self._matched = subs, tuple(
                    sub for sub in subs if incompatible_policy(self.qos_profile, sub.qos_profile) is None)
            for sub in self._matched:
                if sub.ignore_local_publications and sub.node is node:
                    continue
                item = raw if sub.raw else msg
                sub._enqueue((item, info) if sub.with_info else item)
        dds = self._dds
        if dds is not None:
            dds.write(msg, raw)

    def get_subscription_count(self) -> int:
        """Subscriptions matched: the process's own and, on a networked context, remote DDS readers."""
        dds = self._dds
        local = sum(incompatible_policy(self.qos_profile, sub.qos_profile) is None for sub in self._topic.subscriptions)
        return local + (dds.matched() if dds is not None else 0)

    def destroy(self) -> bool:
        return self.node.destroy_publisher(self)


class QueuedEntity:
    """What an executor runs: a bounded queue of items and a handler for each (subscriptions, services, clients).

    Items are queued by the thread that spins the entity's executor; another thread hands
    them over through the executor's inbox. The executor calls ``_handler(*item)`` when
    ``_packs`` (the item is already an argument tuple), else ``_handler(item)``; ``_what``
    names the entity in error reports.

    Attributes:
        received: items queued since the entity was made.
        dropped: items dropped because the queue was full (KEEP_LAST depth reached).
    """

    _handler: Callable[..., Any]
    _packs = False
    _what = ''

    def __init__(self, node: Node, qos: QoSProfile) -> None:
        self.node = node
        self.qos_profile = qos
        self._queue: deque = deque(maxlen=qos.queue_bound)
        self._ready = False
        self.received = 0
        self.dropped = 0
        self._executor: Executor | None = None
        self._dds: Any = None  # the DDS side, on a networked context

    def _enqueue(self, item: Any) -> None:
        executor = self._executor
        if executor is not None and executor._thread_id not in (None, _get_ident()):
            executor.call_soon_threadsafe(self._enqueue_local, item)
            return
        self._enqueue_local(item)

    def _enqueue_local(self, item: Any) -> None:
        queue = self._queue
        if len(queue) == queue.maxlen:
            self.dropped += 1
        queue.append(item)
        self.received += 1
        if not self._ready:
            executor = self._executor
            if executor is not None:
                self._ready = True
                executor._ready.append(self)


class Subscription(QueuedEntity):
    """``node.create_subscription(MsgType, 'topic', callback, qos)``.

    Attributes:
        received: messages queued for this subscription since it was made.
        dropped: messages dropped because the queue was full (KEEP_LAST depth reached).
    """

    def __init__(self, node: Node, topic: Topic, callback: Callable[[Any], None], qos: QoSProfile,
                 raw: bool = False, ignore_local_publications: bool = False) -> None:
        super().__init__(node, qos)
        # rclcpp's option: skip messages published by this subscription's own node (bridges use it).
        self.ignore_local_publications = ignore_local_publications
        self.msg_type = topic.msg_type
        self.callback = callback
        self.raw = raw
        self._topic = topic
        self.with_info = _takes_message_info(callback)
        self._handler = callback
        self._packs = self.with_info  # a (msg, info) item is the argument tuple
        self._what = f"subscription to '{topic.name}'"

    @property
    def topic_name(self) -> str:
        return self._topic.name

    @property
    def topic(self) -> str:
        return self._topic.name

    def destroy(self) -> bool:
        return self.node.destroy_subscription(self)


def warn_incompatible(pub: Publisher, sub: Subscription) -> bool:
    """Log rclpy's warnings on both nodes when ``pub`` and ``sub`` cannot match; True if they cannot."""
    policy = incompatible_policy(pub.qos_profile, sub.qos_profile)
    if policy is None:
        return False
    sub.node.get_logger().warning(f"New publisher discovered on topic '{sub.topic_name}', offering incompatible QoS. "
                                  f'No messages will be received from it. Last incompatible policy: {policy}')
    pub.node.get_logger().warning(f"New subscription discovered on topic '{pub.topic_name}', requesting incompatible "
                                  f'QoS. No messages will be sent to it. Last incompatible policy: {policy}')
    return True


def _takes_message_info(callback: Callable) -> bool:
    """True for a callback that takes ``(msg, message_info)``, as rclpy allows."""
    try:
        params = list(inspect.signature(callback).parameters.values())
    except (TypeError, ValueError):  # a builtin without a signature: the one-argument form
        return False
    if any(p.kind == p.VAR_POSITIONAL for p in params):
        return False
    positional = [p for p in params if p.kind in (p.POSITIONAL_ONLY, p.POSITIONAL_OR_KEYWORD)]
    return len(positional) >= 2 and all(p.default is p.empty for p in positional[:2])


class Timer:
    """``node.create_timer(period_s, callback)``: calls ``callback()`` every period of ROS time.

    Deadlines advance by whole periods from the first one, so a timer does not drift;
    periods missed while the executor was busy are skipped (counted in ``missed``).
    """

    def __init__(self, node: Node, period_ns: int, callback: Callable[[], None], autostart: bool = True) -> None:
        if period_ns <= 0:
            raise ValueError(f'timer period must be > 0, got {period_ns} ns')
        self.node = node
        self.callback = callback
        self.timer_period_ns = period_ns
        self.missed = 0
        self.calls = 0
        self._canceled = not autostart
        self._deadline_ns = node.context.now_ns() + period_ns
        self._executor: Executor | None = None
        self._generation = 0  # bumps on reset/cancel so stale heap entries are ignored
        self._order = next(_timer_order)

    @property
    def is_ready(self) -> bool:
        return not self._canceled and self.node.context.now_ns() >= self._deadline_ns

    def is_canceled(self) -> bool:
        return self._canceled

    def cancel(self) -> None:
        self._canceled = True
        self._generation += 1

    def reset(self) -> None:
        """Restart the period from now (and un-cancel)."""
        self._canceled = False
        self._generation += 1
        self._deadline_ns = self.node.context.now_ns() + self.timer_period_ns
        if self._executor is not None:
            self._executor._schedule(self)

    def time_until_next_call(self) -> int | None:
        if self._canceled:
            return None
        return max(0, self._deadline_ns - self.node.context.now_ns())

    def _advance(self, now_ns: int) -> None:
        deadline = self._deadline_ns + self.timer_period_ns
        if deadline <= now_ns:
            skipped = (now_ns - deadline) // self.timer_period_ns + 1
            self.missed += skipped
            deadline += skipped * self.timer_period_ns
        self._deadline_ns = deadline

    def destroy(self) -> bool:
        return self.node.destroy_timer(self)
