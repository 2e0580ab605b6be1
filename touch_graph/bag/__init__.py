"""rosbag2 record and replay: MCAP bags that ``ros2 bag``, Foxglove and rosbags open."""

from .definitions import DefinitionCheck, check_definition
from .player import BagPlayer, BagTopic, bag_info
from .recorder import BagRecorder
from .reindex import ReindexReport, reindex

__all__ = ['BagPlayer', 'BagRecorder', 'BagTopic', 'DefinitionCheck', 'PlayerNode', 'RecorderNode', 'ReindexReport',
           'bag_info', 'check_definition', 'reindex']


def __getattr__(name: str):  # the nodes import the runtime: only load them when asked for
    if name == 'PlayerNode':
        from .player_node import PlayerNode  # lazy: see __getattr__
        return PlayerNode
    if name == 'RecorderNode':
        from .recorder_node import RecorderNode  # lazy: see __getattr__
        return RecorderNode
    raise AttributeError(name)
