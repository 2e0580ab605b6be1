"""Join graph processes into one graph, as DDS does for ROS 2: ``launch`` here, ``topic echo`` there.

Design (one :class:`Bridge` per process and context):

- **Discovery**: the bridge listens on a Unix socket in the domain directory (see
  :mod:`touch_graph.bridge.discovery`), connects to every peer socket present when it
  starts, and accepts the peers that start later: a full mesh, one connection per pair
  (if two peers start together and connect both ways, the connection initiated by the
  peer with the smaller id survives). Stale sockets are removed on contact.
- **Graph**: on connecting, each side sends HELLO and a GRAPH snapshot of its nodes,
  publishers and subscriptions (:mod:`touch_graph.bridge.graph`), and a new snapshot
  whenever its graph changes. Peers that close or die disappear from the remote graph
  at once, with everything that was bridged for them.
- **Data**: a process sends a topic's messages only to the peers that subscribe to it.
  For each local topic that a peer wants, the bridge's hidden node (``/_bridge_<name>``)
  holds a raw subscription with ``ignore_local_publications=True`` whose callback (in the
  executor thread) stamps the CDR bytes with the ROS time of the publishing process and
  queues them on each interested connection. Received messages go to a bounded inbound
  queue, drained in the executor thread (through ``call_soon_threadsafe``), and are
  published into the local graph by the hidden node's publishers; the hidden node's own
  subscription skips them, so nothing echoes back, and each process forwards only what
  its own nodes publish.
- **Taps**: tools (``topic echo``, ``hz``, ``record``) subscribe with :meth:`Bridge.tap`
  and get :class:`Sample` objects (topic, type, publisher-side ROS time, CDR bytes) in the
  executor thread, so a recording of a simulated-time scene carries simulated time.
- **Threads**: one I/O thread (``selectors``) does every socket call. Send queues are
  bounded and drop their oldest frame when full (counted), so a slow or paused reader
  never blocks the robot's graph. :meth:`Bridge.stop` closes every socket, removes the
  socket file and joins the thread.

Limitations: TRANSIENT_LOCAL (latched) messages are not replayed to peers that join
later; a topic with different types in two processes is not bridged (a warning says so).
"""

from __future__ import annotations

import contextlib
import os
import selectors
import socket
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from itertools import count
from pathlib import Path
from typing import Any

from ..errors import GraphError, MessageError
from ..runtime.node import Node
from ..runtime.qos import QoSProfile
from .connection import PeerConnection
from .discovery import MAX_SOCKET_PATH, connect_or_clean, domain_directory, domain_id, list_sockets, socket_name
from .graph import GraphView, build_snapshot
from .io_thread import PeerIO
from .protocol import GRAPH, encode_json

__all__ = ['Bridge', 'Sample', 'Tap']

_serials = count()


@dataclass(frozen=True)
class Sample:
    """One message as it crossed the bridge."""

    topic: str
    type_name: str
    stamp_ns: int  #: ROS time of the publishing process when the message left it, ns
    data: bytes  #: CDR bytes
    peer: str  #: socket id of the publishing process


class Tap:
    """A tool's subscription served by the bridge itself (see :meth:`Bridge.tap`)."""

    def __init__(self, bridge: Bridge, topic: str, type_name: str, callback: Callable[[Sample], None]) -> None:
        self.bridge = bridge
        self.topic = topic
        self.type_name = type_name
        self.callback = callback
        self.received = 0
        self.errors = 0

    def close(self) -> None:
        self.bridge._remove_tap(self)


class Bridge(PeerIO):
    """A graph process as a peer of the other graph processes of its domain.

    Args:
        context: the process's :class:`~touch_graph.runtime.Context` (initialised).
        executor: the executor that spins it; call :meth:`start` before it spins (or from its thread).
        name: a readable peer name (``launch``, ``topic_echo``); the hidden node is ``/_bridge_<name>``.
        directory: base directory of the domain directories (tests: a tmp dir); default
            ``$SOCIAL_TOUCH_GRAPH_DIR``, ``$XDG_RUNTIME_DIR/social_touch`` or ``/tmp/social_touch-<uid>``.
        domain: the domain id (default ``$ROS_DOMAIN_ID`` or 0).
        send_queue_frames, send_queue_bytes: bounds of each connection's send queue.
        inbound_limit: bound (frames) of the queue of received messages waiting for the executor.
    """

    def __init__(self, context: Any, executor: Any, *, name: str = 'graph', directory: str | os.PathLike | None = None,
                 domain: int | None = None, send_queue_frames: int = 4096, send_queue_bytes: int = 16 * 1024 * 1024,
                 inbound_limit: int = 10_000) -> None:
        if inbound_limit < 1:
            raise ValueError(f'inbound_limit must be >= 1, got {inbound_limit}')
        self.context = context
        self.executor = executor
        self.name = name
        self.domain = domain_id() if domain is None else domain
        self._directory = directory
        self._queue_bounds = (send_queue_frames, send_queue_bytes)
        self.path: Path | None = None
        self.peer_id = ''
        self._lock = threading.RLock()
        self._cond = threading.Condition(self._lock)
        self._conns: list[PeerConnection] = []
        self._initial: list[PeerConnection] = []
        self._taps: dict[str, list[Tap]] = {}
        self._inbound: deque[tuple[str, int, bytes, str]] = deque(maxlen=inbound_limit)
        self.inbound_dropped = 0
        self.inject_errors = 0
        self._drain_scheduled = False
        self._sync_scheduled = False
        self._graph_dirty = True
        self._last_graph: bytes | None = None
        self._interest: dict[str, dict[str, list[PeerConnection]]] = {}
        self._senders: dict[str, tuple[PeerConnection, ...]] = {}  # copy-on-write, read by the executor thread
        self._outbound: dict[str, Any] = {}  # topic -> raw Subscription of the hidden node
        self._inject: dict[str, Any] = {}  # topic -> Publisher of the hidden node
        self._warned: set[tuple[str, str]] = set()
        self._suspects: list[tuple[float, int, Path, str]] = []  # (due, tries, socket, peer) to probe
        self._node: Node | None = None
        self._listener: socket.socket | None = None
        self._wake_r: socket.socket | None = None
        self._wake_w: socket.socket | None = None
        self._selector: selectors.BaseSelector | None = None
        self._thread: threading.Thread | None = None
        self._stopping = False
        self._started = False
        self._stopped = False

    # ------------------------------------------------------------------ lifecycle
    def start(self) -> Bridge:
        """Listen, connect to the peers present, start the I/O thread; returns ``self``."""
        if self._started:
            raise GraphError('bridge already started')
        self._started = True
        folder = domain_directory(self._directory, self.domain)
        self.peer_id = socket_name(self.name, os.getpid(), next(_serials))
        self.path = folder / self.peer_id
        if len(str(self.path).encode()) > MAX_SOCKET_PATH:
            raise GraphError(f'graph socket path {self.path} is longer than {MAX_SOCKET_PATH} bytes; '
                             'set SOCIAL_TOUCH_GRAPH_DIR to a shorter directory')
        safe = ''.join(c if c.isalnum() or c == '_' else '_' for c in self.name)
        self._node = Node(f'_bridge_{safe}', context=self.context)
        self.executor.add_node(self._node)
        listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            self.path.unlink(missing_ok=True)
            listener.bind(str(self.path))
            listener.listen(64)
            listener.setblocking(False)
        except OSError as err:
            listener.close()
            self._node.destroy_node()
            raise GraphError(f'cannot listen on graph socket {self.path}: {err}') from err
        self._listener = listener
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._wake_w.setblocking(False)
        self._selector = selectors.DefaultSelector()
        self._selector.register(listener, selectors.EVENT_READ, 'listen')
        self._selector.register(self._wake_r, selectors.EVENT_READ, 'wake')
        self.context.add_graph_listener(self._on_local_graph)
        self.context.on_shutdown(self.stop)
        # Bind before looking, so two peers starting together always find each other.
        for path in list_sockets(folder):
            if path.name == self.peer_id:
                continue
            sock = connect_or_clean(path, timeout_s=1.0)
            if sock is not None:
                conn = self._add_connection(sock, initiated=True)
                self._initial.append(conn)
        self._thread = threading.Thread(target=self._run, name=f'bridge-{self.name}', daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Close every connection and the socket, join the I/O thread, remove the hidden node. Idempotent."""
        if not self._started or self._stopped:
            return
        self._stopped = True
        self._stopping = True
        self._wake()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        self.context.remove_graph_listener(self._on_local_graph)
        if self._node is not None:
            self._node.destroy_node()
        with self._cond:
            self._cond.notify_all()

    def __enter__(self) -> Bridge:
        return self.start() if not self._started else self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ------------------------------------------------------------------ queries
    def remote_graph(self) -> GraphView:
        """Nodes and topics of every connected peer (not of this process)."""
        with self._lock:
            snaps = [c.snapshot for c in self._conns if c.snapshot is not None and not c.closed]
        return GraphView.from_snapshots(snaps)

    def peers(self) -> list[str]:
        with self._lock:
            return sorted(c.peer_id for c in self._conns if c.peer_id and not c.closed)

    def wait_for_discovery(self, timeout_s: float = 2.0) -> bool:
        """Wait until every peer present at start has sent its graph (or gone); False on timeout."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while not all(c.snapshot is not None or c.closed for c in self._initial):
                left = deadline - time.monotonic()
                if left <= 0 or self._stopped:
                    return False
                self._cond.wait(left)
        return True

    def wait_until(self, predicate: Callable[[GraphView], bool], timeout_s: float) -> bool:
        """Wait (wall time) until ``predicate(remote_graph())`` holds; returns its last value."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while True:
                if predicate(self.remote_graph()):
                    return True
                left = deadline - time.monotonic()
                if left <= 0 or self._stopped:
                    return False
                self._cond.wait(min(left, 0.25))

    def stats(self) -> dict[str, int]:
        """Counters: peers, DATA frames sent/dropped/received, inbound drops, injection errors."""
        with self._lock:
            conns = list(self._conns)
        return {'peers': sum(1 for c in conns if c.peer_id and not c.closed), 'sent': sum(c.sent for c in conns),
                'dropped': sum(c.dropped for c in conns), 'received': sum(c.received for c in conns),
                'inbound_dropped': self.inbound_dropped, 'inject_errors': self.inject_errors}

    def flush(self, timeout_s: float = 2.0) -> bool:
        """Spin the executor until local messages reached the wire; call from the spinning thread."""
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            pending_local = any(sub._queue for sub in list(self._outbound.values()))
            with self._lock:
                pending_net = any(c.has_output() for c in self._conns if not c.closed)
            if not pending_local and not pending_net:
                return True
            if pending_local:
                self.executor.spin_once(0.01)
            else:
                time.sleep(0.005)
        return False

    # ------------------------------------------------------------------ taps
    def tap(self, topic: str, callback: Callable[[Sample], None], type_name: str) -> Tap:
        """Subscribe a tool to ``topic`` of type ``type_name`` across the graph.

        ``callback(sample)`` runs in the executor thread; peers see the tap as a
        subscription of the hidden node.
        """
        tap = Tap(self, topic, type_name, callback)
        with self._lock:
            self._taps.setdefault(topic, []).append(tap)
            self._graph_dirty = True
        self._wake()
        return tap

    def _remove_tap(self, tap: Tap) -> None:
        with self._lock:
            taps = self._taps.get(tap.topic, [])
            if tap in taps:
                taps.remove(tap)
                if not taps:
                    del self._taps[tap.topic]
                self._graph_dirty = True
        self._wake()

    # ------------------------------------------------------------------ local graph -> peers
    def _on_local_graph(self, event: str, endpoint: Any) -> None:
        owner = endpoint if event.startswith('node') else getattr(endpoint, 'node', None)
        if owner is self._node or self._stopping:
            return
        with self._lock:
            self._graph_dirty = True
        self._wake()
        self._schedule_sync()

    def _snapshot_frame(self) -> bytes:
        with self._lock:
            taps = [(topic, tap.type_name) for topic, taps in self._taps.items() for tap in taps]
        snap = build_snapshot(self.context, peer=self.peer_id, name=self.name, pid=os.getpid(),
                              hidden_node=self._node, taps=taps)
        return encode_json(GRAPH, snap)

    def _wake(self) -> None:
        sock = self._wake_w
        if sock is not None:
            # A full wake pipe already wakes the thread; a closed one means we stopped.
            with contextlib.suppress(OSError):
                sock.send(b'\0')

    # ------------------------------------------------------------------ endpoints (executor thread)
    def _schedule_sync(self) -> None:
        with self._lock:
            if self._sync_scheduled or self._stopping:
                return
            self._sync_scheduled = True
        self.executor.call_soon_threadsafe(self._sync_endpoints)

    def _sync_endpoints(self) -> None:
        """Make the hidden node's endpoints match remote interest and local publishers."""
        with self._lock:
            self._sync_scheduled = False
            interest = {t: {ty: list(cs) for ty, cs in types.items()} for t, types in self._interest.items()}
        if self._stopped or self._node is None:
            return
        node = self._node
        senders: dict[str, tuple[PeerConnection, ...]] = {}
        with self.context._lock:
            local = {name: topic for name, topic in self.context.topics.items()
                     if any(p.node is not node for p in topic.publishers)}
        for name, types in interest.items():
            topic = local.get(name)
            if topic is None:
                continue
            conns = types.get(topic.type_name)
            for other in types:
                if other != topic.type_name and (name, other) not in self._warned:
                    self._warned.add((name, other))
                    node.get_logger().warn(f"not bridging '{name}': a peer subscribes with type {other}, "
                                           f'this process publishes {topic.type_name}')
            if conns:
                senders[name] = tuple(conns)
        for name in list(self._outbound):
            if name not in senders:
                node.destroy_subscription(self._outbound.pop(name))
        for name in senders:
            if name not in self._outbound:
                topic = local[name]
                self._outbound[name] = node.create_subscription(
                    topic.msg_type, name, self._make_forwarder(name), QoSProfile(depth=1000), raw=True,
                    ignore_local_publications=True)
        self._senders = senders
        for name in list(self._inject):
            topic = self.context.topics.get(name)
            if topic is None or not any(s.node is not node for s in topic.subscriptions):
                node.destroy_publisher(self._inject.pop(name))

    def _make_forwarder(self, topic: str) -> Callable[[bytes], None]:
        from .protocol import encode_data
        now_ns = self.context.now_ns

        def forward(data: bytes) -> None:
            conns = self._senders.get(topic)
            if not conns:
                return
            frame = encode_data(topic, now_ns(), data)
            wake = False
            for conn in conns:
                wake |= conn.enqueue_data(frame)
            if wake:
                self._wake()
        return forward

    def _drain_inbound(self) -> None:
        with self._lock:
            items = list(self._inbound)
            self._inbound.clear()
            self._drain_scheduled = False
            taps = {t: list(v) for t, v in self._taps.items()}
        if self._stopped:
            return
        for topic, stamp, data, peer in items:
            for tap in taps.get(topic, ()):
                tap.received += 1
                try:
                    tap.callback(Sample(topic, tap.type_name, stamp, data, peer))
                except Exception as err:  # a tool's bug must not stop delivery to the graph
                    tap.errors += 1
                    if tap.errors == 1:
                        self._node.get_logger().error(f"tap on '{topic}' raised: {type(err).__name__}: {err}")
            self._publish_locally(topic, data)

    def _publish_locally(self, topic_name: str, data: bytes) -> None:
        node = self._node
        pub = self._inject.get(topic_name)
        if pub is None:
            topic = self.context.topics.get(topic_name)
            if topic is None or not any(s.node is not node for s in topic.subscriptions):
                return
            pub = self._inject[topic_name] = node.create_publisher(topic.msg_type, topic_name, QoSProfile(depth=10))
        try:
            pub.publish(data)
        except (MessageError, GraphError) as err:
            self.inject_errors += 1
            if self.inject_errors == 1:
                node.get_logger().error(f"dropped a message on '{topic_name}' from a peer: {err}")
