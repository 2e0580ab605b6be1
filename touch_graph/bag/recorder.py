"""Write rosbag2 bags (MCAP storage, metadata version 9) that survive a crash of their writer.

:class:`BagRecorder` wraps ``rosbags.rosbag2.Writer``. Each topic becomes a connection
carrying its full message definition (from :data:`touch_graph.messages.typestore`, so
``ros2 bag``, Foxglove and the rosbags reader can decode it) and its offered QoS.

Durability: rosbags' MCAP writer keeps messages in an in-memory chunk until it holds
1 MiB or the bag closes. A background thread closes the pending chunk and fsyncs the file
every ``flush_period_s`` (default 1 s), so a recorder killed with SIGKILL loses at most
about that much; :func:`touch_graph.bag.reindex.reindex` then rebuilds the summary and
``metadata.yaml``. Closing the pending chunk uses the writer's storage internals
(``McapWriter.close_chunk``), which is why setup.py pins ``rosbags<0.12``;
:func:`check_writer_internals` fails loudly if a newer rosbags changed them.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime
from rosbags.rosbag2 import StoragePlugin, Writer, WriterError

from .. import messages
from ..errors import BagError, MessageError

__all__ = ['BagRecorder', 'check_writer_internals', 'to_bag_qos']

_ZERO = QosTime(0, 0)


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


def check_writer_internals(writer: Writer) -> None:
    """Raise BagError when rosbags' MCAP writer lacks what :meth:`BagRecorder.flush` uses."""
    storage = writer.storage
    missing = [a for a in ('close_chunk', 'chunk', 'bio') if not hasattr(storage, a)]
    if not missing and not hasattr(storage.chunk, 'msgs'):
        missing.append('chunk.msgs')
    if missing:
        import rosbags
        version = getattr(rosbags, '__version__', '?')
        raise BagError(f'rosbags {version} MCAP writer has no {", ".join(missing)}; the recorder needs them to '
                       "flush once a second. Install the pinned version: pip install 'rosbags>=0.10,<0.12'")


class BagRecorder:
    """A rosbag2 (MCAP) being written; thread-safe (the flusher thread and writers share a lock).

    Args:
        path: the bag directory to create (must not exist).
        flush_period_s: wall seconds between flushes of the pending chunk (None: only at close).
        custom_data: ``str -> str`` stored in metadata.yaml's ``custom_data``.

    Attributes:
        counts, sizes: messages and CDR bytes written per topic.
        flushes: chunk flushes done (closing included).
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
        self._custom = dict(custom_data or {})
        self._lock = threading.Lock()  # writer state
        self._io_lock = threading.Lock()  # fsync vs close, so fsync runs outside the writer lock
        self._writer: Writer | None = None
        self._connections: dict[str, Any] = {}
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
        writer = Writer(self.path, version=9, storage_plugin=StoragePlugin.MCAP)
        try:
            writer.open()
        except (WriterError, OSError) as err:
            raise BagError(f'cannot create bag {self.path}: {err}') from err
        check_writer_internals(writer)
        writer.storage.bio.flush()  # the MCAP header on disk at once: a bag killed early is still MCAP
        for key, value in self._custom.items():
            writer.set_custom_data(key, str(value))
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
            if writer is not None:
                try:
                    writer.close()
                except (WriterError, OSError) as err:
                    raise BagError(f'cannot close bag {self.path}: {err}; run social-touch bag reindex '
                                   f'{self.path} to recover what was flushed') from err
            self.flushes += 1

    def __enter__(self) -> BagRecorder:
        return self.open() if self._writer is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ writing
    def add_topic(self, topic: str, type_name: str, qos: Any = None) -> None:
        """Declare ``topic`` before its first message (to record its QoS; :meth:`write` does it otherwise).

        Raises:
            BagError: unknown type, or the topic already recorded with another type.
        """
        with self._lock:
            self._connection(topic, type_name, qos)

    def _connection(self, topic: str, type_name: str, qos: Any) -> Any:
        conn = self._connections.get(topic)
        if conn is not None:
            if conn.msgtype != type_name:
                raise BagError(f"topic '{topic}' is recorded as {conn.msgtype}, not {type_name}")
            return conn
        if self._writer is None:
            raise BagError(f'bag {self.path} is not open')
        try:
            messages.get_message(type_name)
            conn = self._writer.add_connection(topic, type_name, typestore=messages.typestore,
                                               offered_qos_profiles=[to_bag_qos(qos)])
        except (WriterError, MessageError) as err:
            raise BagError(f"cannot record '{topic}' ({type_name}): {err}") from err
        self._connections[topic] = conn
        self.counts[topic] = 0
        self.sizes[topic] = 0
        return conn

    def write(self, topic: str, type_name: str, stamp_ns: int, data: bytes, qos: Any = None) -> None:
        """Append one message (CDR bytes) stamped ``stamp_ns`` (ROS time, ns).

        Raises:
            BagError: the bag is closed, the type is unknown, or the disk refused the write.
        """
        if stamp_ns < 0:
            raise BagError(f"message on '{topic}' has a negative stamp {stamp_ns} ns")
        with self._lock:
            if self._writer is None:
                raise BagError(f'bag {self.path} is closed; message on {topic!r} not recorded')
            conn = self._connection(topic, type_name, qos)
            try:
                self._writer.write(conn, int(stamp_ns), data)
            except (WriterError, OSError) as err:
                raise BagError(f'cannot write to bag {self.path}: {err}') from err
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
                if writer is None or not self._dirty:
                    return False
                storage = writer.storage
                try:
                    if storage.chunk.msgs:
                        storage.close_chunk()
                    storage.bio.flush()
                except OSError as err:
                    raise BagError(f'cannot flush bag {self.path}: {err}') from err
                self._dirty = False
                fd = storage.bio.fileno()
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

    def topics(self) -> Sequence[str]:
        with self._lock:
            return list(self._connections)
