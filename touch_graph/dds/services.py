"""The DDS side of a runtime ``Service`` and ``Client``: ROS 2's request/reply mapping, as rmw_cyclonedds does it.

A service ``/x`` is the DDS topics ``rq/xRequest`` and ``rr/xReply``; a server reads the first and
writes the second, a client the opposite. All four endpoints have the service QoS and the user data
``serviceid=...;`` or ``clientid=...;`` (how rmw_cyclonedds pairs them), then ``typehash=RIHS01_...;``.
A payload is the CDR header, ``cdds_request_header_t`` (uint64 client id, int64 sequence number),
then the fields; a reply carries its request's header back, and a client keeps the replies with its id.
A server replies once it has matched the client's reply reader (waiting up to 100 ms, as rmw does).
"""

from __future__ import annotations

import struct
import time
from collections import deque
from typing import TYPE_CHECKING, Any

from cyclonedds._clayer import ddspy_take, ddspy_write_ts
from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from .. import messages
from ..errors import MessageError
from .cdds import delete_entity, forget, matched_endpoint, matched_readers
from .discovery import user_data_value
from .endpoints import TAKE_BATCH, pad4, writer_type
from .idl import idl_service_struct, idl_struct
from .names import dds_service_topics
from .qos import dds_qos

if TYPE_CHECKING:
    from ..runtime.services import Client, Service
    from .participant import DdsParticipant

__all__ = ['FAST_DDS_REMEDY', 'MISSING_WRITE_CALL', 'REQUEST_HEADER', 'DdsClient', 'DdsService', 'decode_request',
           'encode_request', 'format_csid', 'is_fast_dds']

#: ``cdds_request_header_t``: client id (uint64), sequence number (int64), little endian after the CDR header.
REQUEST_HEADER = struct.Struct('<Qq')
_CDR_HEADER = 4
_BODY = _CDR_HEADER + REQUEST_HEADER.size
_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any
#: How long a server waits for a client's reply reader to be matched before dropping the reply, s (rmw: 100 ms).
REPLY_MATCH_WAIT_S = 0.1
#: The first two bytes of a GUID prefix are the RTPS vendor id of the participant that made it.
FAST_DDS_VENDOR = b'\x01\x0f'
#: What cyclonedds-python lacks for a Fast DDS client (named in errors and docs/ros2-services.md).
MISSING_WRITE_CALL = ('cyclonedds-python 11.0.1 cannot write a sample with the RTPS inline QoS '
                      'PID_RELATED_SAMPLE_IDENTITY (DataWriter.write has no write-params argument, and its '
                      'serdata has no get_related_sample_identity operation for Cyclone DDS to send one)')
#: How long a client waits for a Fast DDS server to match its header-less endpoints, s.
PLAIN_MATCH_WAIT_S = 1.0
#: A remedy for a Fast DDS peer, to be said with every failure about one.
FAST_DDS_REMEDY = ('run the rclpy node with RMW_IMPLEMENTATION=rmw_cyclonedds_cpp (same domain), or let the '
                   'rclpy side serve and our side call (that direction works)')


def is_fast_dds(guid: bytes) -> bool:
    """Whether an endpoint or participant GUID was made by eProsima Fast DDS (rmw_fastrtps)."""
    return bytes(guid[:2]) == FAST_DDS_VENDOR


def format_csid(guid: bytes, counter: int) -> str:
    """A client/service id as rmw_cyclonedds prints it: the participant's GUID prefix with a counter, in hex.

    >>> format_csid(bytes(range(1, 17)), 3)
    ' 1.2.3.4.5.6.7.8.9.a.b.c.0.0.0.3'
    """
    data = guid[:12] + counter.to_bytes(4, 'big')
    return f'{data[0]:2x}' + ''.join(f'.{b:x}' for b in data[1:])


def encode_request(guid: int, seq: int, body_cdr: bytes) -> bytes:
    """The payload of a request or reply: CDR header, request header, then the fields (``body_cdr`` minus its header).

    >>> encode_request(1, 2, b'\\x00\\x01\\x00\\x00\\x07').hex()
    '000100000100000000000000020000000000000007000000'
    """
    return pad4(body_cdr[:_CDR_HEADER] + REQUEST_HEADER.pack(guid, seq) + body_cdr[_CDR_HEADER:])


def decode_request(data: bytes) -> tuple[int, int, bytes]:
    """``(client id, sequence number, CDR of the fields)`` of a payload; MessageError when it is too short."""
    if len(data) < _BODY:
        raise MessageError(f'{len(data)} bytes cannot hold the {_BODY}-byte CDR and request headers')
    guid, seq = REQUEST_HEADER.unpack_from(data, _CDR_HEADER)
    return guid, seq, bytes(data[:_CDR_HEADER]) + bytes(data[_BODY:])


class _Pair:
    """A reader and a writer with one service QoS and one id, on a request/reply topic pair."""

    def __init__(self, participant: DdsParticipant, entity: Any, read_topic: str, read_type: str,
                 write_topic: str, write_type: str, role: str) -> None:
        self.entity = entity
        self.participant = participant
        self.node = entity.node
        csid = format_csid(participant.gid, next(participant.csids))
        self.csid = csid
        # ROS 2 names no fields of the request header, so a peer that describes its types may name them otherwise
        def qos_for(type_name: str) -> Qos:
            # after the id, the hash of the topic's own type (X_Request or X_Response), as Jazzy's rmw_fastrtps
            digest = participant.type_hash(type_name)
            user_data = f'{role}={csid};' + (f'typehash={digest};' if digest else '')
            return Qos(Policy.TypeConsistency.AllowTypeCoercion(ignore_member_names=True),
                       base=dds_qos(entity.qos_profile, user_data=user_data))
        self.read_topic, self.read_type = read_topic, read_type
        self.write_topic, self.write_type = write_topic, write_type
        read_struct = idl_service_struct(read_type)
        self.reader = DataReader(participant.dds_subscriber,
                                 participant.dds_topic(read_topic, read_type, struct=read_struct), qos_for(read_type))
        forget(self.reader)
        try:
            self.writer = DataWriter(participant.dds_publisher, participant.dds_topic(
                write_topic, write_type, struct=idl_service_struct(write_type)), qos_for(write_type))
        except Exception:
            delete_entity(self.reader)
            raise
        forget(self.writer)
        self.condition = ReadCondition(self.reader, _ANY_STATE)
        forget(self.condition)
        self.condition_ref = self.condition._ref
        self.ref = self.reader._ref
        self.reader_gid = self.reader.get_guid().bytes
        self.writer_gid = self.writer.get_guid().bytes
        self._now_ns = entity.node.context.now_ns
        self.waker: Any = None  # the DdsWaker of the executor taking from the reader
        self.undecodable = 0
        self.incompatible = 0
        self._reported: set[int | bytes] = set()  # writer handles or GUIDs said once
        self._fast_writers: dict[int, bool] = {}  # matched writer handle -> made by Fast DDS

    def qos_checks(self) -> list[tuple[Any, bool, str, str]]:
        """``(DDS entity, is a writer, DDS topic, type)`` whose QoS statuses the participant watches."""
        return [(self.reader, False, self.read_topic, self.read_type),
                (self.writer, True, self.write_topic, self.write_type)]

    def _graph_endpoints(self, kind: str, dds_topic: str) -> list[bytes]:
        """GUIDs of the ``kind`` ('reader'/'writer') endpoints on ``dds_topic`` that discovery knows."""
        graph = getattr(self.participant, 'graph', None)
        if graph is None:
            return []
        with graph._lock:
            return [bytes(key) for key, e in graph._endpoints.items() if e['kind'] == kind and e['topic'] == dds_topic]

    def _take(self) -> list[tuple[int, int, Any, int]]:
        """``(client id, seq, CDR of the fields, writer handle)`` of every valid sample waiting on the reader.

        A sample of a Fast DDS writer has no request header (its id travels in the RTPS inline
        QoS, which Cyclone DDS does not give us): its client id and seq are -1.
        """
        out = []
        while True:
            samples = ddspy_take(self.ref, _ANY_STATE, TAKE_BATCH)
            if not isinstance(samples, list) or not samples:
                return out
            for data, info in samples:
                if not info.valid_data:
                    continue
                handle = info.publication_handle
                if self.writer_is_fast_dds(handle):
                    out.append((-1, -1, bytes(data), handle))
                    continue
                try:
                    guid, seq, body = decode_request(data)
                    out.append((guid, seq, body, handle))
                except MessageError as err:
                    self._undecodable(handle, err)
            if len(samples) < TAKE_BATCH:
                return out

    def writer_is_fast_dds(self, handle: int) -> bool:
        """Whether the matched writer ``handle`` (of the reader's topic) is Fast DDS's (cached per writer)."""
        known = self._fast_writers.get(handle)
        if known is None:
            data = matched_endpoint(self.reader.get_matched_publication_data, handle)
            if data is None:
                return False  # gone already: its sample is taken as ours are
            known = self._fast_writers[handle] = is_fast_dds(data.key.bytes)
            if len(self._fast_writers) > 1000:
                self._fast_writers.clear()
        return known

    def _decode(self, body: bytes, handle: int) -> Any:
        try:
            return messages.deserialize(body, self.read_type)
        except MessageError as err:
            self._undecodable(handle, err)
            return None

    def _undecodable(self, writer_handle: int, err: MessageError) -> None:
        self.undecodable += 1
        if writer_handle in self._reported:
            return
        self._reported.add(writer_handle)
        self.node.get_logger().error(
            f"'{self.read_topic}': a sample from a writer of {writer_type(self.reader, writer_handle)} does not "
            f"decode as '{self.read_type}' ({err}); skipped. Further ones from it are counted.")

    def _write(self, guid: int, seq: int, msg: Any) -> bool:
        data = encode_request(guid, seq, messages.serialize(msg, self.write_type))
        return ddspy_write_ts(self.writer._ref, data, self._now_ns()) >= 0


class DdsService(_Pair):
    """The request reader and reply writer of a runtime :class:`~touch_graph.runtime.services.Service`.

    Attributes:
        gone: replies not sent because the client's request writer was gone.
        fast_dds_requests: requests of Fast DDS clients, not answered (see :data:`MISSING_WRITE_CALL`).
        unmatched: replies dropped because the client's reply reader was not matched in time.
        failed: replies DDS refused.
    """

    def __init__(self, participant: DdsParticipant, service: Service) -> None:
        request_topic, reply_topic = dds_service_topics(service.srv_name)
        super().__init__(participant, service, request_topic, f'{service.service_type}_Request',
                         reply_topic, f'{service.service_type}_Response', 'serviceid')
        self.service = service
        self.gone = self.unmatched = self.failed = self.fast_dds_requests = 0
        self._clients_seen: set[str] = set()  # client ids whose reply reader was matched

    def drain(self) -> bool:
        """Take the requests DDS holds onto the service's queue (executor thread); True if any came."""
        took = False
        for guid, seq, body, handle in self._take():
            if guid == -1:
                self._fast_dds_client(handle)
                continue
            request = self._decode(body, handle)
            if request is not None:
                self.service._enqueue_local((request, _DdsReply(self, guid, seq, handle)))
                took = True
        return took

    def _fast_dds_client(self, handle: int | bytes, counted: bool = True) -> None:
        """A Fast DDS client (or its request): it would drop any reply we can send, so none is sent; said once."""
        self.fast_dds_requests += counted
        if handle in self._reported:
            return
        self._reported.add(handle)
        self.node.get_logger().error(
            f"service '{self.service.srv_name}': requests from a Fast DDS client (rmw_fastrtps) are not answered: "
            'that client keeps only replies whose RTPS inline QoS PID_RELATED_SAMPLE_IDENTITY names it, and '
            f'{MISSING_WRITE_CALL}. Remedy: {FAST_DDS_REMEDY}. Further requests from it are counted.')

    def send_response(self, guid: int, seq: int, handle: int, response: Any) -> None:
        """Reply to request ``seq`` of client ``guid`` (its request writer is ``handle`` here)."""
        state = self._client_state(handle)
        if state == 'gone':
            self.gone += 1
            return
        if state == 'maybe':
            self.unmatched += 1
            self.node.get_logger().warn(f"service '{self.service.srv_name}': the client's reply reader was not "
                                        f'discovered within {REPLY_MATCH_WAIT_S * 1e3:.0f} ms; reply dropped',
                                        throttle_duration_sec=5.0)
            return
        if not self._write(guid, seq, response):
            self.failed += 1

    def check_clients(self) -> None:
        """Say once per client when the graph has a Fast DDS client of the service (housekeeping).

        Read from discovery: Cyclone matches a Fast DDS request writer but drops its requests
        (header-less, they fail the check against our type), so none reaches :meth:`drain`.
        """
        for key in self._graph_endpoints('writer', self.read_topic):
            if is_fast_dds(key):
                self._fast_dds_client(key, counted=False)

    def _client_state(self, handle: int) -> str:
        """'yes' (its reply reader is matched), 'gone' (its request writer left) or 'maybe' (after waiting)."""
        deadline = time.monotonic() + REPLY_MATCH_WAIT_S
        while True:
            writer = matched_endpoint(self.reader.get_matched_publication_data, handle)
            if writer is None:
                return 'gone'
            clientid = user_data_value(writer.qos, 'clientid')
            if not clientid or clientid in self._clients_seen:
                return 'yes'  # a client without an id (older rmw): assume all is well, as rmw_cyclonedds does
            for reader_handle in self.writer.get_matched_subscriptions():
                reader = matched_endpoint(self.writer.get_matched_subscription_data, reader_handle)
                if reader is not None and user_data_value(reader.qos, 'clientid') == clientid:
                    if len(self._clients_seen) > 1000:
                        self._clients_seen.clear()
                    self._clients_seen.add(clientid)
                    return 'yes'
            if time.monotonic() >= deadline:
                return 'maybe'
            time.sleep(0.01)


class _DdsReply:
    """Where a server sends the response to a request that came over DDS."""

    __slots__ = ('dds', 'guid', 'handle', 'seq')

    def __init__(self, dds: DdsService, guid: int, seq: int, handle: int) -> None:
        self.dds, self.guid, self.seq, self.handle = dds, guid, seq, handle

    def send(self, response: Any) -> None:
        self.dds.send_response(self.guid, self.seq, self.handle, response)

    def fail(self, error: BaseException) -> None:
        pass  # a remote client learns nothing (as from a ROS 2 server going away); its call times out


class DdsClient(_Pair):
    """The request writer and reply reader of a runtime :class:`~touch_graph.runtime.services.Client`.

    Attributes:
        guid: the client id in the request header (the request writer's instance handle).
        sent: requests written. foreign: replies for other clients (skipped).
    """

    def __init__(self, participant: DdsParticipant, client: Client) -> None:
        request_topic, reply_topic = dds_service_topics(client.srv_name)
        super().__init__(participant, client, reply_topic, f'{client.service_type}_Response',
                         request_topic, f'{client.service_type}_Request', 'clientid')
        self.client = client
        self.guid = self.writer.get_instance_handle() & 0xFFFF_FFFF_FFFF_FFFF  # cyclonedds-python gives it signed
        self.sent = self.foreign = 0
        self._in_flight: set[int] = set()
        self._fast_order: deque[int] = deque()  # requests sent to a Fast DDS server, oldest first
        # made when a Fast DDS server is first called: its types have no request header
        self._plain_writer: Any = None
        self._plain_reader: Any = None
        self._plain_key: Any = None

    def send_request(self, seq: int, request: Any) -> str:
        """Write the request in the convention of the server matched; '' when sent, else why it could not be.

        A Fast DDS server wants no request header and names the request of a reply only in the RTPS
        inline QoS, which Cyclone does not hand us: its replies are paired with requests in order,
        which is sound only while no other client of the service is in the graph (else this fails).
        """
        readers = self.writer.get_matched_subscriptions()
        if not readers:
            return 'no server is matched on DDS; wait_for_service() first'
        fast = [is_fast_dds(data.key.bytes) for data in
                (matched_endpoint(self.writer.get_matched_subscription_data, h) for h in readers) if data is not None]
        if any(fast):
            why = self._fast_dds_ambiguity(all(fast)) or self._plain_ready()
            if why:
                return why
            data = pad4(messages.serialize(request, self.write_type))
            self._fast_order.append(seq)  # before writing: the reply may be taken before write returns
            if ddspy_write_ts(self._plain_writer._ref, data, self._now_ns()) < 0:
                self._fast_order.pop()
                return 'DDS refused the request'
        elif not self._write(self.guid, seq, request):
            return 'DDS refused the request'
        self.sent += 1
        self._in_flight.add(seq)
        return ''

    def _fast_dds_ambiguity(self, only_fast: bool) -> str:
        """Why a reply of a Fast DDS server could not be known for ours ('' when it can)."""
        cause = ('the server runs on Fast DDS (rmw_fastrtps), whose reply names its request only in the RTPS '
                 'inline QoS PID_RELATED_SAMPLE_IDENTITY, and cyclonedds-python 11.0.1 does not return it with a '
                 'sample (its SampleInfo, like Cyclone\'s dds_sample_info_t, has no related_sample_identity)')
        if not only_fast:
            return (f'servers of two conventions (Fast DDS and Cyclone DDS) are matched, and one request cannot '
                    f'be written in both; {cause}. Remedy: {FAST_DDS_REMEDY}')
        others = self._other_clients()
        if others:
            return (f'{cause}, so its replies can be told from those to the other {others} client(s) of the '
                    f'service in the graph only by order, which is not sound. Remedy: call when no other client '
                    f'of it runs, or {FAST_DDS_REMEDY}')
        return ''

    def _plain_ready(self) -> str:
        """Make the header-less request writer and reply reader a Fast DDS server needs, and wait until it
        matched them; '' when ready, else why not (within :data:`PLAIN_MATCH_WAIT_S`)."""
        if self._plain_writer is None:
            p, qos = self.participant, self.writer.get_qos()
            struct_key = '+plain'
            self._plain_writer = DataWriter(p.dds_publisher, p.dds_topic(
                self.write_topic + struct_key, self.write_type, struct=idl_struct(self.write_type),
                dds_name=self.write_topic), qos)
            forget(self._plain_writer)
            self._plain_reader = DataReader(p.dds_subscriber, p.dds_topic(
                self.read_topic + struct_key, self.read_type, struct=idl_struct(self.read_type),
                dds_name=self.read_topic), self.reader.get_qos())
            forget(self._plain_reader)
            condition = ReadCondition(self._plain_reader, _ANY_STATE)
            forget(condition)
            self._plain_key = (condition._ref, p.attach(condition._ref, self._drain_plain))
        deadline = time.monotonic() + PLAIN_MATCH_WAIT_S
        while True:
            writers = [matched_endpoint(self._plain_reader.get_matched_publication_data, h)
                       for h in self._plain_reader.get_matched_publications()]
            if matched_readers(self._plain_writer._ref) and any(w is not None and is_fast_dds(w.key.bytes)
                                                                 for w in writers):
                return ''
            if time.monotonic() >= deadline:
                return (f'the Fast DDS server did not match our header-less request writer and reply reader '
                        f'within {PLAIN_MATCH_WAIT_S:g} s; Remedy: {FAST_DDS_REMEDY}')
            time.sleep(0.01)

    def _drain_plain(self) -> None:
        """Take the replies of a Fast DDS server (receive thread); each is the reply to our oldest request."""
        while True:
            samples = ddspy_take(self._plain_reader._ref, _ANY_STATE, TAKE_BATCH)
            if not isinstance(samples, list) or not samples:
                return
            for data, info in samples:
                if not info.valid_data:
                    continue
                seq = self._next_fast_dds_seq()
                if seq is None:
                    self.foreign += 1
                    continue
                response = self._decode(bytes(data), info.publication_handle)
                if response is not None:
                    self._in_flight.discard(seq)
                    self.client._enqueue((seq, response))
            if len(samples) < TAKE_BATCH:
                return

    def close_plain(self) -> None:
        """Delete the Fast DDS entities, if made (with the client)."""
        if self._plain_key is not None:
            self.participant.detach(*self._plain_key)
            self._plain_key = None
        for entity in (self._plain_reader, self._plain_writer):
            if entity is not None:
                delete_entity(entity)
        self._plain_reader = self._plain_writer = None

    def _other_clients(self) -> int:
        """How many reply readers of the service, other than ours, the graph knows."""
        mine = {self.reader_gid}
        if self._plain_reader is not None:
            mine.add(self._plain_reader.get_guid().bytes)
        return sum(1 for key in self._graph_endpoints('reader', self.read_topic) if key not in mine)

    def drain(self) -> bool:
        """Take the replies DDS holds; ours go onto the client's queue (executor thread). True if any did."""
        took = False
        for guid, seq, body, handle in self._take():
            if guid == -1:  # a Fast DDS reply that happened to fit the header type: the plain reader has it
                continue
            if guid != self.guid:
                self.foreign += 1
                continue
            response = self._decode(body, handle)
            if response is not None:
                self._in_flight.discard(seq)
                self.client._enqueue_local((seq, response))
                took = True
        return took

    def _next_fast_dds_seq(self) -> int | None:
        """The request a Fast DDS server's reply answers: the oldest one sent and not answered yet.

        None when it is no longer waited for (timed out, removed: the reply came late and is
        dropped) or when no request was sent (the reply is another client's).
        """
        if not self._fast_order:
            return None
        seq = self._fast_order.popleft()
        return seq if seq in self.client._pending else None

    def server_ready(self) -> bool:
        """rmw_cyclonedds' test: a matched request reader and a matched reply writer of one server (``serviceid``)."""
        try:
            readers = self.writer.get_matched_subscriptions()
            writers = self.reader.get_matched_publications()
        except Exception:  # deleted under us (shutdown)
            return False
        if not readers or not writers:
            return False
        ids = set()
        for handle in readers:
            data = matched_endpoint(self.writer.get_matched_subscription_data, handle)
            if data is not None and user_data_value(data.qos, 'serviceid'):
                ids.add(user_data_value(data.qos, 'serviceid'))
        if not ids:
            return True  # servers without ids (older rmw): matches on both topics are enough
        for handle in writers:
            data = matched_endpoint(self.reader.get_matched_publication_data, handle)
            if data is not None and user_data_value(data.qos, 'serviceid') in ids:
                return True
        return False

    def check_server(self) -> None:
        """Fail the requests under way when no server reader is matched any more (housekeeping, any thread)."""
        pending = self.client._pending
        self._in_flight = {seq for seq in self._in_flight if seq in pending}
        if self._in_flight and matched_readers(self.writer._ref) == 0:
            seqs, self._in_flight = list(self._in_flight), set()
            self.client._fail_pending('the server left the graph before replying', seqs)


