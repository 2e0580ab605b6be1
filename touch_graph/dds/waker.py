"""An executor's wait on DDS: remote samples wake the executor thread itself, as rclpy's wait set does.

On a networked context an executor does not sleep on a ``threading.Event`` but on a
Cyclone wait set that holds a guard condition (what ``set()`` triggers: work from other
threads, a stop request) and the read condition of every DDS reader of its
subscriptions. When a sample arrives, the thread that will run the callback wakes up
directly (no hand-over from another Python thread), takes the sample, decodes it and
queues it on the subscription, where a full queue drops and counts its oldest message.

:class:`DdsWaker` has ``threading.Event``'s interface, so the executor and the clocks use
it unchanged.
"""

from __future__ import annotations

import threading
import time
from typing import TYPE_CHECKING

from cyclonedds.core import DDSException

from .cdds import WaitSet

if TYPE_CHECKING:
    from .endpoints import DdsReader

__all__ = ['DdsWaker']

#: While the executor is busy (it does not block), how often it still looks for samples, s.
POLL_S = 0.001


class DdsWaker:
    """An event the executor waits on, woken by ``set()`` or by data for one of its readers.

    Args:
        participant_ref: the DDS participant of the executor's context.
    """

    def __init__(self, participant_ref: int, owner: object = None) -> None:
        self.owner = owner  # the transport it belongs to; a new one needs a new waker
        self._waitset = WaitSet(participant_ref)
        self._flag = False
        self._readers: dict[int, DdsReader] = {}
        self._keys: dict[int, int] = {}  # id(reader) -> attach key
        self._next_key = 1
        self._pending: set[int] = set()
        self._last_poll = 0.0
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ threading.Event's interface
    def set(self) -> None:
        self._flag = True
        self._waitset.wake()

    def clear(self) -> None:
        self._flag = False

    def is_set(self) -> bool:
        return self._flag

    def wait(self, timeout: float | None = None) -> bool:
        """Block (GIL released) until ``set()``, data for a reader, or ``timeout`` seconds."""
        if self._flag:
            return True
        timeout_ns = 2**62 if timeout is None else max(0, int(timeout * 1e9))
        try:
            keys = self._waitset.wait(timeout_ns)
        except DDSException:  # the participant was deleted (the context shut down): nothing to wait for
            return True
        self._last_poll = time.monotonic()  # a wait is a poll: take() need not ask again at once
        self._note(keys)
        return bool(keys) or self._flag

    # ------------------------------------------------------------------ readers
    def attach(self, reader: DdsReader) -> None:
        with self._lock:
            if id(reader) in self._keys:
                return
            key = self._next_key
            self._next_key += 1
            self._keys[id(reader)] = key
            self._readers[key] = reader
        self._waitset.attach(reader.condition_ref, key)

    def detach(self, reader: DdsReader) -> None:
        with self._lock:
            key = self._keys.pop(id(reader), None)
            if key is None:
                return
            self._readers.pop(key, None)
            self._pending.discard(key)
        self._waitset.detach(reader.condition_ref)

    def take(self) -> bool:
        """Move the samples of readers with data onto their subscriptions' queues (executor thread).

        Looks (without blocking) for newly arrived samples at most every :data:`POLL_S`, so a
        busy executor still takes them; returns True when it took anything.
        """
        now = time.monotonic()
        if now - self._last_poll >= POLL_S:
            self._last_poll = now
            try:
                self._note(self._waitset.wait(0))
            except DDSException:  # deleted with the participant
                return False
        if not self._pending:
            return False
        pending, self._pending = self._pending, set()
        took = False
        for key in pending:
            reader = self._readers.get(key)
            if reader is not None:
                took = reader.drain() or took
        return took

    def _note(self, keys: list[int]) -> None:
        for key in keys:
            if key != WaitSet.GUARD:
                self._pending.add(key)

    def close(self) -> None:
        with self._lock:
            self._readers.clear()
            self._keys.clear()
        self._waitset.close()
