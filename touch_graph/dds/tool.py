"""A place in the DDS graph for the graph commands (topic, node, param, service, record, play).

:class:`GraphTool` gives a command a networked context with a hidden node
(``/_social_touch_<command>_<pid>``), waits until discovery is complete (bounded), and turns
the usual mistakes into clear errors: no graph, an unknown topic, node or service.
"""

from __future__ import annotations

import os
import re
import time
from collections.abc import Callable
from typing import Any

from ..errors import GraphError
from ..offered_qos import OfferedQosSubscriptions
from ..runtime import Context, Node, SingleThreadedExecutor
from .cdds import wait_for_acks
from .graph import GraphView
from .graph_queries import GraphQueries, NoGraphError, no_graph_message

__all__ = ['GraphTool', 'NoGraphError', 'wait_for_complete_graph']

#: Discovery counts as settled when the graph has not changed for this long, s.
SETTLE_S = 0.3
#: The longest a tool waits for participants found to announce their nodes and endpoints, s.
COMPLETE_TIMEOUT_S = 5.0


def wait_for_complete_graph(discovery: Any, timeout_s: float, *, started: float | None = None,
                            last_change: float | None = None) -> bool:
    """Wait until ``discovery``'s graph is complete, or ``timeout_s`` passed with nobody found; True if anyone is
    there.

    Complete: someone was found, every participant found has announced its nodes and DDS has shown
    their endpoints (:meth:`~touch_graph.dds.discovery.GraphDiscovery.incomplete`), and no participant,
    endpoint or node changed for :data:`SETTLE_S`. Once someone is found, waiting for the rest takes at most
    :data:`COMPLETE_TIMEOUT_S` more.

    Args:
        discovery: a :class:`~touch_graph.dds.discovery.GraphDiscovery`.
        timeout_s: how long after ``started`` to wait while nobody is found, s.
        started: when the participant joined (``time.monotonic()``; default now).
        last_change: when the graph last changed (monotonic; default now, as for a participant that just joined).
    """
    now = time.monotonic()
    start = now if started is None else started
    last_change = now if last_change is None else last_change
    version = discovery.version
    structure = discovery.structure_version
    found_at: float | None = None
    while True:
        now = time.monotonic()
        if discovery.remote_participant_count():
            found_at = now if found_at is None else found_at
            if now - last_change >= SETTLE_S and not discovery.incomplete():
                break
            if now - found_at >= COMPLETE_TIMEOUT_S:
                break
        elif now - start >= timeout_s:
            break
        version = discovery.wait_for_change(version, SETTLE_S / 3)
        if discovery.structure_version != structure:  # statistics flowing in are no news
            structure, last_change = discovery.structure_version, time.monotonic()
    return discovery.remote_participant_count() > 0


class GraphTool(GraphQueries):
    """A command-line tool's place in the graph (a context manager).

    Args:
        name: the command (``topic_echo``); its node is ``/_social_touch_<name>_<pid>``.
        discovery_timeout_s: how long to wait for discovery when nobody answers (wall time).
    """

    def __init__(self, name: str, *, discovery_timeout_s: float = 2.0) -> None:
        self.name = re.sub(r'\W', '_', name)
        self.discovery_timeout_s = discovery_timeout_s
        self.context = Context('wall', network=True)
        self.executor: Any = None
        self.node: Any = None
        self._clients: dict[tuple[str, int], Any] = {}
        self._adapted: Any = None

    def __enter__(self) -> GraphTool:
        self.context.init([])
        try:
            self.executor = SingleThreadedExecutor(context=self.context)
            # ros2cli's nodes serve no parameters and log nowhere but the console; neither do these
            self.node = Node(f'_social_touch_{self.name}_{os.getpid()}', context=self.context,
                             start_parameter_services=False, enable_rosout=False)
            self.executor.add_node(self.node)
            self.wait_for_discovery(self.discovery_timeout_s)
        except BaseException:
            self.context.try_shutdown()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        if self.node is not None:
            self.node.destroy_node()
        if self.executor is not None:
            self.executor.shutdown()
        self.context.try_shutdown()

    # ------------------------------------------------------------------ graph
    @property
    def discovery(self) -> Any:
        return self.context.transport.graph

    def graph(self) -> GraphView:
        return self.discovery.view()

    def wait_for_discovery(self, timeout_s: float) -> bool:
        """Wait until the graph is complete or ``timeout_s`` passes with nobody found; True if anyone is there
        (:func:`wait_for_complete_graph`)."""
        return wait_for_complete_graph(self.discovery, timeout_s)

    def wait_for_change(self, timeout_s: float) -> None:
        self.discovery.wait_for_change(self.discovery.version, timeout_s)

    def no_graph_message(self) -> str:
        transport = self.context.transport
        return no_graph_message(transport.domain_id, transport.discovery_options.range)

    def call(self, srv_type: Any, service: str, request: Any, timeout_s: float) -> Any:
        """Call ``service`` and return the response, waiting at most ``timeout_s`` for the server and again
        for the response (wall time).

        Raises:
            GraphError: no server within the timeout (naming the service and how to look for it), no
                response within it, or the server left mid-call (ServiceCallError).
        """
        client = self._clients.get((service, id(srv_type)))
        if client is None:
            client = self._clients[(service, id(srv_type))] = self.node.create_client(srv_type, service)
        if not client.wait_for_service(timeout_s):
            raise GraphError(f"service '{service}' is not available (waited {timeout_s:g} s); see social-touch "
                             'service list, or wait longer with --timeout')
        future = client.call_async(request)
        self.executor.spin_until_future_complete(future, timeout_s)
        if not future.done():
            client.remove_pending_request(future)
            raise GraphError(f"service '{service}' did not answer within {timeout_s:g} s (is its node's executor "
                             'busy or stuck?); try again with a longer --timeout')
        return future.result()

    def subscribe(self, msg_type: type, topic: str, callback: Callable[..., None], depth: int = 100,
                  **kwargs: Any) -> Any:
        """Subscribe with the QoS the topic's publishers offer, remade when a later publisher needs another
        (:class:`~touch_graph.offered_qos.OfferedQosSubscriptions`; ``kwargs`` e.g. ``raw=True``)."""
        if self._adapted is None:
            self._adapted = OfferedQosSubscriptions(self.node)
        return self._adapted.create_subscription(msg_type, topic, callback, depth, **kwargs)

    # ------------------------------------------------------------------ spinning
    def spin_until(self, predicate: Callable[[], bool], timeout_s: float | None, stop: Any = None,
                   every: Callable[[], None] | None = None, every_s: float = 1.0) -> bool:
        """Spin until ``predicate()``, a stop request or ``timeout_s`` (wall); call ``every()`` each ``every_s``."""
        start = time.monotonic()
        next_every = start + every_s
        while not predicate():
            if stop is not None and stop.requested:
                return False
            now = time.monotonic()
            if timeout_s is not None and now - start >= timeout_s:
                return predicate()
            if every is not None and now >= next_every:
                every()
                next_every = now + every_s
            self.executor.spin_once(0.05)
        return True

    def flush(self, publishers: list[Any], timeout_s: float = 2.0) -> bool:
        """Wait until every reliable remote reader acknowledged what ``publishers`` wrote (before exiting)."""
        deadline = time.monotonic() + timeout_s
        acked = True
        for pub in publishers:
            dds = getattr(pub, '_dds', None)
            if dds is not None:
                left = max(0.0, deadline - time.monotonic())
                acked = wait_for_acks(dds.ref, int(left * 1e9)) and acked
        return acked
