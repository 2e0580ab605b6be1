"""A thread that blocks on a serial port's reads and hands the bytes to the node's executor.

The driver node reads when bytes arrive rather than polling: this thread waits in
``port.read`` (pyserial, with a timeout so it can be stopped), and for every read that
returns bytes it queues them and triggers the node's guard condition; the executor then
decodes and publishes in its own thread (``node.create_guard_condition``, rclpy's idiom for
work arriving from another thread). A read that fails (the port unplugged) is queued as the
exception and ends the thread; the node reopens the port and starts a new reader.
"""

from __future__ import annotations

import contextlib
import threading
from collections import deque
from typing import Any

import serial

__all__ = ['PortReader']

#: s a blocked read waits before it checks whether it should stop.
READ_TIMEOUT_S = 0.5
#: Reads handed over and not taken yet past which the thread stops reading (an executor that is not
#: spinning): the bytes wait in the port's own buffer, which overruns as a UART's does, not in memory.
MAX_BACKLOG = 1024


class PortReader:
    """Read ``port`` in a daemon thread; :meth:`take` returns what came (bytes, or the error that ended it).

    Args:
        port: an open pyserial port.
        guard: the node's guard condition (``trigger()`` wakes the executor).
        name: the thread's name.
    """

    def __init__(self, port: Any, guard: Any, name: str) -> None:
        self.port = port
        self.guard = guard
        self.received: deque[bytes | Exception] = deque()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)

    def start(self) -> None:
        self._thread.start()

    @property
    def alive(self) -> bool:
        return self._thread.is_alive()

    def _run(self) -> None:
        port, received, trigger = self.port, self.received, self.guard.trigger
        try:
            port.timeout = READ_TIMEOUT_S       # read() blocks until a byte comes or this passes
            while not self._stop.is_set():
                if len(received) >= MAX_BACKLOG:
                    self._stop.wait(0.01)
                    continue
                data = port.read(port.in_waiting or 1)
                if data and not self._stop.is_set():
                    more = port.in_waiting      # the rest of a frame that came in pieces
                    if more:
                        data += port.read(more)
                    received.append(data)
                    trigger()
        except (serial.SerialException, OSError, TypeError, AttributeError) as err:
            # pyserial raises TypeError/AttributeError when the port is closed under a blocked read
            if not self._stop.is_set():
                received.append(err if isinstance(err, (serial.SerialException, OSError)) else OSError(str(err)))
                trigger()

    def take(self) -> list[bytes | Exception]:
        """Everything received since the last call, oldest first."""
        out = []
        received = self.received
        while received:
            out.append(received.popleft())
        return out

    def stop(self, timeout_s: float = 1.0) -> None:
        """Stop the thread (a blocked read is cancelled where pyserial can, else ends at its timeout)."""
        self._stop.set()
        with contextlib.suppress(Exception):
            self.port.cancel_read()
        if self._thread.is_alive() and self._thread is not threading.current_thread():
            self._thread.join(timeout_s)
