"""rclpy's ``TopicEndpointInfo``, for ``Node.get_publishers_info_by_topic`` and ``get_subscriptions_info_by_topic``,
in process and from DDS discovery. An endpoint that announced no reliability has its kind's DDS default.

>>> _profile({}, 'SUBSCRIPTION').reliability.name, _profile({}, 'PUBLISHER').reliability.name
('BEST_EFFORT', 'RELIABLE')
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from .qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy

__all__ = ['TopicEndpointInfo', 'endpoints_info']


@dataclass
class TopicEndpointInfo:
    """One endpoint of a topic, with rclpy's attribute names (``endpoint_type``: 'PUBLISHER' or 'SUBSCRIPTION')."""

    node_name: str
    node_namespace: str
    topic_type: str
    endpoint_type: str
    endpoint_gid: list[int] = field(default_factory=list)
    qos_profile: QoSProfile = field(default_factory=QoSProfile)
    topic_type_hash: str = ''


#: Reliability of a discovered endpoint that announced none: the DDS/RTPS default of its kind (a reader
#: BEST_EFFORT, a writer RELIABLE), which the rmw layers fill in and ros2cli therefore shows.
_UNANNOUNCED_RELIABILITY = {'PUBLISHER': ReliabilityPolicy.RELIABLE, 'SUBSCRIPTION': ReliabilityPolicy.BEST_EFFORT}


def _profile(qos: dict, endpoint_type: str = 'PUBLISHER') -> QoSProfile:
    """A profile from a discovered endpoint's QoS dict; a policy it did not announce takes the DDS
    default of the endpoint's kind (``endpoint_type``: 'PUBLISHER' or 'SUBSCRIPTION')."""
    history = HistoryPolicy(qos.get('history', HistoryPolicy.KEEP_LAST))
    depth = int(qos.get('depth', 10))
    if history == HistoryPolicy.KEEP_LAST and depth < 1:
        depth = 1
    reliability = qos.get('reliability', _UNANNOUNCED_RELIABILITY[endpoint_type])
    return QoSProfile(depth=depth, history=history, reliability=ReliabilityPolicy(reliability),
                      durability=DurabilityPolicy(qos.get('durability', DurabilityPolicy.VOLATILE)))


def endpoints_info(node: Any, topic_name: str, kind: str) -> list[TopicEndpointInfo]:
    """The ``kind`` ('publishers' or 'subscriptions') of ``topic_name`` (resolved by ``node``) as the node sees them."""
    name = node.resolve_topic_name(topic_name)
    endpoint_type = 'PUBLISHER' if kind == 'publishers' else 'SUBSCRIPTION'
    view = node._graph_view()
    if view is not None:
        topic = view.topics.get(name)
        out = []
        for ep in getattr(topic, kind, []):
            namespace, _, base = ep.node.rpartition('/')
            out.append(TopicEndpointInfo(base, namespace or '/', ep.type_name, endpoint_type, list(ep.gid),
                                         _profile(ep.qos, endpoint_type), ep.type_hash))
        return out
    topic = node.context.topics.get(name)
    return [TopicEndpointInfo(ep.node.get_name(), ep.node.get_namespace(), topic.type_name, endpoint_type,
                              qos_profile=ep.qos_profile) for ep in getattr(topic, kind, [])]
