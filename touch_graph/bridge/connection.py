"""One connection to another graph process: a non-blocking socket, a bounded send queue, a frame reader.

Producers (the executor thread, forwarding local messages) only append to the send queue
under a lock; the bridge's I/O thread does every socket call. The data queue is bounded
in frames and bytes and drops its oldest frame when full (counted in ``dropped``), so a
peer that stops reading (a paused ``topic echo``) costs the publisher nothing but memory
up to the bound. Control frames (HELLO, GRAPH) are never dropped; a newer GRAPH replaces
one not yet sent.
"""

from __future__ import annotations

import contextlib
import socket
import threading
from collections import deque

from .protocol import FrameReader

__all__ = ['PeerConnection']

#: Bytes handed to one send() call: large enough to batch many small frames per syscall.
_SEND_CHUNK = 256 * 1024
_RECV_CHUNK = 256 * 1024


class PeerConnection:
    """A connection to one peer.

    Args:
        sock: a connected non-blocking stream socket.
        initiated: True when this side connected (False when it accepted).
        max_frames, max_bytes: bounds of the data send queue.

    Attributes:
        peer_id: the peer's socket file name, known once its HELLO arrived.
        hello, snapshot: the peer's HELLO and latest GRAPH payloads (dicts).
        sent, dropped, received: DATA frames sent, dropped from the send queue, received.
    """

    def __init__(self, sock: socket.socket, *, initiated: bool, max_frames: int = 4096,
                 max_bytes: int = 16 * 1024 * 1024) -> None:
        if max_frames < 1 or max_bytes < 1:
            raise ValueError(f'send queue bounds must be >= 1, got {max_frames} frames / {max_bytes} bytes')
        self.sock = sock
        self.initiated = initiated
        self.reader = FrameReader()
        self.peer_id: str | None = None
        self.hello: dict | None = None
        self.snapshot: dict | None = None
        self.closed = False
        self.max_frames = max_frames
        self.max_bytes = max_bytes
        self.sent = 0
        self.dropped = 0
        self.received = 0
        self._lock = threading.Lock()
        self._control: deque[bytes] = deque()
        self._pending_graph: bytes | None = None
        self._data: deque[bytes] = deque()
        self._data_bytes = 0
        self._out = memoryview(b'')
        self._out_data_frames = 0
        self.write_armed = False  # the I/O thread watches for writability

    def fileno(self) -> int:
        return self.sock.fileno()

    # ------------------------------------------------------------------ producers (any thread)
    def enqueue_data(self, frame: bytes) -> bool:
        """Queue a DATA frame; True when the queue was idle (the I/O thread must be woken)."""
        with self._lock:
            idle = not self._data and not self._control and self._pending_graph is None
            self._data.append(frame)
            self._data_bytes += len(frame)
            while len(self._data) > self.max_frames or (self._data_bytes > self.max_bytes and len(self._data) > 1):
                self._data_bytes -= len(self._data.popleft())
                self.dropped += 1
        return idle

    def enqueue_control(self, frame: bytes, *, graph: bool = False) -> None:
        """Queue a HELLO (or, with ``graph``, a GRAPH frame replacing any unsent one)."""
        with self._lock:
            if graph:
                self._pending_graph = frame
            else:
                self._control.append(frame)

    def queued(self) -> int:
        """DATA frames waiting, including the one being written."""
        with self._lock:
            return len(self._data) + self._out_data_frames

    # ------------------------------------------------------------------ I/O thread
    def has_output(self) -> bool:
        with self._lock:
            return bool(self._out) or bool(self._control) or self._pending_graph is not None or bool(self._data)

    def _refill(self) -> None:
        parts: list[bytes] = []
        size = 0
        frames = 0
        with self._lock:
            while self._control:
                parts.append(self._control.popleft())
            if self._pending_graph is not None:
                parts.append(self._pending_graph)
                self._pending_graph = None
            size = sum(len(p) for p in parts)
            while self._data and size < _SEND_CHUNK:
                frame = self._data.popleft()
                self._data_bytes -= len(frame)
                parts.append(frame)
                size += len(frame)
                frames += 1
            self._out_data_frames = frames
        self._out = memoryview(b''.join(parts))

    def write_some(self) -> bool:
        """Send what the socket takes now; True while output remains. Raises OSError on a dead peer."""
        while True:
            if not self._out:
                self.sent += self._out_data_frames
                self._out_data_frames = 0
                self._refill()
                if not self._out:
                    return False
            try:
                n = self.sock.send(self._out)
            except (BlockingIOError, InterruptedError):
                return True
            self._out = self._out[n:]
            if self._out:
                return True

    def read_frames(self) -> list[tuple[int, bytes]] | None:
        """Frames that arrived; None at end of stream. Raises OSError / ProtocolError."""
        try:
            data = self.sock.recv(_RECV_CHUNK)
        except (BlockingIOError, InterruptedError):
            return []
        if not data:
            return None
        return self.reader.feed(data)

    def close(self) -> None:
        if not self.closed:
            self.closed = True
            with contextlib.suppress(OSError):
                self.sock.close()

    def __repr__(self) -> str:
        return f'PeerConnection({self.peer_id or "?"}, initiated={self.initiated}, queued={self.queued()})'
