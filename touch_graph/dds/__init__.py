"""The graph on the network: Cyclone DDS with ROS 2's wire conventions.

A networked :class:`~touch_graph.runtime.Context` owns one :class:`DdsParticipant`
(:mod:`.participant` explains the design); :mod:`.names`, :mod:`.qos`, :mod:`.idl` and
:mod:`.config` hold ROS 2's conventions (topic and type names, the QoS mapping, type
descriptions, domain and discovery settings); :mod:`.discovery` publishes and reads
``ros_discovery_info`` and builds a :class:`GraphView` from DDS discovery.
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
