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
_monotonic = time.monotonic


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
        self._last_poll = 0.0  # time.monotonic() of the last wait or poll
        self.poll_s = POLL_S
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
            triggered = self._waitset.wait_into(timeout_ns, self._pending)
        except DDSException:  # the participant was deleted (the context shut down): nothing to wait for
            return True
        self._last_poll = _monotonic()  # a wait is a poll: take() need not ask again at once
        return triggered > 0 or self._flag

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

        Takes from the readers a wait noted; with none noted, looks (without blocking) for newly
        arrived samples, so a busy executor that does not wait still takes them. The executor
        calls it only when ``_pending`` holds keys or ``poll_s`` (:data:`POLL_S`) passed since
        ``_last_poll`` (a test it makes inline: it is on every turn of every executor). Returns
        True when it took anything.
        """
        pending = self._pending
        if not pending:  # no wait noted samples: look for some without blocking (a busy executor)
            self._last_poll = _monotonic()
            try:
                self._waitset.wait_into(0, pending)
            except DDSException:  # deleted with the participant
                return False
        took = False
        while pending:  # drain() only queues (no callback runs), so nothing adds keys meanwhile
            reader = self._readers.get(pending.pop())
            if reader is not None:
                took = reader.drain() or took
        return took

    def close(self) -> None:
        with self._lock:
            self._readers.clear()
            self._keys.clear()
        self._waitset.close()
