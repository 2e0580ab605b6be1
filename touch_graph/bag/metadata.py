"""A rosbag2 bag's ``metadata.yaml`` (version 9) and what its MCAP files say about their topics.

One description of a bag for the two writers of this package: the recorder when it closes
a bag, and :func:`~touch_graph.bag.reindex.reindex` when it rebuilds one whose recorder died.
``ros2 bag info``, the rosbags reader and Foxglove read what :func:`bag_metadata` returns.

>>> topic = TopicRecord('/chatter', 'std_msgs/msg/String', 'cdr', qos_text([to_bag_qos(None)]), '', 3)
>>> info = bag_metadata([FileRecord('b.mcap', 10, 30, 3)], [topic])['rosbag2_bagfile_information']
>>> info['message_count'], info['duration'], info['topics_with_message_count'][0]['topic_metadata']['name']
(3, {'nanoseconds': 20}, '/chatter')
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

__all__ = ['DEFAULT_ROS_DISTRO', 'SCHEMA_ENCODING', 'FileRecord', 'TopicRecord', 'bag_metadata', 'qos_text',
           'ros_distro', 'serialized_metadata', 'to_bag_qos', 'type_hash', 'write_metadata']

#: MCAP schema encoding of a ROS 2 ``.msg`` definition (with its nested types), as rosbag2 writes it.
SCHEMA_ENCODING = 'ros2msg'
_ZERO = QosTime(0, 0)
#: The distribution whose wire conventions the runtime follows (GID layout, type hashes) when ``ROS_DISTRO`` is unset.
DEFAULT_ROS_DISTRO = 'jazzy'


def ros_distro(environ: Mapping[str, str] | None = None) -> str:
    """The ``ros_distro`` of a bag's metadata: ``ROS_DISTRO``, as rosbag2's writer stores it, else ``jazzy``.

    >>> ros_distro({'ROS_DISTRO': 'humble'}), ros_distro({})
    ('humble', 'jazzy')
    """
    env = os.environ if environ is None else environ
    return env.get('ROS_DISTRO', '').strip() or DEFAULT_ROS_DISTRO


def to_bag_qos(qos: Any) -> Qos:
    """A rosbags ``Qos`` from a runtime ``QoSProfile`` or its dict form (``qos_to_dict``); None -> defaults.

    >>> to_bag_qos({'depth': 5, 'reliability': 2}).reliability.name
    'BEST_EFFORT'
    """
    if qos is None:
        qos = {}
    if not isinstance(qos, dict):
        qos = {'history': int(qos.history), 'depth': int(qos.depth), 'reliability': int(qos.reliability),
               'durability': int(qos.durability)}

    def pick(enum: Any, key: str, default: int) -> Any:
        try:
            return enum(int(qos.get(key, default)))
        except (TypeError, ValueError):
            return enum(default)
    depth = qos.get('depth', 10)
    return Qos(history=pick(QosHistory, 'history', 1), depth=int(depth) if isinstance(depth, int) else 10,
               reliability=pick(QosReliability, 'reliability', 1), durability=pick(QosDurability, 'durability', 2),
               deadline=_ZERO, lifespan=_ZERO, liveliness=QosLiveliness.AUTOMATIC, liveliness_lease_duration=_ZERO,
               avoid_ros_namespace_conventions=False)


def qos_text(profiles: list[Qos]) -> str:
    """Offered QoS profiles as the YAML text rosbag2 stores in a channel's ``offered_qos_profiles``."""
    return yaml.safe_dump(dump_qos_v9(profiles), default_flow_style=False, sort_keys=False).strip()


def type_hash(type_name: str, encoding: str, definition: str) -> str:
    """RIHS01 hash of a ``.msg`` definition (with nested types); '' when it cannot be parsed."""
    if encoding != SCHEMA_ENCODING:
        return ''
    try:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(definition, type_name))
        return store.hash_rihs01(type_name)
    except Exception:  # rosbags' parser raises several kinds; a hash is optional in metadata
        return ''


@dataclass
class TopicRecord:
    """One topic of a bag: name, type, serialization format, offered QoS (YAML text), type hash, messages."""

    name: str
    type_name: str
    serialization_format: str
    qos: str
    type_description_hash: str
    message_count: int = 0


@dataclass
class FileRecord:
    """One storage file of a bag: its name, first and last log time (ns), messages."""

    path: str
    start_ns: int
    end_ns: int
    message_count: int

    @property
    def span(self) -> tuple[int, int]:
        """(start ns, duration ns); (0, 0) without messages."""
        return (self.start_ns, self.end_ns - self.start_ns) if self.message_count else (0, 0)


def _qos_list(text: str) -> list:
    try:
        return dump_qos_v9(parse_qos(text or []))
    except Exception:  # unreadable QoS text: the topic still replays
        return []


def bag_metadata(files: list[FileRecord], topics: list[TopicRecord],
                 custom_data: dict[str, str] | None = None) -> dict:
    """``metadata.yaml`` content (rosbag2 version 9, MCAP storage) of a bag of ``files`` with ``topics``.

    Times are log times (when the recorder received each message, as rosbag2's
    ``recv_timestamp``): the duration is the last receive time minus the first.
    """
    counted = [f for f in files if f.message_count]
    start = min((f.start_ns for f in counted), default=0)
    end = max((f.end_ns for f in counted), default=0)
    return {'rosbag2_bagfile_information': {
        'version': 9, 'storage_identifier': 'mcap', 'relative_file_paths': [f.path for f in files],
        'duration': {'nanoseconds': end - start}, 'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': sum(f.message_count for f in files),
        'topics_with_message_count': [
            {'topic_metadata': {'name': t.name, 'type': t.type_name, 'serialization_format': t.serialization_format,
                                'offered_qos_profiles': _qos_list(t.qos),
                                'type_description_hash': t.type_description_hash},
             'message_count': t.message_count} for t in topics],
        'compression_format': '', 'compression_mode': '',
        'files': [{'path': f.path, 'starting_time': {'nanoseconds_since_epoch': f.span[0]},
                   'duration': {'nanoseconds': f.span[1]}, 'message_count': f.message_count} for f in files],
        'custom_data': dict(custom_data) if custom_data else None, 'ros_distro': ros_distro()}}


def serialized_metadata(info: dict) -> str:
    """The bag information of ``metadata.yaml`` content as rosbag2 stores it in the MCAP file's ``rosbag2`` metadata."""
    return yaml.safe_dump(info['rosbag2_bagfile_information'], sort_keys=False).strip()


def write_metadata(bag: Path, info: dict) -> None:
    """Write ``bag/metadata.yaml`` atomically (a temporary file renamed over it) and fsync it."""
    tmp = bag / 'metadata.yaml.tmp'
    try:
        with tmp.open('w', encoding='utf-8') as f:
            yaml.safe_dump(info, f, sort_keys=False)
            f.flush()
            os.fsync(f.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)  # a half-written copy on a full disk helps nobody
        raise
    tmp.replace(bag / 'metadata.yaml')
