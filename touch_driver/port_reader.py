"""A thread that blocks on a serial port's reads and hands the bytes to the node's executor.

The driver node reads when bytes arrive rather than polling: this thread waits in
``port.read`` (pyserial, with a timeout so it can be stopped), and for every read that
returns bytes it queues them and triggers the node's guard condition; the executor then
decodes and publishes in its own thread (``node.create_guard_condition``, rclpy's idiom for
work arriving from another thread). A read that fails (the port unplugged) is queued as the
exception and ends the thread; the node reopens the port and starts a new reader.

On a POSIX port (a device, a pty) the thread waits in ``select`` itself and takes everything
that has arrived in one ``os.read``: pyserial's ``read(n)`` waits for exactly ``n`` bytes, so
reading what came without it costs two waits and three ioctls per frame. Other ports (``socket://``,
``rfc2217://``) are read through pyserial.
"""

from __future__ import annotations

import contextlib
import errno
import os
import select
import threading
from collections import deque
from typing import Any

import serial

try:
    from serial.serialposix import Serial as _PosixSerial
except ImportError:  # not a POSIX system: every port is read through pyserial
    _PosixSerial = None

__all__ = ['PortReader']

#: s a blocked read waits before it checks whether it should stop.
READ_TIMEOUT_S = 0.5
#: Reads handed over and not taken yet past which the thread stops reading (an executor that is not
#: spinning): the bytes wait in the port's own buffer, which overruns as a UART's does, not in memory.
MAX_BACKLOG = 1024
#: Bytes one read takes at most on a POSIX port (the rest comes with the next read, at once).
CHUNK_BYTES = 65536
#: errnos of a read that found nothing after all (pyserial ignores the same).
_RETRY_ERRNOS = (errno.EAGAIN, errno.EALREADY, errno.EWOULDBLOCK, errno.EINPROGRESS, errno.EINTR)


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
            if _is_plain_posix(port):
                self._run_posix(port.fd, port.pipe_abort_read_r)
                return
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
        except (serial.SerialException, OSError, TypeError, AttributeError, ValueError) as err:
            # pyserial raises TypeError/AttributeError when the port is closed under a blocked read
            # (select raises ValueError for the -1 it leaves as the descriptor)
            if not self._stop.is_set():
                received.append(err if isinstance(err, (serial.SerialException, OSError)) else OSError(str(err)))
                trigger()

    def _run_posix(self, fd: int, abort: int) -> None:
        """The loop of :meth:`_run` on a POSIX port: wait in ``select``, take all that came in one read.

        ``abort`` is the pipe pyserial's ``cancel_read`` writes to; errors are pyserial's own."""
        received, trigger, stopped = self.received, self.guard.trigger, self._stop.is_set
        while not stopped():
            if len(received) >= MAX_BACKLOG:
                self._stop.wait(0.01)
                continue
            try:
                ready, _, _ = select.select([fd, abort], [], [], READ_TIMEOUT_S)
                if abort in ready:
                    os.read(abort, 1000)
                    continue
                if not ready:
                    continue
                data = os.read(fd, CHUNK_BYTES)
            except OSError as err:
                if err.errno in _RETRY_ERRNOS:
                    continue
                raise serial.SerialException(f'read failed: {err}') from err
            if not data:   # what a disconnected device does on Linux (pyserial's words)
                raise serial.SerialException('device reports readiness to read but returned no data '
                                             '(device disconnected or multiple access on port?)')
            if not stopped():
                received.append(data)
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


def _is_plain_posix(port: Any) -> bool:
    """A pyserial POSIX port whose ``read`` is the base one (not one with its own way of waiting)."""
    return (_PosixSerial is not None and isinstance(port, _PosixSerial) and type(port).read is _PosixSerial.read
            and isinstance(getattr(port, 'fd', None), int))
