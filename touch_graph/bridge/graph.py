"""Graph snapshots (what a peer announces) and the merged view of all peers (what the CLI shows).

A snapshot is a JSON-able dict::

    {"peer": "launch.4242.0.sock", "name": "launch", "pid": 4242, "clock": "sim",
     "nodes": [{"name": "/bear/driver",
                "publishers": [["/bear/frame", "social_touch_msgs/msg/BearFrame", {"depth": 10, ...}]],
                "subscriptions": []}]}

It lists the process's own nodes and endpoints; the bridge's injected publishers and its
network-feeding subscriptions are left out (they are plumbing, not graph), but a tool's
taps (``topic echo``, ``record``) are listed as subscriptions of the bridge's hidden node,
as ``ros2 topic info`` counts an echoing ``ros2 topic echo``.

>>> snap = {'peer': 'p', 'name': 'demo', 'pid': 1, 'clock': 'wall', 'nodes': [
...     {'name': '/talker', 'publishers': [['/chatter', 'std_msgs/msg/String', {}]], 'subscriptions': []},
...     {'name': '/_bridge_demo', 'publishers': [], 'subscriptions': [['/chatter', 'std_msgs/msg/String']]}]}
>>> view = GraphView.from_snapshots([snap])
>>> [n.name for n in view.visible_nodes()], view.topics['/chatter'].type_name
(['/talker'], 'std_msgs/msg/String')
>>> len(view.topics['/chatter'].subscriptions)
1
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

from ..runtime.qos import QoSProfile

__all__ = ['EndpointInfo', 'GraphView', 'NodeInfo', 'TopicInfo', 'build_snapshot', 'qos_to_dict']


def qos_to_dict(qos: QoSProfile) -> dict[str, int]:
    """The parts of a QoS profile a bag or a remote peer needs (enum values as ints)."""
    return {'history': int(qos.history), 'depth': int(qos.depth), 'reliability': int(qos.reliability),
            'durability': int(qos.durability)}


def build_snapshot(context: Any, *, peer: str, name: str, pid: int, hidden_node: Any,
                   taps: Iterable[tuple[str, str]]) -> dict[str, Any]:
    """Snapshot of ``context``'s graph; ``hidden_node``'s own endpoints are left out, ``taps`` put in.

    Args:
        context: a :class:`touch_graph.runtime.Context` (read under its lock).
        taps: ``(topic, type_name)`` of the tool subscriptions served by the bridge itself.
    """
    nodes = []
    with context._lock:
        for node in context.nodes:
            if node is hidden_node:
                continue
            nodes.append({
                'name': node.get_fully_qualified_name(),
                'publishers': [[p.topic_name, p._topic.type_name, qos_to_dict(p.qos_profile)]
                               for p in node.publishers],
                'subscriptions': [[s.topic_name, s._topic.type_name] for s in node.subscriptions],
            })
    if hidden_node is not None:
        nodes.append({'name': hidden_node.get_fully_qualified_name(), 'publishers': [],
                      'subscriptions': [list(t) for t in sorted(set(taps))]})
    clock = 'sim' if getattr(context.time_source, 'simulated', False) else 'wall'
    return {'peer': peer, 'name': name, 'pid': pid, 'clock': clock, 'nodes': nodes}


@dataclass(frozen=True)
class EndpointInfo:
    """One publisher or subscription somewhere in the graph."""

    node: str
    peer: str
    topic: str
    type_name: str
    qos: dict[str, int] = field(default_factory=dict, compare=False, hash=False)


@dataclass
class NodeInfo:
    """A node of some peer: fully qualified name and endpoints."""

    name: str
    peer: str
    pid: int
    publishers: list[EndpointInfo] = field(default_factory=list)
    subscriptions: list[EndpointInfo] = field(default_factory=list)

    @property
    def hidden(self) -> bool:
        """Hidden as in ROS 2: the last name token starts with an underscore."""
        return self.name.rsplit('/', 1)[-1].startswith('_')


@dataclass
class TopicInfo:
    """A topic seen anywhere in the graph."""

    name: str
    types: set[str] = field(default_factory=set)
    publishers: list[EndpointInfo] = field(default_factory=list)
    subscriptions: list[EndpointInfo] = field(default_factory=list)

    @property
    def type_name(self) -> str:
        """The topic's type; several types (a misconfigured graph) are joined with ' | '."""
        return ' | '.join(sorted(self.types))


@dataclass
class GraphView:
    """Nodes and topics of a set of peers (``Bridge.remote_graph()``)."""

    peers: dict[str, dict[str, Any]] = field(default_factory=dict)
    nodes: list[NodeInfo] = field(default_factory=list)
    topics: dict[str, TopicInfo] = field(default_factory=dict)

    @classmethod
    def from_snapshots(cls, snapshots: Iterable[dict[str, Any]]) -> GraphView:
        """Merge peer snapshots; malformed entries are skipped, not fatal (a peer's bug stays its own)."""
        view = cls()
        for snap in snapshots:
            try:
                peer, pid = str(snap['peer']), int(snap.get('pid', 0))
                node_entries = list(snap.get('nodes', []))
            except (KeyError, TypeError, ValueError):
                continue
            view.peers[peer] = {k: snap.get(k) for k in ('name', 'pid', 'clock')}
            for entry in node_entries:
                try:
                    node = NodeInfo(str(entry['name']), peer, pid)
                    for item in entry.get('publishers', []):
                        qos = item[2] if len(item) > 2 and isinstance(item[2], dict) else {}
                        node.publishers.append(EndpointInfo(node.name, peer, str(item[0]), str(item[1]), qos))
                    for item in entry.get('subscriptions', []):
                        node.subscriptions.append(EndpointInfo(node.name, peer, str(item[0]), str(item[1])))
                except (KeyError, TypeError, IndexError):
                    continue
                view.nodes.append(node)
                for ep in node.publishers:
                    view._topic(ep).publishers.append(ep)
                for ep in node.subscriptions:
                    view._topic(ep).subscriptions.append(ep)
        view.nodes.sort(key=lambda n: (n.name, n.peer))
        return view

    def _topic(self, ep: EndpointInfo) -> TopicInfo:
        info = self.topics.get(ep.topic)
        if info is None:
            info = self.topics[ep.topic] = TopicInfo(ep.topic)
        info.types.add(ep.type_name)
        return info

    def visible_nodes(self, include_hidden: bool = False) -> list[NodeInfo]:
        return [n for n in self.nodes if include_hidden or not n.hidden]

    def find_nodes(self, name: str) -> list[NodeInfo]:
        """Nodes named ``name`` (fully qualified, or a bare name that is unique)."""
        full = name if name.startswith('/') else '/' + name
        return [n for n in self.nodes if n.name == full]

    def published_topics(self) -> dict[str, TopicInfo]:
        """Topics with at least one publisher (what ``record -a`` records)."""
        return {name: t for name, t in self.topics.items() if t.publishers}
