"""What the graph commands of ``social-touch`` (topic, node, record, play) share.

:class:`GraphTool` gives a command its own wall-clock context, executor and bridge, waits
for the peers present to announce their graphs, and turns the usual mistakes into clear
errors: no graph running, an unknown topic or node (with a did-you-mean).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from typing import Any

from ..errors import GraphError
from ..runtime import Context, SingleThreadedExecutor
from ..yamlconf import did_you_mean
from .bridge import Bridge
from .discovery import domain_directory
from .graph import GraphView, TopicInfo

__all__ = ['GraphTool', 'NoGraphError']


class NoGraphError(GraphError):
    """No other graph process is running in the domain."""


class GraphTool:
    """A command-line tool's place in the graph (a context manager).

    Args:
        name: the tool's peer name (its hidden node is ``/_bridge_<name>``).
        discovery_timeout_s: how long to wait for the peers present to send their graphs.
        directory: base directory of the graph sockets (default: see :mod:`.discovery`).
    """

    def __init__(self, name: str, *, discovery_timeout_s: float = 2.0, directory: str | None = None) -> None:
        self.name = name
        self.discovery_timeout_s = discovery_timeout_s
        self.directory = directory
        self.context = Context('wall')
        self.executor: SingleThreadedExecutor | None = None
        self.bridge: Bridge | None = None

    def __enter__(self) -> GraphTool:
        self.context.init([])
        self.executor = SingleThreadedExecutor(context=self.context)
        try:
            self.bridge = Bridge(self.context, self.executor, name=f'{self.name}_{os.getpid()}',
                                 directory=self.directory).start()
        except BaseException:
            self.context.try_shutdown()
            raise
        self.bridge.wait_for_discovery(self.discovery_timeout_s)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.bridge is not None:
            self.bridge.stop()
        if self.executor is not None:
            self.executor.shutdown()
        self.context.try_shutdown()

    # ------------------------------------------------------------------ graph
    def graph(self) -> GraphView:
        return self.bridge.remote_graph()

    def no_graph_message(self) -> str:
        folder = domain_directory(self.directory, self.bridge.domain, create=False)
        return (f'no social_touch graph is running in domain {self.bridge.domain} (no peer in {folder}); start one '
                'with social-touch launch FILE (or a node with ros2 run / its console script), or check '
                'ROS_DOMAIN_ID and SOCIAL_TOUCH_GRAPH_DIR')

    def require_graph(self) -> GraphView:
        """The remote graph; NoGraphError when nobody is there."""
        if not self.bridge.peers():
            raise NoGraphError(self.no_graph_message())
        return self.graph()

    def require_topic(self, topic: str, type_name: str | None = None, wait_s: float = 0.0) -> TopicInfo:
        """The topic as the graph knows it, waiting up to ``wait_s`` for it to appear.

        Raises:
            NoGraphError: no graph running.
            GraphError: the topic is unknown (with a did-you-mean), or carries several types.
        """
        view = self.require_graph()
        if topic not in view.topics and wait_s > 0:
            self.bridge.wait_until(lambda v: topic in v.topics, wait_s)
            view = self.graph()
        info = view.topics.get(topic)
        if info is None:
            if type_name:
                return TopicInfo(topic, {type_name})
            known = sorted(view.topics)
            raise GraphError(f"unknown topic '{topic}'{did_you_mean(topic, known)}; topics in the graph: "
                             f'{", ".join(known) or "none"}')
        if len(info.types) > 1 and not type_name:
            raise GraphError(f"topic '{topic}' carries several types ({info.type_name}); name the one to use")
        return info

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
