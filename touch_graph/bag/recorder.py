"""Write rosbag2 bags (MCAP storage, metadata version 9) that survive a crash of their writer.

The file is written with the ``mcap`` writer in rosbag2's ROS 2 profile: a channel per topic
(CDR, its offered QoS in ``offered_qos_profiles``) whose schema is the type's full ``.msg``
definition; chunks carry CRCs. A message's log time is when it was received, its publish time
when it was sent (rosbag2 Jazzy's ``recv_timestamp``/``send_timestamp``).

A background thread closes the pending chunk and fsyncs every ``flush_period_s``, so a
recorder killed with SIGKILL loses at most that much (:func:`touch_graph.bag.reindex.reindex`
rebuilds the rest). A full disk (ENOSPC, EDQUOT) stops the recording for good: the file keeps
what reached the disk, later messages are refused and counted in ``dropped``.
"""

from __future__ import annotations

import contextlib
import errno
import os
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mcap.writer import CompressionType, Writer

from .. import messages
from ..errors import BagError, MessageError
from .metadata import (
    SCHEMA_ENCODING,
    FileRecord,
    TopicRecord,
    bag_metadata,
    qos_text,
    serialized_metadata,
    to_bag_qos,
    type_hash,
    write_metadata,
)

__all__ = ['BagRecorder', 'to_bag_qos']

#: Messages per chunk before the writer closes it by itself (between flushes), bytes.
CHUNK_SIZE = 1 << 20


@dataclass
class _Channel:
    id: int
    topic: TopicRecord


class BagRecorder:
    """A rosbag2 (MCAP) being written; thread-safe (the flusher thread and writers share a lock).

    Args:
        path: the bag directory to create (must not exist).
        flush_period_s: wall seconds between flushes of the pending chunk (None: only at close).
        custom_data: ``str -> str`` stored in metadata.yaml's ``custom_data``.

    Attributes:
        counts, sizes: messages and CDR bytes written per topic.
        flushes: chunk flushes done (closing included).
        flushed_messages: messages on disk as of the last flush (those a reindex surely recovers).
        full: the error of a full disk, once the disk ran out of space (None until then).
        dropped: messages refused after the disk was full.
    """

    def __init__(self, path: str | os.PathLike, *, flush_period_s: float | None = 1.0,
                 custom_data: dict[str, str] | None = None) -> None:
        if flush_period_s is not None and not flush_period_s > 0:
            raise ValueError(f'flush_period_s must be > 0 (or None), got {flush_period_s}')
        self.path = Path(path)
        self.flush_period_s = flush_period_s
        self.counts: dict[str, int] = {}
        self.sizes: dict[str, int] = {}
        self.flushes = 0
        self.flushed_messages = 0
        self.full: OSError | None = None
        self.dropped = 0
        self._custom = dict(custom_data or {})
        self._lock = threading.Lock()  # writer state
        self._io_lock = threading.Lock()  # fsync vs close, so fsync runs outside the writer lock
        self._writer: Writer | None = None
        self._file: Any = None
        self._schemas: dict[str, int] = {}
        self._channels: dict[str, _Channel] = {}
        self._span: list[int] = []    # [first, last] log time written, ns
        self._dirty = False
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self.closed = False

    # ------------------------------------------------------------------ lifecycle
    def open(self) -> BagRecorder:
        if self._writer is not None or self.closed:
            raise BagError(f'bag {self.path} is already open or closed')
        if self.path.exists():
            raise BagError(f'{self.path} exists already; record to a new path (-o) or remove it first')
        try:
            self.path.mkdir(parents=True)
            self._file = (self.path / f'{self.path.name}.mcap').open('xb')
        except OSError as err:
            raise BagError(f'cannot create bag {self.path}: {err}') from err
        writer = Writer(self._file, chunk_size=CHUNK_SIZE, compression=CompressionType.NONE)
        writer.start(profile='ros2', library='social_touch')
        writer.flush()  # the MCAP header on disk at once: a bag killed early is still MCAP
        self._writer = writer
        if self.flush_period_s is not None:
            self._thread = threading.Thread(target=self._flush_loop, name=f'bag-flush-{self.path.name}', daemon=True)
            self._thread.start()
        return self

    def close(self) -> None:
        """Write the summary and metadata.yaml; safe to call twice."""
        if self.closed:
            return
        self.closed = True
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        with self._io_lock, self._lock:
            writer, self._writer = self._writer, None
            if self.full is not None:
                raise BagError(self._full_message())
            if writer is not None:
                try:
                    info = self._metadata()
                    writer.add_metadata('rosbag2', {'serialized_metadata': serialized_metadata(info)})
                    writer.finish()
                    self._file.flush()
                    os.fsync(self._file.fileno())
                    self._file.close()
                    write_metadata(self.path, info)
                except OSError as err:
                    if _no_space(err):
                        self._disk_full(err)
                        raise BagError(self._full_message()) from err
                    raise BagError(f'cannot close bag {self.path}: {err}; run social-touch bag reindex '
                                   f'{self.path} to recover what was flushed') from err
            self.flushes += 1

    def _metadata(self) -> dict:
        first, last = self._span or (0, 0)
        name = f'{self.path.name}.mcap'
        topics = [c.topic for c in self._channels.values()]
        return bag_metadata([FileRecord(name, first, last, self.message_count)], topics, self._custom)

    def __enter__(self) -> BagRecorder:
        return self.open() if self._writer is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ writing
    def add_topic(self, topic: str, type_name: str, qos: Any = None) -> None:
        """Declare ``topic`` before its first message (to record its QoS; :meth:`write` does it otherwise).

        ``qos``: the offered profile, or a list of them (one per publisher, as rosbag2 stores them).

        Raises:
            BagError: unknown type, or the topic already recorded with another type.
        """
        with self._lock:
            self._connection(topic, type_name, qos)

    def _connection(self, topic: str, type_name: str, qos: Any) -> _Channel:
        channel = self._channels.get(topic)
        if channel is not None:
            if channel.topic.type_name != type_name:
                raise BagError(f"topic '{topic}' is recorded as {channel.topic.type_name}, not {type_name}")
            return channel
        if self._writer is None:
            raise BagError(f'bag {self.path} is not open')
        try:
            messages.get_message(type_name)
            definition, _ = messages.typestore.generate_msgdef(type_name, ros_version=2)
        except (MessageError, KeyError) as err:
            raise BagError(f"cannot record '{topic}' ({type_name}): {err}") from err
        schema = self._schemas.get(type_name)
        if schema is None:
            schema = self._schemas[type_name] = self._writer.register_schema(
                name=type_name, encoding=SCHEMA_ENCODING, data=definition.encode())
        offered = qos_text([to_bag_qos(q) for q in (qos if isinstance(qos, list) and qos else [qos])])
        record = TopicRecord(topic, type_name, 'cdr', offered, type_hash(type_name, SCHEMA_ENCODING, definition))
        channel_id = self._writer.register_channel(topic=topic, message_encoding='cdr', schema_id=schema,
                                                   metadata={'offered_qos_profiles': offered})
        channel = self._channels[topic] = _Channel(channel_id, record)
        self.counts[topic] = 0
        self.sizes[topic] = 0
        return channel

    def write(self, topic: str, type_name: str, stamp_ns: int, data: bytes, qos: Any = None, *,
              publish_ns: int | None = None) -> None:
        """Append one message (CDR bytes) received at ``stamp_ns`` (ROS time, ns: its log time), sent at
        ``publish_ns`` (ns, its publish time; None: the same as ``stamp_ns``).

        Raises:
            BagError: the bag is closed, the type is unknown, or the disk refused the write.
        """
        if stamp_ns < 0:
            raise BagError(f"message on '{topic}' has a negative stamp {stamp_ns} ns")
        sent = int(stamp_ns if publish_ns is None or publish_ns < 0 else publish_ns)
        with self._lock:
            if self.full is not None:
                self.dropped += 1
                raise BagError(self._full_message())
            if self._writer is None:
                raise BagError(f'bag {self.path} is closed; message on {topic!r} not recorded')
            channel = self._connection(topic, type_name, qos)
            stamp = int(stamp_ns)
            try:
                self._writer.add_message(channel.id, log_time=stamp, data=bytes(data), publish_time=sent,
                                         sequence=self.counts[topic])
            except OSError as err:
                if _no_space(err):
                    self._disk_full(err)
                    self.dropped += 1
                    raise BagError(self._full_message()) from err
                raise BagError(f'cannot write to bag {self.path}: {err}') from err
            self._span = [min(self._span[0], stamp), max(self._span[1], stamp)] if self._span else [stamp, stamp]
            channel.topic.message_count += 1
            self.counts[topic] += 1
            self.sizes[topic] += len(data)
            self._dirty = True

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    # ------------------------------------------------------------------ durability
    def flush(self) -> bool:
        """Close the pending chunk and fsync; True when something was written to disk."""
        with self._io_lock:
            with self._lock:
                writer = self._writer
                if writer is None or not self._dirty or self.full is not None:
                    return False
                try:
                    writer.flush()   # the chunk in progress, with its CRC and message indexes
                    self._file.flush()
                except OSError as err:
                    if _no_space(err):
                        self._disk_full(err)
                        raise BagError(self._full_message()) from err
                    raise BagError(f'cannot flush bag {self.path}: {err}') from err
                self._dirty = False
                self.flushed_messages = self.message_count
                fd = self._file.fileno()
            # fsync outside the writer lock: a slow disk must not stall the graph's callbacks.
            with contextlib.suppress(OSError):
                os.fsync(fd)
            self.flushes += 1
        return True

    def _flush_loop(self) -> None:
        while not self._stop.wait(self.flush_period_s):
            try:
                self.flush()
            except BagError as err:  # keep trying: the disk may come back; close() reports for good
                import sys
                sys.stderr.write(f'[bag recorder] {err}\n')
            if self.full is not None:
                return  # said once by flush or write; nothing more will reach this file

    def _disk_full(self, err: OSError) -> None:
        """Stop writing for good after ``err`` (no space): what is in the file stays as it is.

        The file's buffer may hold the rest of a chunk the disk refused; its descriptor is pointed
        at /dev/null (atomically, so no other file can take its number), so closing it writes
        nothing more, and a reindex finds the whole chunks before the torn one.
        """
        self.full = err
        self._writer = None
        if self._file is not None:
            fd = self._file.fileno()
            with contextlib.suppress(OSError):
                os.fsync(fd)
            null = os.open(os.devnull, os.O_WRONLY)
            try:
                os.dup2(null, fd)
            finally:
                os.close(null)
            with contextlib.suppress(OSError):
                self._file.close()

    def _full_message(self) -> str:
        name = errno.errorcode.get(self.full.errno, 'ENOSPC') if self.full is not None else 'ENOSPC'
        return (f'{name}: no space left on the disk of bag {self.path}; recording stopped. Kept: the messages '
                f'that reached the disk (at least the {self.flushed_messages} flushed, of {self.message_count} '
                f'received; {self.dropped} refused since). To read the bag: free some space and run social-touch '
                f'bag reindex {self.path}, or rebuild it on another disk with social-touch bag reindex {self.path} '
                f'-o OTHER_DIR/{self.path.name}')

    def topics(self) -> list[str]:
        with self._lock:
            return list(self._channels)


def _no_space(err: OSError) -> bool:
    return err.errno in (errno.ENOSPC, errno.EDQUOT)

