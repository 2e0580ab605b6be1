"""The DDS writer behind a runtime ``Publisher`` and the DDS reader behind a ``Subscription``.

A writer serialises a message only when a remote reader is matched (or when the
publisher is TRANSIENT_LOCAL: its DDS history must hold the last samples for readers
that join later) and writes the CDR bytes as they are, padded with zeros to a multiple
of four as rmw_cyclonedds pads them; the sample's source timestamp is the publishing
context's ROS time (simulated time in a simulated graph, else the wall clock as in ROS 2,
which Cyclone reads itself when it is not given one).

A reader is taken from by the executor of its subscription, in that executor's thread
(:mod:`.waker`): each sample is decoded there (raw subscriptions get the bytes) and queued
on the subscription. A sample that does not decode is counted and skipped, and reported
once per writer with both type names.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from functools import partial
from typing import TYPE_CHECKING, Any

from cyclonedds._clayer import ddspy_take, ddspy_write, ddspy_write_ts
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader

from .. import messages
from ..errors import MessageError
from ..runtime.qos import DurabilityPolicy
from .cdds import forget, matched_endpoint, matched_readers
from .qos import dds_qos

if TYPE_CHECKING:
    from ..runtime.endpoints import Publisher, Subscription
    from .participant import DdsParticipant

__all__ = ['DdsReader', 'DdsWriter', 'pad4', 'writer_type']

#: Samples taken from a reader per call.
TAKE_BATCH = 256
#: A writer that had a remote reader asks DDS again after this long, s (a write to no reader only costs its encoding;
#: asking on every write costs a C call).
MATCH_RECHECK_S = 0.25
_ANY_STATE = SampleState.Any | ViewState.Any | InstanceState.Any
_RETCODE_TIMEOUT = -10
_monotonic = time.monotonic


def pad4(data: bytes) -> bytes:
    """``data`` padded with zero bytes to a multiple of 4, as rmw_cyclonedds and cyclonedds pad a payload.

    >>> pad4(b'\\x00\\x01\\x00\\x00ab')
    b'\\x00\\x01\\x00\\x00ab\\x00\\x00'
    """
    extra = -len(data) % 4
    return data + b'\0' * extra if extra else data


def _make(entity_class: type, parent: Any, participant: DdsParticipant, endpoint: Any) -> Any:
    """The DataWriter or DataReader of a runtime endpoint, on its ``rt/`` topic with ROS 2's QoS."""
    type_name = endpoint._topic.type_name
    topic = participant.topic(endpoint.topic_name, type_name)
    entity = entity_class(parent, topic, dds_qos(endpoint.qos_profile, type_hash=participant.type_hash(type_name)))
    forget(entity)  # deleted with the participant, or explicitly with its endpoint
    return entity


class DdsWriter:
    """The DDS side of one runtime publisher.

    Attributes:
        written: samples handed to DDS.
        skipped: publishes not serialised because no remote reader was matched.
        failed: samples DDS refused or timed out on (a full KEEP_ALL history).
    """

    def __init__(self, participant: DdsParticipant, publisher: Publisher) -> None:
        self.publisher = publisher
        self.node = publisher.node
        self.topic_name = publisher.topic_name
        self.type_name = publisher._topic.type_name
        self.writer = _make(DataWriter, participant.dds_publisher, participant, publisher)
        self.ref = self.writer._ref
        self.gid = self.writer.get_guid().bytes
        self.latched = publisher.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL
        clock = publisher.node.context.time_source  # the context's ROS time (fixed per context)
        # Wall-clock time: Cyclone stamps the sample itself (no Python call per write); else simulated time.
        self._write = partial(_write_at, clock.now_ns) if clock.simulated else ddspy_write
        self._encode = messages.encoder(self.type_name)
        self._matched_until = 0.0  # time.monotonic() until which a remote reader counts as matched
        self.written = self.skipped = self.failed = 0

    def matched(self) -> int:
        """Remote readers matched (this process's own readers are ignored by DDS)."""
        return matched_readers(self.ref)

    def write(self, msg: Any, raw: bytes | None) -> None:
        """Send ``msg`` (or its CDR bytes ``raw``) to the remote readers, if there are any.

        Once a remote reader is matched, DDS is asked again only every :data:`MATCH_RECHECK_S`.
        """
        if not self.latched and _monotonic() >= self._matched_until:
            if matched_readers(self.ref) == 0:
                self.skipped += 1
                return
            self._matched_until = _monotonic() + MATCH_RECHECK_S
        if raw is None:
            data = self._encode(msg, True)
        else:  # pad4 inlined: every forwarded sample's path
            data = raw + b'\0' * (-len(raw) % 4) if len(raw) % 4 else raw
        ret = self._write(self.ref, data)
        if ret < 0:
            self.failed += 1
            why = ('a reliable reader did not take a sample within the blocking time' if ret == _RETCODE_TIMEOUT
                   else f'DDS refused a sample (error {ret}: CDR bytes that are no {self.type_name}?)')
            self.publisher.node.get_logger().warn(f"'{self.topic_name}': {why}; dropped", throttle_duration_sec=5.0)
        else:
            self.written += 1


def _write_at(now_ns: Callable[[], int], ref: int, data: bytes) -> int:
    """Write ``data`` stamped with the ROS time ``now_ns()`` (a simulated clock)."""
    return ddspy_write_ts(ref, data, now_ns())


class DdsReader:
    """The DDS side of one runtime subscription.

    Attributes:
        received: samples taken from DDS.
        undecodable: samples that did not decode as the subscription's type (skipped).
    """

    def __init__(self, participant: DdsParticipant, subscription: Subscription) -> None:
        self.subscription = subscription
        self.node = subscription.node
        self.topic_name = subscription.topic_name
        self.type_name = subscription._topic.type_name
        self.reader = _make(DataReader, participant.dds_subscriber, participant, subscription)
        self.condition = ReadCondition(self.reader, _ANY_STATE)
        forget(self.condition)
        self.condition_ref = self.condition._ref
        self.ref = self.reader._ref
        self.gid = self.reader.get_guid().bytes
        self._decode = messages.decoder(self.type_name)
        self.received = 0
        self.undecodable = 0
        self.waker: Any = None  # the DdsWaker of the executor taking from this reader
        self._reported: set[int] = set()

    def drain(self) -> bool:
        """Take everything DDS holds for this reader onto the subscription's queue; True if anything came.

        The queue is the subscription's (``Subscription._enqueue_local``, inlined here: this is every
        received sample's path): when it is full the oldest item is dropped and counted.
        """
        sub = self.subscription
        decode = self._decode if not sub.raw else None
        with_info = sub.with_info
        queue = sub._queue
        depth = queue.maxlen
        append = queue.append
        queued = 0
        while True:
            samples = ddspy_take(self.ref, _ANY_STATE, TAKE_BATCH)
            if type(samples) is not list:  # a DDS error code: the reader is gone
                break
            for data, info in samples:
                if not info.valid_data:
                    continue  # a writer went away (no data, only an instance state change)
                self.received += 1
                if decode is not None:
                    try:
                        data = decode(data)
                    except MessageError as err:
                        self._undecodable(info.publication_handle, err)
                        continue
                if with_info:
                    data = (data, {'source_timestamp': info.source_timestamp, 'received_timestamp': time.time_ns()})
                if len(queue) == depth:
                    sub.dropped += 1
                append(data)
                queued += 1
            if len(samples) < TAKE_BATCH:
                break
        if not queued:
            return False
        sub.received += queued
        executor = sub._executor
        if not sub._ready and executor is not None:
            sub._ready = True
            executor._ready.append(sub)
        return True

    def _undecodable(self, writer_handle: int, err: MessageError) -> None:
        self.undecodable += 1
        if writer_handle in self._reported:
            return
        self._reported.add(writer_handle)
        self.subscription.node.get_logger().error(
            f"'{self.topic_name}': a sample from a writer of {writer_type(self.reader, writer_handle)} does not "
            f"decode as '{self.type_name}' ({err}); skipped. Further ones from it are counted (social-touch topic "
            'info -v).')


def writer_type(reader: Any, writer_handle: int) -> str:
    """``'type' (writer GUID)`` of a writer matched with ``reader``, for reports ('an unknown type' if gone)."""
    endpoint = matched_endpoint(reader.get_matched_publication_data, writer_handle)  # None: gone already
    return f"'{endpoint.type_name}' (writer {endpoint.key})" if endpoint is not None else 'an unknown type'
