"""rosbag2 record and replay: MCAP bags that ``ros2 bag``, Foxglove and rosbags open.

- :class:`BagRecorder`: writes a bag with the ``mcap`` writer, chunks with CRCs, flushed once a second
  (survives SIGKILL, see :func:`reindex`);
- :class:`BagPlayer`: reads one for replay, checking message definitions against ours;
- :class:`RecorderNode`, :class:`PlayerNode`: the ``recorder`` / ``player`` nodes for launch files;
- :func:`reindex`: rebuilds (with the ``mcap`` reader and writer) a bag whose recorder died, dropping
  chunks whose CRC does not check;
- :mod:`.metadata`: the bag's ``metadata.yaml``, written by both.
"""

from .definitions import DefinitionCheck, check_definition
from .player import BagPlayer, BagTopic, bag_info
from .recorder import BagRecorder
from .reindex import ReindexReport, reindex

__all__ = ['BagPlayer', 'BagRecorder', 'BagTopic', 'DefinitionCheck', 'PlayerNode', 'RecorderNode', 'ReindexReport',
           'bag_info', 'check_definition', 'reindex']


def __getattr__(name: str):  # the nodes import the runtime: only load them when asked for
    if name == 'PlayerNode':
        from .player_node import PlayerNode
        return PlayerNode
    if name == 'RecorderNode':
        from .recorder_node import RecorderNode
        return RecorderNode
    raise AttributeError(name)
