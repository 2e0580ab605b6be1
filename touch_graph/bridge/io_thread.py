"""The bridge's I/O thread: accept, connect, read, write and drop peer connections (a mixin of Bridge).

Every socket call of a :class:`~touch_graph.bridge.Bridge` happens here, in one thread
waiting on a ``selectors`` selector: the listening socket, a wake-up socket pair that
other threads write to, and one :class:`~touch_graph.bridge.connection.PeerConnection`
per peer. Frames from peers are handled here (HELLO, GRAPH, DATA); received messages are
handed to the executor thread through the bridge's bounded inbound queue. The attributes
used here are created by ``Bridge.__init__`` and ``Bridge.start``.
"""

from __future__ import annotations

import contextlib
import os
import selectors
import socket
import time
from pathlib import Path
from typing import Any

from .connection import PeerConnection
from .discovery import connect_or_clean
from .protocol import DATA, GRAPH, HELLO, PROTOCOL_VERSION, ProtocolError, decode_data, decode_json, encode_json

__all__ = ['PeerIO']


class PeerIO:
    """Peer connection handling for :class:`~touch_graph.bridge.Bridge` (runs in its I/O thread)."""

    _selector: Any
    _listener: Any
    _wake_r: Any
    _wake_w: Any

    def _add_connection(self, sock: socket.socket, initiated: bool) -> PeerConnection:
        conn = PeerConnection(sock, initiated=initiated, max_frames=self._queue_bounds[0],
                              max_bytes=self._queue_bounds[1])
        conn.enqueue_control(encode_json(HELLO, {'protocol': PROTOCOL_VERSION, 'peer': self.peer_id,
                                                 'name': self.name, 'pid': os.getpid(), 'socket': str(self.path)}))
        conn.enqueue_control(self._snapshot_frame(), graph=True)
        with self._lock:
            self._conns.append(conn)
        self._selector.register(conn.sock, selectors.EVENT_READ | selectors.EVENT_WRITE, conn)
        conn.write_armed = True
        return conn

    def _run(self) -> None:
        selector = self._selector
        try:
            while not self._stopping:
                self._before_select()
                timeout = 1.0
                if self._suspects:
                    timeout = max(0.0, min(timeout, min(s[0] for s in self._suspects) - time.monotonic()))
                for key, mask in selector.select(timeout=timeout):
                    if key.data == 'listen':
                        self._accept()
                    elif key.data == 'wake':
                        try:
                            while self._wake_r.recv(4096):
                                pass
                        except (BlockingIOError, OSError):
                            pass
                    else:
                        self._service(key.data, mask)
        except Exception as err:  # pragma: no cover - a bug here must be visible, not silent
            if self._node is not None:
                self._node.get_logger().error(f'bridge I/O thread failed: {type(err).__name__}: {err}')
        finally:
            self._close_all()

    def _before_select(self) -> None:
        if self._suspects:
            self._probe_suspects()
        if self._graph_dirty:
            with self._lock:
                self._graph_dirty = False
            frame = self._snapshot_frame()
            if frame != self._last_graph:
                self._last_graph = frame
                with self._lock:
                    conns = [c for c in self._conns if not c.closed]
                for conn in conns:
                    conn.enqueue_control(frame, graph=True)
        with self._lock:
            conns = [c for c in self._conns if not c.closed]
        for conn in conns:
            want = conn.has_output()
            if want != conn.write_armed:
                events = selectors.EVENT_READ | (selectors.EVENT_WRITE if want else 0)
                self._selector.modify(conn.sock, events, conn)
                conn.write_armed = want

    def _accept(self) -> None:
        try:
            sock, _ = self._listener.accept()
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            return
        sock.setblocking(False)
        self._add_connection(sock, initiated=False)

    def _service(self, conn: PeerConnection, mask: int) -> None:
        try:
            if mask & selectors.EVENT_READ:
                frames = conn.read_frames()
                if frames is None:
                    self._drop(conn, 'closed the connection')
                    return
                for kind, payload in frames:
                    self._handle(conn, kind, payload)
                    if conn.closed:
                        return
            if mask & selectors.EVENT_WRITE and not conn.closed:
                conn.write_armed = conn.write_some()
                if not conn.write_armed:
                    self._selector.modify(conn.sock, selectors.EVENT_READ, conn)
        except ProtocolError as err:
            self._drop(conn, f'broke the protocol: {err}')
        except OSError as err:
            self._drop(conn, f'failed: {err}')

    def _handle(self, conn: PeerConnection, kind: int, payload: bytes) -> None:
        if kind == HELLO:
            hello = decode_json(payload)
            if not isinstance(hello, dict) or hello.get('protocol') != PROTOCOL_VERSION or not hello.get('peer'):
                raise ProtocolError(f'expected a HELLO of protocol {PROTOCOL_VERSION}, got {str(hello)[:120]}')
            conn.hello, conn.peer_id = hello, str(hello['peer'])
            self._resolve_duplicates(conn)
        elif conn.hello is None:
            raise ProtocolError(f'expected HELLO first, got frame kind {kind}')
        elif kind == GRAPH:
            snap = decode_json(payload)
            if not isinstance(snap, dict):
                raise ProtocolError(f'expected a GRAPH object, got {str(snap)[:120]}')
            snap['peer'] = conn.peer_id
            with self._cond:
                conn.snapshot = snap
                self._recompute_interest()
                self._cond.notify_all()
            self._schedule_sync()
        elif kind == DATA:
            topic, stamp, data = decode_data(payload)
            conn.received += 1
            with self._lock:
                if len(self._inbound) == self._inbound.maxlen:
                    self.inbound_dropped += 1
                self._inbound.append((topic, stamp, data, conn.peer_id))
                schedule = not self._drain_scheduled and not self._stopping
                self._drain_scheduled = self._drain_scheduled or schedule
            if schedule:
                self.executor.call_soon_threadsafe(self._drain_inbound)

    def _resolve_duplicates(self, conn: PeerConnection) -> None:
        """Two peers that connected to each other at once keep the link the smaller id initiated."""
        with self._lock:
            twins = [c for c in self._conns if c is not conn and c.peer_id == conn.peer_id and not c.closed]
        for twin in twins:
            def initiator(c: PeerConnection) -> str:
                return self.peer_id if c.initiated else c.peer_id
            keep_new = initiator(conn) == min(self.peer_id, conn.peer_id)
            self._drop(twin if keep_new else conn, 'was a duplicate link', quiet=True)

    def _recompute_interest(self) -> None:
        interest: dict[str, dict[str, list[PeerConnection]]] = {}
        for conn in self._conns:
            if conn.closed or conn.snapshot is None:
                continue
            for node in conn.snapshot.get('nodes', []):
                for item in node.get('subscriptions', []):
                    try:
                        topic, type_name = str(item[0]), str(item[1])
                    except (IndexError, TypeError):
                        continue
                    conns = interest.setdefault(topic, {}).setdefault(type_name, [])
                    if conn not in conns:
                        conns.append(conn)
        self._interest = interest

    def _drop(self, conn: PeerConnection, why: str, quiet: bool = False) -> None:
        if conn.closed:
            return
        with contextlib.suppress(KeyError, ValueError):
            self._selector.unregister(conn.sock)
        conn.close()
        with self._cond:
            if conn in self._conns:
                self._conns.remove(conn)
            self._recompute_interest()
            self._cond.notify_all()
        self._schedule_sync()
        if quiet:
            return
        # A peer that died without cleaning up leaves its socket file: probe it, now and a little
        # later (a dying process may close our link before its listening socket), and remove it
        # once nobody listens there.
        socket_path = (conn.hello or {}).get('socket')
        if socket_path and not self._stopping and Path(socket_path).parent == self.path.parent:
            self._suspects.append((time.monotonic(), 0, Path(socket_path), conn.peer_id))

    def _probe_suspects(self) -> None:
        now = time.monotonic()
        due = [s for s in self._suspects if s[0] <= now]
        self._suspects = [s for s in self._suspects if s[0] > now]
        for _, tries, path, peer in due:
            with self._lock:
                if any(c.peer_id == peer for c in self._conns if not c.closed):
                    continue  # it came back
            probe = connect_or_clean(path, timeout_s=0.5)
            if probe is not None:
                probe.close()
                if tries < 4:  # still listening: look again at 0.1, 0.3, 0.7, 1.5 s
                    self._suspects.append((now + 0.1 * 2 ** tries, tries + 1, path, peer))

    def _close_all(self) -> None:
        with self._lock:
            conns, self._conns = list(self._conns), []
        for conn in conns:
            try:
                conn.sock.setblocking(True)
                conn.sock.settimeout(0.2)
                if conn.has_output():
                    conn.write_some()  # best effort: what is queued now, within 0.2 s
            except OSError:
                pass
            conn.close()
        for sock in (self._listener, self._wake_r, self._wake_w):
            if sock is not None:
                sock.close()
        self._wake_w = None
        if self._selector is not None:
            self._selector.close()
        if self.path is not None:
            with contextlib.suppress(FileNotFoundError):
                self.path.unlink()
