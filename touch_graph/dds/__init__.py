"""The graph on the network: Cyclone DDS with ROS 2's wire conventions.

A networked :class:`~touch_graph.runtime.Context` owns one :class:`DdsParticipant`
(:mod:`.participant` explains the design); :mod:`.names`, :mod:`.qos`, :mod:`.idl` and
:mod:`.config` hold ROS 2's conventions (topic and type names, the QoS mapping, type
descriptions, domain and discovery settings); :mod:`.discovery` publishes and reads
``ros_discovery_info`` and builds a :class:`GraphView` from DDS discovery.
"""

from .graph import UNKNOWN_NODE, EndpointInfo, GraphView, NodeInfo, TopicInfo
from .participant import DdsParticipant

__all__ = ['UNKNOWN_NODE', 'DdsParticipant', 'EndpointInfo', 'GraphView', 'NodeInfo', 'TopicInfo']
