"""A snapshot of the ROS graph as DDS discovery shows it: nodes, topics, endpoints, whoever runs them.

An endpoint no node claims belongs to ROS 2's ``_NODE_NAMESPACE_UNKNOWN_/_NODE_NAME_UNKNOWN_``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ['UNKNOWN_NODE', 'EndpointInfo', 'GraphView', 'NodeInfo', 'ServiceEndpoint', 'ServiceInfo', 'TopicInfo',
           'format_gid', 'is_hidden']

#: How rmw_dds_common names the owner of an endpoint no node claims.
UNKNOWN_NODE = '/_NODE_NAMESPACE_UNKNOWN_/_NODE_NAME_UNKNOWN_'


def format_gid(gid: bytes) -> str:
    """A GID as ``ros2 topic info -v`` prints it.

    >>> format_gid(bytes(range(16)))
    '00.01.02.03.04.05.06.07.08.09.0a.0b.0c.0d.0e.0f'
    """
    return '.'.join(f'{b:02x}' for b in gid)


def is_hidden(name: str) -> bool:
    """Hidden as in ROS 2: some token of the name starts with an underscore.

    >>> is_hidden('/_social_touch/subscription_stats'), is_hidden('/touch/symbolic')
    (True, False)
    """
    return any(token.startswith('_') for token in name.split('/') if token)


@dataclass(frozen=True)
class EndpointInfo:
    """One publisher or subscription somewhere in the graph.

    Attributes:
        node: fully qualified name of the owning node (:data:`UNKNOWN_NODE` if none claims it).
        participant: the owning participant's GID as hex (a process, for ROS 2).
        qos: ``{'history', 'depth', 'reliability', 'durability'}`` as far as announced.
        stats: ``{'received', 'dropped', 'undecodable'}`` of a subscription of ours, where known.
    """

    node: str
    participant: str
    topic: str
    type_name: str
    gid: bytes = b''
    qos: dict = field(default_factory=dict, compare=False, hash=False)
    type_hash: str = field(default='', compare=False, hash=False)
    stats: dict = field(default_factory=dict, compare=False, hash=False)


@dataclass(frozen=True)
class ServiceEndpoint:
    """One DDS reader or writer of a service server or client somewhere in the graph.

    Attributes:
        role: ``'server'`` or ``'client'``; ``kind``: ``'reader'`` or ``'writer'``.
        csid: the ``serviceid``/``clientid`` the endpoint announces ('' if none), pairing its reader and writer.
    """

    node: str
    participant: str
    service: str
    type_name: str
    role: str
    gid: bytes = b''
    kind: str = 'reader'
    csid: str = ''


@dataclass
class ServiceInfo:
    """A service seen anywhere in the graph: its types, and the nodes serving and calling it."""

    name: str
    types: set[str] = field(default_factory=set)
    servers: set[str] = field(default_factory=set)
    clients: set[str] = field(default_factory=set)

    @property
    def type_name(self) -> str:
        return ' | '.join(sorted(self.types))


@dataclass
class NodeInfo:
    """A node of some participant: fully qualified name and endpoints.

    Attributes:
        services, clients: service name -> type of the services it serves and calls.
    """

    name: str
    participant: str
    enclave: str = '/'
    publishers: list[EndpointInfo] = field(default_factory=list)
    subscriptions: list[EndpointInfo] = field(default_factory=list)
    services: dict[str, str] = field(default_factory=dict)
    clients: dict[str, str] = field(default_factory=dict)

    @property
    def hidden(self) -> bool:
        return self.name.rsplit('/', 1)[-1].startswith('_')

    def add_service_endpoint(self, endpoint: ServiceEndpoint) -> None:
        (self.services if endpoint.role == 'server' else self.clients)[endpoint.service] = endpoint.type_name


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
    """Nodes and topics of a domain, as one participant sees them.

    Attributes:
        participants: GID hex -> ``{'enclave': ..., 'local': bool}`` of every live participant.
    """

    participants: dict[str, dict] = field(default_factory=dict)
    nodes: list[NodeInfo] = field(default_factory=list)
    topics: dict[str, TopicInfo] = field(default_factory=dict)
    services: dict[str, ServiceInfo] = field(default_factory=dict)

    def add_service_endpoint(self, endpoint: ServiceEndpoint) -> None:
        info = self.services.get(endpoint.service)
        if info is None:
            info = self.services[endpoint.service] = ServiceInfo(endpoint.service)
        info.types.add(endpoint.type_name)
        (info.servers if endpoint.role == 'server' else info.clients).add(endpoint.node)

    def visible_services(self, include_hidden: bool = False) -> dict[str, ServiceInfo]:
        """Services by name (``ros2 service list``: servers' and clients' alike), hidden ones on request."""
        return {name: s for name, s in sorted(self.services.items()) if include_hidden or not is_hidden(name)}

    def add_endpoint(self, endpoint: EndpointInfo, kind: str) -> None:
        info = self.topics.get(endpoint.topic)
        if info is None:
            info = self.topics[endpoint.topic] = TopicInfo(endpoint.topic)
        info.types.add(endpoint.type_name)
        (info.publishers if kind == 'writer' else info.subscriptions).append(endpoint)

    def visible_nodes(self, include_hidden: bool = False) -> list[NodeInfo]:
        return [n for n in self.nodes if include_hidden or not n.hidden]

    def visible_topics(self, include_hidden: bool = False) -> dict[str, TopicInfo]:
        return {name: t for name, t in self.topics.items() if include_hidden or not is_hidden(name)}

    def find_nodes(self, name: str) -> list[NodeInfo]:
        """Nodes named ``name`` (fully qualified; a bare name is taken as ``/name``)."""
        full = name if name.startswith('/') else '/' + name
        return [n for n in self.nodes if n.name == full]

    def published_topics(self, include_hidden: bool = False) -> dict[str, TopicInfo]:
        """Topics with at least one publisher (what ``record -a`` records)."""
        return {name: t for name, t in self.visible_topics(include_hidden).items() if t.publishers}

    def remote_participants(self) -> list[str]:
        return sorted(gid for gid, info in self.participants.items() if not info.get('local'))
