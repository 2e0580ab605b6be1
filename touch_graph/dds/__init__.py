"""The graph on the network: Cyclone DDS with ROS 2's wire conventions (names, QoS, type descriptions,
discovery); a networked :class:`~touch_graph.runtime.Context` owns one :class:`DdsParticipant`.
"""

from typing import Any

from .graph import UNKNOWN_NODE, EndpointInfo, GraphView, NodeInfo, TopicInfo

__all__ = ['UNKNOWN_NODE', 'DdsParticipant', 'EndpointInfo', 'GraphView', 'NodeInfo', 'TopicInfo']


def __getattr__(name: str) -> Any:
    # Cyclone loads with the participant only: the graph daemon's clients read graph views and nothing else.
    if name == 'DdsParticipant':
        from .participant import DdsParticipant  # lazy: see above
        return DdsParticipant
    raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
