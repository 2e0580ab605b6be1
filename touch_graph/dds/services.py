"""The DDS side of a runtime ``Service`` and ``Client``: ROS 2's request/reply mapping, as rmw_cyclonedds does it.

A service ``/x`` is two DDS topics, ``rq/xRequest`` (type ``pkg::srv::dds_::T_Request_``)
and ``rr/xReply`` (``pkg::srv::dds_::T_Response_``). A server has a reader on the first and
a writer on the second, a client the opposite; all four have the service QoS (reliable,
volatile, keep last 10 by default) and, as user data, ``serviceid=...;`` or
``clientid=...;`` (one id for the reader and the writer of one server or client), which is
how rmw_cyclonedds pairs them.

**On the wire** (rmw_cyclonedds ``serdata.cpp`` / ``Serialization.cpp``): the 4-byte CDR
encapsulation header, then the request header ``cdds_request_header_t`` (uint64 client id
= the instance handle of the client's request writer, int64 sequence number), then the
request's or response's fields. A reply carries the header of its request back; every
client of the service receives every reply and keeps those with its own id. The header is
16 bytes, so the fields keep the alignment they have on their own: they are rosbags' CDR
bytes after its encapsulation header.

**A server** replies only once it has matched the client's reply reader (rmw_cyclonedds
waits up to 100 ms for that, then drops the reply; a client whose request writer is gone
gets nothing). **A client** is ready when it matched a server's request reader and reply
writer with the same ``serviceid``; a request it sends with no server reader matched
fails at once, and when the server's reader goes away with requests under way, those fail
at the next housekeeping round (:meth:`DdsClient.check_server`).
"""

from __future__ import annotations

import struct
import time
from typing import TYPE_CHECKING, Any

from cyclonedds._clayer import ddspy_take, ddspy_write_ts
from cyclonedds.core import InstanceState, Policy, Qos, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from .. import messages
from ..errors import MessageError
from .cdds import forget, matched_endpoint, matched_readers
from .discovery import user_data_value
from .endpoints import TAKE_BATCH, pad4, writer_type
from .idl import idl_service_struct
from .names import dds_service_topics
from .qos import dds_qos

if TYPE_CHECKING:
    from ..runtime.services import Client, Service
    from .participant import DdsParticipant

__all__ = ['REQUEST_HEADER', 'DdsClient', 'DdsService', 'decode_request', 'encode_request', 'format_csid']

#: ``cdds_request_header_t``: client id (uint64), sequence number (int64), little endian after the CDR header.
REQUEST_HEADER = struct.Struct('<Qq')
_CDR_HEADER = 4
_BODY = _CDR_HEADER + REQUEST_HEADER.size
_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any
#: How long a server waits for a client's reply reader to be matched before dropping the reply, s (rmw: 100 ms).
REPLY_MATCH_WAIT_S = 0.1


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
        self.node = entity.node
        csid = format_csid(participant.gid, next(participant.csids))
        self.csid = csid
        # ROS 2 names no fields of the request header, so a peer that describes its types may name them otherwise
        qos = Qos(Policy.TypeConsistency.AllowTypeCoercion(ignore_member_names=True),
                  base=dds_qos(entity.qos_profile, user_data=f'{role}={csid};'))
        self.read_topic, self.read_type = read_topic, read_type
        self.write_topic, self.write_type = write_topic, write_type
        read_struct = idl_service_struct(read_type)
        self.reader = DataReader(participant.dds_subscriber,
                                 participant.dds_topic(read_topic, read_type, struct=read_struct), qos)
        forget(self.reader)
        try:
            self.writer = DataWriter(participant.dds_publisher, participant.dds_topic(
                write_topic, write_type, struct=idl_service_struct(write_type)), qos)
        except Exception:
            from .cdds import delete_entity
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
        self._reported: set[int] = set()

    def qos_checks(self) -> list[tuple[Any, bool, str, str]]:
        """``(DDS entity, is a writer, DDS topic, type)`` whose QoS statuses the participant watches."""
        return [(self.reader, False, self.read_topic, self.read_type),
                (self.writer, True, self.write_topic, self.write_type)]

    def _take(self) -> list[tuple[int, int, Any, int]]:
        """``(client id, seq, decoded message, writer handle)`` of every valid sample waiting on the reader."""
        out = []
        while True:
            samples = ddspy_take(self.ref, _ANY_STATE, TAKE_BATCH)
            if not isinstance(samples, list) or not samples:
                return out
            for data, info in samples:
                if not info.valid_data:
                    continue
                try:
                    guid, seq, body = decode_request(data)
                    out.append((guid, seq, body, info.publication_handle))
                except MessageError as err:
                    self._undecodable(info.publication_handle, err)
            if len(samples) < TAKE_BATCH:
                return out

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
        unmatched: replies dropped because the client's reply reader was not matched in time.
        failed: replies DDS refused.
    """

    def __init__(self, participant: DdsParticipant, service: Service) -> None:
        request_topic, reply_topic = dds_service_topics(service.srv_name)
        super().__init__(participant, service, request_topic, f'{service.service_type}_Request',
                         reply_topic, f'{service.service_type}_Response', 'serviceid')
        self.service = service
        self.gone = self.unmatched = self.failed = 0
        self._clients_seen: set[str] = set()  # client ids whose reply reader was matched

    def drain(self) -> bool:
        """Take the requests DDS holds onto the service's queue (executor thread); True if any came."""
        took = False
        for guid, seq, body, handle in self._take():
            request = self._decode(body, handle)
            if request is not None:
                self.service._enqueue_local((request, _DdsReply(self, guid, seq, handle)))
                took = True
        return took

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

    def send_request(self, seq: int, request: Any) -> str:
        """Write the request; '' when sent, else why it could not be (no server)."""
        if matched_readers(self.writer._ref) == 0:
            return 'no server is matched on DDS'
        if not self._write(self.guid, seq, request):
            return 'DDS refused the request'
        self.sent += 1
        self._in_flight.add(seq)
        return ''

    def drain(self) -> bool:
        """Take the replies DDS holds; ours go onto the client's queue (executor thread). True if any did."""
        took = False
        for guid, seq, body, handle in self._take():
            if guid != self.guid:
                self.foreign += 1
                continue
            response = self._decode(body, handle)
            if response is not None:
                self._in_flight.discard(seq)
                self.client._enqueue_local((seq, response))
                took = True
        return took

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


