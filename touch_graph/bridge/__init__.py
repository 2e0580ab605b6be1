"""Cross-process graph: each graph process is a peer the others reach over Unix sockets.

``Bridge(context, executor, name=...).start()`` makes a process part of its domain's graph
(see :mod:`touch_graph.bridge.bridge` for the design); ``connect_tool`` sets one up for a
command-line tool.
"""

from .bridge import Bridge, Sample, Tap
from .graph import EndpointInfo, GraphView, NodeInfo, TopicInfo

__all__ = ['Bridge', 'EndpointInfo', 'GraphView', 'NodeInfo', 'Sample', 'Tap', 'TopicInfo']
