"""Connected pages: one bounded frame queue per client, so a slow page costs only itself.

The broadcaster :meth:`ClientQueue.offer` s each frame to every client without ever waiting:
when a client's queue is full its oldest frame is dropped and counted for that client. Each
client's own server thread :meth:`ClientQueue.take` s frames and writes them to its socket;
a page that is slow or paused blocks only that thread (and is disconnected after the
server's write timeout).
"""

from __future__ import annotations

import itertools
import threading
import time
from collections import deque

__all__ = ['ClientQueue', 'ClientRegistry']

_ids = itertools.count(1)


class ClientQueue:
    """The frames waiting for one client.

    Args:
        peer: ``host:port`` of the client, for the stats.
        capacity: frames kept; every frame is a whole snapshot, so a few suffice.

    Attributes:
        sent, dropped: frames written to the client, and dropped because it did not keep up.
    """

    def __init__(self, peer: str, capacity: int = 4) -> None:
        if capacity < 1:
            raise ValueError(f'capacity must be >= 1 frame, got {capacity}')
        self.id = next(_ids)
        self.peer = peer
        self.connected_wall = time.time()
        self.sent = 0
        self.dropped = 0
        self.closed = False
        self._frames: deque[bytes] = deque(maxlen=capacity)
        self._ready = threading.Condition()

    def offer(self, frame: bytes) -> None:
        """Queue ``frame``, dropping (and counting) the oldest when full; never blocks on the client."""
        with self._ready:
            if len(self._frames) == self._frames.maxlen:
                self.dropped += 1
            self._frames.append(frame)
            self._ready.notify()

    def take(self, timeout_s: float) -> bytes | None:
        """The oldest frame, waiting up to ``timeout_s``; None on timeout or when closed."""
        with self._ready:
            if not self._ready.wait_for(lambda: self._frames or self.closed, timeout_s) or self.closed:
                return None
            return self._frames.popleft()

    def close(self) -> None:
        with self._ready:
            self.closed = True
            self._ready.notify_all()

    def stats(self) -> dict[str, object]:
        return {'id': self.id, 'peer': self.peer, 'sent': self.sent, 'dropped': self.dropped,
                'connected_s': round(time.time() - self.connected_wall, 1)}


class ClientRegistry:
    """The connected clients, bounded; totals survive a client's disconnection.

    Args:
        max_clients: more connections than this are refused (each holds a server thread).
        capacity: frames queued per client.
    """

    def __init__(self, max_clients: int = 32, capacity: int = 4) -> None:
        if max_clients < 1:
            raise ValueError(f'max_clients must be >= 1, got {max_clients}')
        self.max_clients = max_clients
        self.capacity = capacity
        self._clients: dict[int, ClientQueue] = {}
        self._lock = threading.Lock()
        self.connected_total = 0
        self.refused = 0
        self.timed_out = 0
        self._dropped_gone = 0

    def add(self, peer: str) -> ClientQueue | None:
        """A new client's queue, or None when ``max_clients`` are connected (the caller refuses it)."""
        with self._lock:
            if len(self._clients) >= self.max_clients:
                self.refused += 1
                return None
            client = ClientQueue(peer, self.capacity)
            self._clients[client.id] = client
            self.connected_total += 1
            return client

    def remove(self, client: ClientQueue, *, timed_out: bool = False) -> None:
        client.close()
        with self._lock:
            if self._clients.pop(client.id, None) is not None:
                self._dropped_gone += client.dropped
                self.timed_out += int(timed_out)

    def broadcast(self, frame: bytes) -> None:
        for client in self.snapshot():
            client.offer(frame)

    def snapshot(self) -> list[ClientQueue]:
        with self._lock:
            return list(self._clients.values())

    def __len__(self) -> int:
        return len(self._clients)

    def close_all(self) -> None:
        for client in self.snapshot():
            client.close()

    def stats(self) -> dict[str, object]:
        clients = self.snapshot()
        return {'connected': len(clients), 'connected_total': self.connected_total, 'refused': self.refused,
                'timed_out': self.timed_out, 'dropped_total': self._dropped_gone + sum(c.dropped for c in clients),
                'clients': [c.stats() for c in clients]}
