"""The questions a graph command asks a :class:`~touch_graph.dds.graph.GraphView`, with the errors it gives,
shared by :class:`~touch_graph.dds.tool.GraphTool` and the graph daemon's client; imports no Cyclone.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from ..errors import GraphError, did_you_mean
from .graph import GraphView, TopicInfo

__all__ = ['GraphQueries', 'NoGraphError', 'no_graph_message']


class NoGraphError(GraphError):
    """No other participant is in the domain."""


def no_graph_message(domain_id: int, discovery_range: str) -> str:
    """What to say when nobody else is in domain ``domain_id``."""
    return (f'no ROS 2 graph is running in DDS domain {domain_id} (discovery range {discovery_range}); start one '
            'with social-touch launch FILE (or a node with ros2 run / its console script), or check ROS_DOMAIN_ID '
            'and ROS_AUTOMATIC_DISCOVERY_RANGE')


class GraphQueries:
    """``require_graph``, ``require_topic``, ``require_node`` and ``wait_until`` over :meth:`graph`.

    A subclass gives :meth:`graph` (the graph now), :meth:`wait_for_change` and :meth:`no_graph_message`.
    """

    def graph(self) -> GraphView:
        raise NotImplementedError

    def wait_for_change(self, timeout_s: float) -> None:
        """Return when the graph may have changed, or after ``timeout_s``."""
        raise NotImplementedError

    def no_graph_message(self) -> str:
        raise NotImplementedError

    def wait_until(self, predicate: Callable[[GraphView], bool], timeout_s: float) -> bool:
        """Wait (wall time) until ``predicate(graph())`` holds; returns its last value."""
        deadline = time.monotonic() + timeout_s
        while True:
            if predicate(self.graph()):
                return True
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self.wait_for_change(min(left, 0.25))

    def require_graph(self) -> GraphView:
        """The graph; NoGraphError when no other participant is in the domain."""
        view = self.graph()
        if not view.remote_participants():
            raise NoGraphError(self.no_graph_message())
        return view

    def require_topic(self, topic: str, type_name: str | None = None, wait_s: float = 0.0) -> TopicInfo:
        """The topic as the graph knows it, waiting up to ``wait_s`` for it to appear.

        Raises:
            NoGraphError: no graph running.
            GraphError: the topic is unknown (with a did-you-mean), or carries several types.
        """
        view = self.require_graph()
        if topic not in view.topics and wait_s > 0:
            self.wait_until(lambda v: topic in v.topics, wait_s)
            view = self.graph()
        info = view.topics.get(topic)
        if info is None:
            if type_name:
                return TopicInfo(topic, {type_name})
            known = sorted(view.visible_topics())
            raise GraphError(f"unknown topic '{topic}'{did_you_mean(topic, known)}; topics in the graph: "
                             f'{", ".join(known) or "none"}')
        if len(info.types) > 1 and not type_name:
            raise GraphError(f"topic '{topic}' carries several types ({info.type_name}); name the one to use")
        return info

    def require_node(self, name: str, include_hidden: bool = False, wait_s: float = 1.0) -> str:
        """The fully qualified name of a node of the graph (``name`` may lack the leading '/').

        Raises:
            NoGraphError: no graph running.
            GraphError: no such node (with a did-you-mean and the nodes there are).
        """
        full = name if name.startswith('/') else '/' + name
        view = self.require_graph()
        if not view.find_nodes(full) and wait_s > 0:
            self.wait_until(lambda v: bool(v.find_nodes(full)), wait_s)
            view = self.graph()
        if not view.find_nodes(full):
            known = sorted(n.name for n in view.visible_nodes(include_hidden))
            raise GraphError(f"node '{full}' not found{did_you_mean(full, known)}; nodes: {', '.join(known) or 'none'}")
        return full
