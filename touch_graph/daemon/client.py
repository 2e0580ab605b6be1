"""What a graph command uses: the daemon's graph, the daemon started on first use, or a participant of its own.

:func:`graph_source` is the entry. When no daemon answers, or one of another code version
does (it leaves), one is started in the background and asked once it answers; when it does
not come up, the command joins the domain itself. Imports nothing of Cyclone or the runtime
unless it falls back to a participant.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pickle
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from typing import Any

from ..dds.graph import GraphView
from ..dds.graph_queries import GraphQueries, no_graph_message
from ..errors import GraphError
from .address import DaemonAddress, code_version, daemon_address

__all__ = ['DaemonGraph', 'DaemonUnavailable', 'NewerDaemon', 'daemon_enabled', 'graph_source', 'request', 'spawn',
           'stop']

#: Longest the first command waits for the daemon it started to answer before joining the domain itself, s.
START_TIMEOUT_S = 10.0
#: Longest a query waits for the daemon's answer, s (the daemon's completeness wait is bounded well below).
REPLY_TIMEOUT_S = 15.0
#: The classes a daemon's answer may hold (anything else is refused, not unpickled).
_ALLOWED = {('touch_graph.dds.graph', name) for name in
            ('GraphView', 'NodeInfo', 'TopicInfo', 'ServiceInfo', 'EndpointInfo', 'ServiceEndpoint')} | {
    ('builtins', 'set'), ('builtins', 'frozenset'), ('builtins', 'bytearray')}


class DaemonUnavailable(GraphError):
    """No daemon answered at the address (not running, being replaced, or its answer was not readable)."""


class NewerDaemon(DaemonUnavailable):
    """The daemon runs a newer installation than this command: it stays, and this command asks its own participant."""


class _GraphUnpickler(pickle.Unpickler):
    def find_class(self, module: str, name: str) -> Any:
        if (module, name) not in _ALLOWED:
            raise pickle.UnpicklingError(f'the graph daemon sent {module}.{name}, which a graph answer never holds')
        return super().find_class(module, name)


def daemon_enabled() -> bool:
    """False when ``SOCIAL_TOUCH_DAEMON`` is ``0`` (as ``--no-daemon`` on every command)."""
    return os.environ.get('SOCIAL_TOUCH_DAEMON', '1').strip() != '0'


def request(op: str, address: DaemonAddress | None = None, timeout_s: float = REPLY_TIMEOUT_S) -> dict:
    """Send ``op`` (``graph``, ``status``, ``stop``) to the daemon; its answer.

    Raises:
        DaemonUnavailable: nobody listens at the address, or the answer did not come or could not be read.
    """
    address = daemon_address() if address is None else address
    line = json.dumps({'op': op, 'version': code_version()}).encode() + b'\n'
    try:
        with socket.socket(socket.AF_UNIX, socket.SOCK_STREAM) as sock:
            sock.settimeout(timeout_s)
            sock.connect(str(address.socket_path))
            sock.sendall(line)
            chunks = []
            while chunk := sock.recv(1 << 16):
                chunks.append(chunk)
    except OSError as err:  # no socket, refused (a daemon that was killed), timed out
        raise DaemonUnavailable(f'no graph daemon answers at {address.socket_path} ({err})') from err
    try:
        return _GraphUnpickler(io.BytesIO(b''.join(chunks))).load()
    except (pickle.UnpicklingError, EOFError, AttributeError, ValueError) as err:
        raise DaemonUnavailable(f'the graph daemon at {address.socket_path} sent an unreadable answer ({err})') from err


def spawn(address: DaemonAddress | None = None) -> subprocess.Popen:
    """Start the daemon for the current environment in the background, detached from this terminal."""
    address = daemon_address() if address is None else address
    # the runtime's own command runner (the console script belongs to the lab); argv shows in the process list
    argv = [sys.executable, '-c', 'import sys; from touch_graph.cli.main import main; sys.exit(main())', 'daemon',
            'serve', '--ros-domain-id', str(address.domain_id)]
    env = {k: v for k, v in os.environ.items() if k != 'SOCIAL_TOUCH_NETWORK'}  # a daemon is in the domain
    return subprocess.Popen(argv, env=env, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL, start_new_session=True, close_fds=True, cwd='/')


def wait_running(address: DaemonAddress | None = None, timeout_s: float = START_TIMEOUT_S,
                 process: subprocess.Popen | None = None) -> dict | None:
    """The daemon's status once it answers (None if it did not within ``timeout_s``, or ``process``, the daemon
    just spawned, exited without answering); with ``process``, only a daemon of this code version counts."""
    address = daemon_address() if address is None else address
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            status = request('status', address, timeout_s=max(0.1, deadline - time.monotonic()))
            if process is None or status.get('version') == code_version():
                return status
            raise DaemonUnavailable('the daemon of another version is still leaving')
        except DaemonUnavailable:
            if time.monotonic() >= deadline or (process is not None and process.poll() is not None):
                return None
            time.sleep(0.05)


def stop(address: DaemonAddress | None = None, timeout_s: float = 10.0) -> bool:
    """Ask the daemon to stop and wait until it has left; False if none was running."""
    address = daemon_address() if address is None else address
    try:
        request('stop', address)
    except DaemonUnavailable:
        return False
    deadline = time.monotonic() + timeout_s
    while address.socket_path.exists() and time.monotonic() < deadline:
        time.sleep(0.02)
    return True


class DaemonGraph(GraphQueries):
    """The daemon's graph, asked again at each :meth:`graph` (the daemon waits for it to be complete)."""

    def __init__(self, address: DaemonAddress, view: GraphView) -> None:
        self.address = address
        self._view = view

    def graph(self) -> GraphView:
        return self._view

    def wait_for_change(self, timeout_s: float) -> None:
        time.sleep(min(timeout_s, 0.1))
        self._view = fetch(self.address)

    def no_graph_message(self) -> str:
        return no_graph_message(self.address.domain_id, self.address.discovery_range)


def fetch(address: DaemonAddress) -> GraphView:
    """The daemon's complete graph.

    Raises:
        NewerDaemon: it runs a newer installation (it stays).
        DaemonUnavailable: no daemon answers, or it runs an older installation (it leaves; start another).
    """
    reply = request('graph', address)
    if reply.get('error') == 'version' and not reply.get('leaving'):
        raise NewerDaemon(f'the graph daemon at {address.socket_path} runs a newer installation of social-touch')
    if not reply.get('ok'):
        raise DaemonUnavailable(f"the graph daemon at {address.socket_path} refused: {reply.get('error')}")
    return reply['view']


@contextlib.contextmanager
def graph_source(name: str, no_daemon: bool = False) -> Iterator[GraphQueries]:
    """The graph for command ``name``: the daemon's (started here if none answers), else a participant of its own."""
    if not no_daemon and daemon_enabled():
        address = daemon_address()
        try:
            view = fetch(address)
        except NewerDaemon:
            view = None
        except DaemonUnavailable:
            # Start it and ask it: joining the domain here as well would cost the same discovery wait, and the
            # daemon's participant joining meanwhile would make this command wait for it too.
            view = None
            if wait_running(address, process=spawn(address)) is not None:
                with contextlib.suppress(DaemonUnavailable):
                    view = fetch(address)
        if view is not None:
            yield DaemonGraph(address, view)
            return
    from ..dds.tool import GraphTool  # lazy: a daemon's answer needs no Cyclone DDS, runtime or messages
    with GraphTool(name) as tool:
        yield tool
