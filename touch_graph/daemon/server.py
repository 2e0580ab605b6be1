"""The graph daemon process: a hidden node in the domain, answering graph queries on a Unix socket.

Run by :func:`touch_graph.daemon.client.spawn` as ``social-touch daemon serve``, detached (a session
of its own, no terminal). One request per connection: a JSON line
``{"op": "graph" | "status" | "stop", "version": ...}``; the answer is a pickled dict
(:mod:`.client` reads it back with only the graph's classes allowed).
"""

from __future__ import annotations

import fcntl
import json
import os
import pickle
import signal
import socketserver
import threading
import time
from typing import Any

from ..errors import GraphError
from .address import code_version, daemon_address, is_older

__all__ = ['IDLE_TIMEOUT_S', 'serve']

#: A daemon nobody asked for this long exits, s (ros2cli's: two hours).
IDLE_TIMEOUT_S = 2 * 3600.0
#: How long a new daemon waits for the one it replaces (another code version) to leave, s.
LOCK_WAIT_S = 30.0
#: The daemon's participant announces itself this often (Cyclone configuration, after the user's): a Fast DDS node
#: on LOCALHOST announces itself by multicast only and learns of a participant that started before it (the daemon)
#: from that participant's next announcement; until then the daemon cannot know the node (touch_graph.dds.config).
DAEMON_SPDP = '<CycloneDDS><Domain><Discovery><SPDPInterval>100ms</SPDPInterval></Discovery></Domain></CycloneDDS>'
#: How long after joining the daemon waits for anyone before saying the domain is empty, s.
DISCOVERY_TIMEOUT_S = 2.0


class _GraphCache:
    """The daemon's participant and when its graph last changed (tracked all the time, for the settle rule)."""

    def __init__(self, tool: Any) -> None:
        self.tool = tool
        self.started = time.monotonic()
        self.last_change = self.started
        self.last_request = self.started
        self.requests = 0
        self._stop = threading.Event()
        self._watcher = threading.Thread(target=self._watch, name='graph-daemon-watch', daemon=True)
        self._watcher.start()

    def _watch(self) -> None:
        discovery = self.tool.discovery
        version, structure = discovery.version, discovery.structure_version
        while not self._stop.is_set():
            version = discovery.wait_for_change(version, 0.5)
            if discovery.structure_version != structure:
                structure, self.last_change = discovery.structure_version, time.monotonic()

    def complete_view(self) -> Any:
        """The graph once complete (:func:`~touch_graph.dds.tool.wait_for_complete_graph`)."""
        from ..dds.tool import wait_for_complete_graph  # lazy: loaded by serve() (see there)
        wait_for_complete_graph(self.tool.discovery, DISCOVERY_TIMEOUT_S, started=self.started,
                                last_change=self.last_change)
        return self.tool.graph()

    def close(self) -> None:
        self._stop.set()
        self._watcher.join(2.0)


class _Server(socketserver.ThreadingMixIn, socketserver.UnixStreamServer):
    daemon_threads = True

    def __init__(self, path: str, cache: _GraphCache, version: str, info: dict) -> None:
        super().__init__(path, _Handler)
        self.cache, self.version, self.info = cache, version, info
        self.stopping = threading.Event()

    def stop(self) -> None:
        if not self.stopping.is_set():
            self.stopping.set()
            threading.Thread(target=self.shutdown, daemon=True).start()


class _Handler(socketserver.StreamRequestHandler):
    server: _Server

    def handle(self) -> None:
        server = self.server
        try:
            request = json.loads(self.rfile.readline(4096) or b'{}')
            op = request.get('op')
        except (ValueError, AttributeError):
            op, request = None, {}
        cache = server.cache
        cache.last_request = time.monotonic()
        cache.requests += 1
        reply: dict[str, Any] = {'ok': True, 'version': server.version, 'pid': os.getpid()}
        if op == 'graph' and request.get('version') != server.version:
            leaving = is_older(server.version, str(request.get('version')))
            reply.update(ok=False, error='version', leaving=leaving)
            if leaving:  # a newer installation asks: leave it the place (an older one asks its own participant)
                server.stop()
        elif op == 'graph':
            started = time.monotonic()
            reply['view'] = cache.complete_view()
            reply['waited_s'] = time.monotonic() - started
        elif op == 'status':
            reply.update(server.info, requests=cache.requests, up_s=time.monotonic() - cache.started,
                         participants=cache.tool.discovery.remote_participant_count())
        elif op == 'stop':
            server.stop()
        else:
            reply.update(ok=False, error=f'unknown request {request!r}')
        self.wfile.write(pickle.dumps(reply, protocol=pickle.HIGHEST_PROTOCOL))


def _hold_lock(path: Any, wait_s: float) -> int | None:
    """An exclusive lock on ``path`` for this process's life (one daemon per address), waiting up to ``wait_s``
    for a daemon that is leaving; None if another still holds it."""
    fd = os.open(path, os.O_CREAT | os.O_RDWR, 0o600)
    deadline = time.monotonic() + wait_s
    while True:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            return fd
        except BlockingIOError:
            if time.monotonic() >= deadline:
                os.close(fd)
                return None
            time.sleep(0.05)


def serve(domain_id: int, idle_timeout_s: float = IDLE_TIMEOUT_S) -> int:
    """Be the daemon of the current environment's address until stopped or idle for ``idle_timeout_s``.

    ``domain_id`` must be ``ROS_DOMAIN_ID`` (given to be seen in the process list, as ros2cli's daemon does).
    Returns 0 at once when another daemon serves the address.
    """
    address = daemon_address()
    if domain_id != address.domain_id:
        raise GraphError(f'--ros-domain-id {domain_id} is not ROS_DOMAIN_ID ({address.domain_id})')
    lock = _hold_lock(address.lock_path, LOCK_WAIT_S)
    if lock is None:
        return 0  # another daemon serves this address
    from ..dds.tool import GraphTool  # lazy: a second daemon returns above without loading Cyclone DDS
    address.socket_path.unlink(missing_ok=True)  # left by a daemon that was killed
    # After the address is known (the setting names the daemon): announce the daemon often, see DAEMON_SPDP.
    os.environ['CYCLONEDDS_URI'] = ','.join(filter(None, [os.environ.get('CYCLONEDDS_URI', ''), DAEMON_SPDP]))
    version = code_version()
    with GraphTool(f'daemon_{address.domain_id}', discovery_timeout_s=0.0) as tool:
        cache = _GraphCache(tool)
        info = {'domain_id': address.domain_id, 'discovery_range': address.discovery_range,
                'socket': str(address.socket_path), 'idle_timeout_s': idle_timeout_s}
        server = _Server(str(address.socket_path), cache, version, info)
        for signum in (signal.SIGTERM, signal.SIGINT, signal.SIGHUP):
            signal.signal(signum, lambda *_: server.stop())

        def idle_watch() -> None:
            while not server.stopping.wait(min(idle_timeout_s, 5.0)):
                if time.monotonic() - cache.last_request >= idle_timeout_s:
                    server.stop()
        threading.Thread(target=idle_watch, name='graph-daemon-idle', daemon=True).start()
        try:
            server.serve_forever(poll_interval=0.5)
        finally:
            server.server_close()
            address.socket_path.unlink(missing_ok=True)
            cache.close()
    os.close(lock)
    return 0
