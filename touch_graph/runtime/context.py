"""The graph a set of nodes share (rclpy's ``Context``): topics, nodes, time, and the shutdown flag.

Publishing queues the message on each subscription of the topic without copying or serialising
it. An initialised context joins the DDS domain unless ``network=False``; with ``network=None`` a
wall-clock context joins and a simulated one does not, and ``SOCIAL_TOUCH_NETWORK=0`` keeps every
context not told otherwise off the network.
"""

from __future__ import annotations

import math
import os
import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..errors import GraphError
from .clock import SimTimeSource, TimeSource, WallTimeSource
from .logging import set_default_level
from .parameters import RosArgs, parse_ros_args

if TYPE_CHECKING:
    from .node import Node, Publisher, Subscription

__all__ = ['Context', 'ExternalShutdownException', 'Topic', 'get_default_context', 'network_default']


class ExternalShutdownException(Exception):
    """Raised out of spin when the context was shut down from elsewhere (rclpy's name)."""


def network_default(clock_mode: str) -> bool:
    """Whether a context joins the DDS domain when its constructor was not told (see the module doc)."""
    if os.environ.get('SOCIAL_TOUCH_NETWORK', '').strip().lower() in ('0', 'off', 'false', 'no'):
        return False
    return clock_mode == 'wall'


class Topic:
    """A topic of the in-process graph: name, message type, endpoints."""

    __slots__ = ('info_subscriptions', 'latched', 'msg_type', 'name', 'publishers', 'raw_subscriptions',
                 'subscriptions', 'type_name')

    def __init__(self, name: str, msg_type: type) -> None:
        self.name = name
        self.msg_type = msg_type
        self.type_name: str = msg_type.__msgtype__
        self.publishers: list[Publisher] = []
        # Kept as tuples, rebuilt on change, so publish() iterates without copying.
        self.subscriptions: tuple[Subscription, ...] = ()
        self.raw_subscriptions = 0
        self.info_subscriptions = 0  # subscriptions whose callback takes (msg, message_info)

    def endpoint_count(self) -> int:
        return len(self.publishers) + len(self.subscriptions)


class Context:
    """A ROS graph of nodes, in memory inside the process and on DDS beyond it.

    Args:
        clock_mode: ``'wall'`` (ROS time is the system clock) or ``'sim'`` (simulated time,
            see :class:`~touch_graph.runtime.clock.SimTimeSource`).
        rate: for ``'sim'``, how many times faster than real time (``math.inf``: as fast as
            the work allows, deterministic).
        start_s: for ``'sim'``, the simulated epoch in seconds.
        network: join the DDS domain at :meth:`init` (None: see :func:`network_default`).
        domain_id: the DDS domain (default ``$ROS_DOMAIN_ID``, else 0).

    Attributes:
        transport: the :class:`~touch_graph.dds.DdsParticipant` while initialised on the network, else None.
    """

    def __init__(self, clock_mode: str = 'wall', rate: float = math.inf, start_s: float = 1_700_000_000.0, *,
                 network: bool | None = None, domain_id: int | None = None) -> None:
        if clock_mode == 'wall':
            self.time_source: TimeSource = WallTimeSource()
        elif clock_mode == 'sim':
            self.time_source = SimTimeSource(start_s=start_s, rate=rate)
        else:
            raise ValueError(f"clock_mode must be 'wall' or 'sim', got {clock_mode!r}")
        self._ok = False
        self._lock = threading.RLock()
        self.topics: dict[str, Topic] = {}
        self.nodes: list[Node] = []
        self._services: dict[str, list[Any]] = {}  # name -> servers in this context, first one answers
        self.global_args = RosArgs()
        self.callback_errors = 0
        self._shutdown_callbacks: list[Callable[[], None]] = []
        self._graph_listeners: list[Callable[[str, Any], None]] = []
        self.network = network_default(clock_mode) if network is None else bool(network)
        self.domain_id = domain_id
        self.transport: Any = None

    # ------------------------------------------------------------------ lifecycle
    def init(self, args: list[str] | None = None) -> None:
        """Start the context; ``args`` may hold ``--ros-args`` for every node in it."""
        with self._lock:
            if self._ok:
                raise GraphError('context is already initialised; call shutdown() first')
            self.global_args = parse_ros_args(args)
            self.global_args.overrides()  # reads the files now: a bad file fails init, not the first node
            if self.global_args.log_level:
                set_default_level(self.global_args.log_level)
            if self.network:
                from ..dds import DdsParticipant  # deferred: in-process graphs never load Cyclone
                self.transport = DdsParticipant(self, domain=self.domain_id)
            self._ok = True

    def ok(self) -> bool:
        return self._ok

    def shutdown(self) -> None:
        """Stop the context: spinning executors return, shutdown callbacks run once."""
        with self._lock:
            if not self._ok:
                raise GraphError('context is not initialised (already shut down?)')
            self._ok = False
            callbacks, self._shutdown_callbacks = self._shutdown_callbacks, []
        try:
            for callback in callbacks:
                callback()
        finally:
            transport, self.transport = self.transport, None
            if transport is not None:
                transport.close()

    def try_shutdown(self) -> None:
        if self._ok:
            self.shutdown()

    def on_shutdown(self, callback: Callable[[], None]) -> None:
        self._shutdown_callbacks.append(callback)

    # ------------------------------------------------------------------ graph
    def now_ns(self) -> int:
        return self.time_source.now_ns()

    def add_graph_listener(self, listener: Callable[[str, Any], None]) -> None:
        """``listener(event, endpoint)`` on every endpoint or node added/removed (the DDS transport, recorders)."""
        self._graph_listeners.append(listener)

    def remove_graph_listener(self, listener: Callable[[str, Any], None]) -> None:
        if listener in self._graph_listeners:
            self._graph_listeners.remove(listener)

    def _notify(self, event: str, endpoint: Any) -> None:
        for listener in list(self._graph_listeners):
            listener(event, endpoint)

    def _topic_for(self, name: str, msg_type: type, who: str) -> Topic:
        topic = self.topics.get(name)
        type_name = getattr(msg_type, '__msgtype__', None)
        if type_name is None:
            raise GraphError(f'{who}: {msg_type!r} is not a message class (use touch_graph.compat.get_message)')
        if topic is None:
            topic = self.topics[name] = Topic(name, msg_type)
        elif topic.type_name != type_name:
            users = [p.node.get_fully_qualified_name() for p in topic.publishers] + \
                    [s.node.get_fully_qualified_name() for s in topic.subscriptions]
            raise GraphError(f"{who}: topic '{name}' already carries {topic.type_name} (used by "
                             f'{", ".join(users) or "nobody"}), not {type_name}; remap one of them')
        elif topic.msg_type is not msg_type:
            raise GraphError(f"{who}: topic '{name}': two different classes claim {type_name}")
        return topic

    def _add_service(self, service: Any, who: str) -> None:
        servers = self._services.setdefault(service.srv_name, [])
        if servers and servers[0].service_type != service.service_type:
            raise GraphError(f"{who}: service '{service.srv_name}' is already served as {servers[0].service_type} by "
                             f'{servers[0].node.get_fully_qualified_name()}, not {service.service_type}; remap one')
        servers.append(service)

    def _remove_service(self, service: Any) -> None:
        servers = self._services.get(service.srv_name, [])
        if service in servers:
            servers.remove(service)
        if not servers:
            self._services.pop(service.srv_name, None)

    def _drop_topic_if_unused(self, topic: Topic) -> None:
        if topic.endpoint_count() == 0 and self.topics.get(topic.name) is topic:
            del self.topics[topic.name]

    def topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        with self._lock:
            return sorted((name, [t.type_name]) for name, t in self.topics.items())


_default_context: Context | None = None
_default_lock = threading.Lock()


def get_default_context() -> Context:
    """The process-wide context ``init()`` starts when none is given."""
    global _default_context
    with _default_lock:
        if _default_context is None:
            _default_context = Context()
        return _default_context


def reset_default_context(context: Context | None = None) -> None:
    """Replace the default context (tests; ``social-touch`` commands choosing a clock)."""
    global _default_context
    with _default_lock:
        _default_context = context
