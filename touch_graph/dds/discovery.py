"""Graph discovery the ROS 2 way: ``ros_discovery_info`` out, builtin topics and peers' ``ros_discovery_info`` in.

Every participant publishes ``rmw_dds_common/msg/ParticipantEntitiesInfo`` on ``ros_discovery_info``
(reliable, TRANSIENT_LOCAL, depth 1): its nodes and their readers' and writers' GIDs. A GID is 24
bytes for ``ROS_DISTRO`` humble and older, else 16. When a peer's ``ros_discovery_info`` writer is
seen before its sample, a fresh reader is made (a *nudge*) so that the writer sends it at once
instead of at its next periodic heartbeat. Our participants also publish per-subscription counts
(received, dropped, undecodable) on ``/_social_touch/subscription_stats`` for ``topic info -v``.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any

import numpy as np
from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.builtin import (
    BuiltinDataReader,
    BuiltinTopicDcpsParticipant,
    BuiltinTopicDcpsPublication,
    BuiltinTopicDcpsSubscription,
)
from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from rosbags.typesys import Stores, get_typestore

from .. import messages, type_description
from ..runtime.qos import DurabilityPolicy, QoSProfile
from .cdds import delete_entity, forget, take_builtin
from .endpoints import pad4
from .graph import UNKNOWN_NODE, EndpointInfo, GraphView, NodeInfo, ServiceEndpoint
from .idl import idl_service_struct, idl_struct
from .names import ros_service_name, ros_topic_name, ros_type_name
from .qos import dds_qos, qos_to_dict

if TYPE_CHECKING:
    from .participant import DdsParticipant

__all__ = ['DISCOVERY_TOPIC', 'STATS_TOPIC', 'EntitiesInfoCodec', 'GraphDiscovery', 'gid_size']

DISCOVERY_TOPIC = 'ros_discovery_info'
ENTITIES_INFO = 'rmw_dds_common/msg/ParticipantEntitiesInfo'
STATS_TOPIC = '/_social_touch/subscription_stats'
_DIAGNOSTICS = 'diagnostic_msgs/msg/DiagnosticArray'
_ANY = SampleState.Any | ViewState.Any | InstanceState.Any
_ALIVE = InstanceState.Alive
#: How long a nudge reader (see the module's docstring) lives before it is deleted, s.
NUDGE_READER_LIFE_S = 5.0
_OLD_DISTROS = ('ardent', 'bouncy', 'crystal', 'dashing', 'eloquent', 'foxy', 'galactic', 'humble')


def gid_size(environ: Mapping[str, str] | None = None) -> int:
    """Bytes of a GID in ``ros_discovery_info``: 24 for ``ROS_DISTRO`` humble and older, else 16.

    >>> gid_size({'ROS_DISTRO': 'humble'}), gid_size({'ROS_DISTRO': 'jazzy'}), gid_size({})
    (24, 16, 16)
    """
    env = os.environ if environ is None else environ
    return 24 if env.get('ROS_DISTRO', '').strip().lower() in _OLD_DISTROS else 16


class EntitiesInfoCodec:
    """``ParticipantEntitiesInfo`` to and from CDR, in the GID layout of a distribution.

    >>> codec = EntitiesInfoCodec(16)
    >>> data = codec.encode(bytes(16), [('/', 'talker', [bytes([1] * 16)], [])])
    >>> codec.decode(data) == (bytes(16), [('/', 'talker', [bytes([1] * 16)], [])])
    True
    """

    def __init__(self, size: int) -> None:
        if size not in (16, 24):
            raise ValueError(f'a GID has 16 (Iron and later) or 24 (Humble) bytes, not {size}')
        self.size = size
        self.store = get_typestore(Stores.ROS2_HUMBLE if size == 24 else Stores.LATEST)
        self._gid = self.store.types['rmw_dds_common/msg/Gid']
        self._node = self.store.types['rmw_dds_common/msg/NodeEntitiesInfo']
        self._info = self.store.types[ENTITIES_INFO]

    def _make_gid(self, guid: bytes) -> Any:
        return self._gid(data=np.frombuffer(guid.ljust(self.size, b'\0')[:self.size], np.uint8).copy())

    def encode(self, participant: bytes, nodes: list[tuple[str, str, list[bytes], list[bytes]]]) -> bytes:
        """CDR of the participant's GID (a 16-byte GUID) and ``(namespace, name, reader GIDs, writer GIDs)``."""
        info = self._info(gid=self._make_gid(participant), node_entities_info_seq=[
            self._node(node_namespace=ns, node_name=name, reader_gid_seq=[self._make_gid(g) for g in readers],
                       writer_gid_seq=[self._make_gid(g) for g in writers])
            for ns, name, readers, writers in nodes])
        return bytes(self.store.serialize_cdr(info, ENTITIES_INFO))

    def decode(self, data: bytes) -> tuple[bytes, list[tuple[str, str, list[bytes], list[bytes]]]]:
        """The participant GUID and its nodes; GIDs cut to the 16 bytes of a GUID. Raises on bad bytes."""
        info = self.store.deserialize_cdr(data, ENTITIES_INFO)
        nodes = [(n.node_namespace, n.node_name, [bytes(g.data[:16]) for g in n.reader_gid_seq],
                  [bytes(g.data[:16]) for g in n.writer_gid_seq]) for n in info.node_entities_info_seq]
        return bytes(info.gid.data[:16]), nodes


class GraphDiscovery:
    """The graph side of a :class:`~touch_graph.dds.participant.DdsParticipant` (runs in its receive thread)."""

    def __init__(self, participant: DdsParticipant) -> None:
        self.p = participant
        self.codec = EntitiesInfoCodec(gid_size())
        self._lock = threading.Condition()
        self._participants: dict[bytes, str] = {}  # GUID -> enclave
        self._endpoints: dict[bytes, dict] = {}  # GUID -> {'kind', 'topic', 'type', 'participant', 'qos', ...}
        self._nodes_of: dict[bytes, list] = {}  # participant GUID -> its ros_discovery_info nodes
        self._info_stamp: dict[bytes, int] = {}  # participant GUID -> source time of its sample taken, ns
        self._seen_at: dict[bytes, float] = {}  # participant GUID -> when discovered (monotonic s)
        self._nudged: set[bytes] = set()  # participants a fresh info reader was made for
        self._nudge_readers: list[tuple[float, Any, int]] = []  # (made at, reader, waitset key)
        self.nudges = 0
        self._stats: dict[bytes, dict] = {}  # remote reader GUID -> its statistics
        self.version = 0  # bumps on every change (tools wait on it)
        self.structure_version = 0  # bumps when participants, endpoints or nodes change (not statistics)
        self._counts: dict[tuple[str | None, str], int] = {}  # (ROS topic, 'writer'/'reader') -> endpoints
        self._counts_version = -1  # the structure_version _counts was made at
        self.undecodable_info = 0
        self._dirty = True
        self._last_stats: Any = None
        p = participant
        store = self.codec.store
        info_topic = p.dds_topic(DISCOVERY_TOPIC, ENTITIES_INFO, store=store)
        latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
        info_hash = type_description.type_hash(ENTITIES_INFO, store) if self.codec.size == 16 else ''
        self._info_writer = DataWriter(p.dds_publisher, info_topic, dds_qos(latched, type_hash=info_hash))
        reader_qos = Qos(Policy.History.KeepAll, base=dds_qos(latched, type_hash=info_hash))
        self._info_reader = DataReader(p.dds_subscriber, info_topic, reader_qos)
        self._info_topic, self._info_reader_qos = info_topic, reader_qos
        stats_topic = p.topic(STATS_TOPIC, _DIAGNOSTICS)
        stats_hash = p.type_hash(_DIAGNOSTICS)
        self._stats_writer = DataWriter(p.dds_publisher, stats_topic, dds_qos(latched, type_hash=stats_hash))
        self._stats_reader = DataReader(p.dds_subscriber, stats_topic, dds_qos(latched, type_hash=stats_hash))
        self._builtin = {kind: BuiltinDataReader(p.participant, topic) for kind, topic in (
            ('participant', BuiltinTopicDcpsParticipant), ('writer', BuiltinTopicDcpsPublication),
            ('reader', BuiltinTopicDcpsSubscription))}
        for entity in (self._info_writer, self._info_reader, self._stats_writer, self._stats_reader,
                       *self._builtin.values()):
            forget(entity)
        self._attach(self._info_reader, lambda: self._take_info(self._info_reader))
        self._attach(self._stats_reader, self._take_stats)
        for kind, reader in self._builtin.items():
            self._attach(reader, lambda kind=kind, reader=reader: self._take_builtin(kind, reader))

    def _attach(self, reader: Any, handler: Callable[[], None]) -> tuple[int, int]:
        condition = ReadCondition(reader, _ANY)
        forget(condition)
        return condition._ref, self.p.attach(condition._ref, handler)

    # ------------------------------------------------------------------ what we publish
    def local_changed(self) -> None:
        """The context's nodes or endpoints changed: republish ``ros_discovery_info`` (any thread)."""
        self._dirty = True
        self.p.call_soon(self._publish_info)

    def _publish_info(self) -> None:
        if not self._dirty or self.p.closed:
            return
        self._dirty = False
        ddspy_write(self._info_writer._ref, pad4(self.codec.encode(self.p.gid, self.local_nodes())))
        self._changed()

    def local_nodes(self) -> list[tuple[str, str, list[bytes], list[bytes]]]:
        """``(namespace, name, reader GIDs, writer GIDs)`` of the context's nodes."""
        context = self.p.context
        out = []
        with context._lock:
            for node in list(context.nodes):
                readers = [s._dds.gid for s in list(node.subscriptions) if getattr(s, '_dds', None) is not None]
                writers = [w._dds.gid for w in list(node.publishers) if getattr(w, '_dds', None) is not None]
                for pair in [e._dds for e in (*node.services, *node.clients) if e._dds is not None]:
                    readers.append(pair.reader_gid)
                    writers.append(pair.writer_gid)
                out.append((node.get_namespace(), node.get_name(), readers, writers))
        return out

    def housekeeping(self) -> None:
        """Take pending discovery samples; republish what changed: ``ros_discovery_info``, statistics."""
        for kind, reader in self._builtin.items():
            self._take_builtin(kind, reader)
        self._drop_nudge_readers(NUDGE_READER_LIFE_S)
        self._publish_info()
        stats = self.local_stats()
        snapshot = sorted((gid, tuple(sorted(s.items()))) for gid, s in stats.items())
        if snapshot != self._last_stats:
            self._last_stats = snapshot
            self._publish_stats(stats)

    def local_stats(self) -> dict[bytes, dict[str, int]]:
        """Reader GID -> ``{'received', 'dropped', 'undecodable'}`` of each subscription of ours."""
        with self.p._lock:
            readers = list(self.p.readers.values())
        return {r.gid: {'received': r.subscription.received, 'dropped': r.subscription.dropped,
                        'undecodable': r.undecodable} for r in readers}

    def _publish_stats(self, stats: dict[bytes, dict[str, int]]) -> None:
        status_cls = messages.get_message('diagnostic_msgs/msg/DiagnosticStatus')
        value_cls = messages.get_message('diagnostic_msgs/msg/KeyValue')
        statuses = [status_cls(name='subscription', hardware_id=gid.hex(),
                               values=[value_cls(key=k, value=str(v)) for k, v in sorted(counts.items())])
                    for gid, counts in sorted(stats.items())]
        msg = messages.get_message(_DIAGNOSTICS)(status=statuses)
        ddspy_write(self._stats_writer._ref, pad4(messages.serialize(msg)))

    # ------------------------------------------------------------------ what we read
    def _take_builtin(self, kind: str, reader: Any) -> None:
        samples = take_builtin(reader, 256)
        if not samples:
            return
        with self._lock:
            for s in samples:
                key = s.key.bytes
                alive = s.sample_info.instance_state == _ALIVE and s.sample_info.valid_data
                if kind == 'participant':
                    if alive:
                        self._participants[key] = user_data_value(s.qos, 'enclave')
                        self._seen_at.setdefault(key, time.monotonic())
                    else:
                        self._participants.pop(key, None)
                        self._nodes_of.pop(key, None)
                        self._info_stamp.pop(key, None)
                        self._seen_at.pop(key, None)
                        self._nudged.discard(key)
                elif alive:
                    self._endpoints[key] = {
                        'kind': kind, 'topic': s.topic_name, 'type': s.type_name,
                        'participant': s.participant_key.bytes, 'qos': qos_to_dict(s.qos), 'qos_raw': s.qos,
                        'type_id': s.type_id, 'type_hash': user_data_value(s.qos, 'typehash')}
                else:
                    self._endpoints.pop(key, None)
                    self._stats.pop(key, None)
            waiting = {e['participant'] for e in self._endpoints.values()
                       if e['topic'] == DISCOVERY_TOPIC and e['kind'] == 'writer' and e['participant'] != self.p.gid
                       and e['participant'] not in self._nodes_of and e['participant'] not in self._nudged}
            self._nudged |= waiting
        if waiting:
            self._nudge()
        self._changed()

    def _nudge(self) -> None:
        """A fresh ``ros_discovery_info`` reader: writers that just matched it send their sample at once."""
        reader = DataReader(self.p.dds_subscriber, self._info_topic, self._info_reader_qos)
        forget(reader)
        condition_ref, key = self._attach(reader, lambda: self._take_info(reader))
        self._nudge_readers.append((time.monotonic(), reader, condition_ref, key))
        self.nudges += 1

    def _drop_nudge_readers(self, older_than_s: float) -> None:
        now = time.monotonic()
        keep = []
        for made, reader, condition_ref, key in self._nudge_readers:
            if now - made < older_than_s:
                keep.append((made, reader, condition_ref, key))
                continue
            self._take_info(reader)
            self.p.detach(condition_ref, key)
            delete_entity(reader)
        self._nudge_readers = keep

    def _take_info(self, reader: Any) -> None:
        for data, stamp in self._take_data(reader):
            try:
                gid, nodes = self.codec.decode(data)
            except Exception:  # another distribution's layout, garbage: counted, never fatal
                self.undecodable_info += 1
                continue
            with self._lock:
                if stamp >= self._info_stamp.get(gid, -1):  # two readers may hand over samples out of order
                    self._nodes_of[gid] = nodes
                    self._info_stamp[gid] = stamp
        self._changed()

    def _take_stats(self) -> None:
        for data, _ in self._take_data(self._stats_reader):
            try:
                msg = messages.deserialize(data, _DIAGNOSTICS)
                counts = {bytes.fromhex(s.hardware_id): {kv.key: int(kv.value) for kv in s.values} for s in msg.status}
            except Exception:  # a foreign writer on our hidden topic: ignore its samples
                continue
            with self._lock:
                self._stats.update(counts)
        self._changed(structure=False)

    @staticmethod
    def _take_data(reader: Any) -> list[tuple[bytes, int]]:
        """``(data, source timestamp ns)`` of the valid samples waiting on ``reader``."""
        samples = ddspy_take(reader._ref, _ANY, 256)
        if not isinstance(samples, list):
            return []
        return [(data, info.source_timestamp) for data, info in samples if info.valid_data]

    def _changed(self, structure: bool = True) -> None:
        """Wake the waiters; ``structure``: participants, endpoints or nodes changed (not only statistics)."""
        with self._lock:
            self.version += 1
            if structure:
                self.structure_version += 1
            self._lock.notify_all()

    # ------------------------------------------------------------------ queries (any thread)
    def wait_for_change(self, version: int, timeout_s: float) -> int:
        """Wait until the graph changed after ``version`` (or ``timeout_s`` passed); the current version."""
        deadline = time.monotonic() + timeout_s
        with self._lock:
            while self.version == version:
                left = deadline - time.monotonic()
                if left <= 0:
                    break
                self._lock.wait(left)
            return self.version

    def incomplete(self, grace_s: float = 1.5) -> list[bytes]:
        """Remote participants whose graph is not all here yet: no ``ros_discovery_info`` sample yet from a ROS 2
        participant (one with an ``enclave``), one with a known info writer, or a plain DDS participant younger
        than ``grace_s``; or a sample naming endpoints DDS has not shown yet. The caller bounds the wait."""
        now = time.monotonic()
        out = []
        with self._lock:
            announcing = {e['participant'] for e in self._endpoints.values()
                          if e['topic'] == DISCOVERY_TOPIC and e['kind'] == 'writer'}
            for gid, enclave in self._participants.items():
                if gid == self.p.gid:
                    continue
                nodes = self._nodes_of.get(gid)
                if nodes is None:
                    if enclave or gid in announcing or now - self._seen_at.get(gid, now) < grace_s:
                        out.append(gid)
                elif any(g not in self._endpoints for _, _, readers, writers in nodes for g in (*readers, *writers)):
                    out.append(gid)
        return out

    def count_endpoints(self, topic: str, kind: str) -> int:
        """Writers (``kind`` 'publishers') or readers ('subscriptions') of the ROS topic ``topic``, ours included,
        without building the view (a node may ask on every timer tick)."""
        with self._lock:
            if self._counts_version != self.structure_version:
                counts: dict[tuple[str | None, str], int] = {}
                for entry in self._endpoints.values():
                    key = (ros_topic_name(entry['topic']), entry['kind'])
                    counts[key] = counts.get(key, 0) + 1
                self._counts, self._counts_version = counts, self.structure_version
            return self._counts.get((topic, 'writer' if kind == 'publishers' else 'reader'), 0)

    def remote_participant_count(self) -> int:
        """How many other participants are alive in the domain (cheaper than :meth:`view`)."""
        with self._lock:
            return sum(1 for gid in self._participants if gid != self.p.gid)

    def view(self) -> GraphView:
        """The graph as this participant sees it now (its own nodes included)."""
        local_nodes = self.local_nodes()
        local_stats = self.local_stats()
        with self._lock:
            participants = dict(self._participants)
            endpoints = dict(self._endpoints)
            nodes_of = {gid: list(nodes) for gid, nodes in self._nodes_of.items()}
            stats = {**self._stats, **local_stats}
        nodes_of[self.p.gid] = local_nodes
        participants.setdefault(self.p.gid, self.p.enclave)
        view = GraphView(participants={gid.hex(): {'enclave': enclave, 'local': gid == self.p.gid}
                                       for gid, enclave in participants.items()})
        owner: dict[bytes, str] = {}
        for pgid, nodes in nodes_of.items():
            if pgid not in participants:
                continue
            for ns, name, readers, writers in nodes:
                fqn = ns.rstrip('/') + '/' + name
                node = NodeInfo(fqn, pgid.hex(), participants[pgid])
                for gid, into in [(g, node.subscriptions) for g in readers] + [(g, node.publishers) for g in writers]:
                    entry = endpoints.get(gid)
                    endpoint = self._endpoint_info(gid, entry, fqn, stats)
                    if endpoint is not None:
                        owner[gid] = fqn
                        into.append(endpoint)
                    elif entry is not None:
                        owner[gid] = fqn
                        node.add_service_endpoint(service_endpoint(gid, entry, fqn))
                view.nodes.append(node)
        for gid, entry in endpoints.items():
            endpoint = self._endpoint_info(gid, entry, owner.get(gid, UNKNOWN_NODE), stats)
            if endpoint is not None:
                view.add_endpoint(endpoint, entry['kind'])
            else:
                service = service_endpoint(gid, entry, owner.get(gid, UNKNOWN_NODE))
                if service is not None:
                    view.add_service_endpoint(service)
        view.nodes.sort(key=lambda n: (n.name, n.participant))
        return view

    @staticmethod
    def _endpoint_info(gid: bytes, entry: dict | None, node: str, stats: dict) -> EndpointInfo | None:
        if entry is None:
            return None
        topic = ros_topic_name(entry['topic'])
        if topic is None:
            return None  # ros_discovery_info, services (see service_endpoint)
        return EndpointInfo(node, entry['participant'].hex(), topic, ros_type_name(entry['type']) or entry['type'],
                            gid, entry['qos'], entry['type_hash'],
                            stats.get(gid, {}) if entry['kind'] == 'reader' else {})

    def foreign_types(self, dds_name: str, our_type: str) -> list[str]:
        """DDS type names (with their participant) of remote endpoints on DDS topic ``dds_name`` whose type is
        not ours (``our_type``: a message, or a service's request or response)."""
        struct = idl_service_struct(our_type) if '/srv/' in our_type else idl_struct(our_type)
        ours = struct.__idl__.get_type_id()
        with self._lock:
            found = {f"'{e['type']}' (participant {e['participant'].hex()})" for e in self._endpoints.values()
                     if e['topic'] == dds_name and e['participant'] != self.p.gid
                     and e['type_id'] is not None and e['type_id'] != ours}
        return sorted(found)

    def close(self) -> None:
        with self._lock:
            self._lock.notify_all()
        self._drop_nudge_readers(0.0)


def service_endpoint(gid: bytes, entry: dict | None, node: str) -> ServiceEndpoint | None:
    """The service side of a discovered reader or writer on an ``rq/``/``rr/`` topic (None for any other).

    A reader of requests or a writer of replies belongs to a server, the opposite pair to a client.
    """
    if entry is None:
        return None
    found = ros_service_name(entry['topic'])
    if found is None:
        return None
    name, kind = found
    server = (kind == 'request') == (entry['kind'] == 'reader')
    ros_type = (ros_type_name(entry['type']) or entry['type']).removesuffix('_Request').removesuffix('_Response')
    return ServiceEndpoint(node, entry['participant'].hex(), name, ros_type, 'server' if server else 'client', gid,
                           entry['kind'], user_data_value(entry.get('qos_raw'), 'serviceid' if server else 'clientid'))


def user_data_value(qos: Any, wanted: str) -> str:
    """``value`` of ``wanted=value;`` in an entity's user data (ROS 2 puts ``enclave=`` and ``typehash=`` there)."""
    data = qos[Policy.Userdata] if qos is not None else None
    text = data.data.decode(errors='replace') if data is not None else ''
    for item in text.split(';'):
        key, _, value = item.partition('=')
        if key == wanted:
            return value
    return ''
