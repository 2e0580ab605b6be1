"""A TCP front for the Foxglove WebSocket server that also serves clients asking for ``foxglove.websocket.v1``.

foxglove-sdk's server (0.30) accepts only the subprotocol ``foxglove.sdk.v1`` and answers HTTP 400
to a client that asks for the older name ``foxglove.websocket.v1`` alone (older Foxglove apps,
Lichtblick before 1.22, ``@foxglove/ws-protocol`` and roslibjs-foxglove clients), although both
name the same protocol (foxglove-sdk discussion 1131). :class:`SubprotocolFront` listens where
the server should, and for each connection rewrites only the WebSocket handshake: the request's
``Sec-WebSocket-Protocol: foxglove.websocket.v1`` becomes ``foxglove.sdk.v1`` for the server, and
the server's answer names the protocol the client asked for. After the handshake it passes the
bytes through unchanged in both directions (the frames do not depend on the subprotocol's name), so
the server's per-client queue still sees a slow client as slow. A client that asks for
``foxglove.sdk.v1`` is passed through untouched.

Before anything reaches the server, the front refuses with 403 a handshake from a page of another
site (its ``Origin``) or sent to a name that is not this machine (its ``Host``: DNS rebinding), as
:class:`~touch_view.origins.OriginPolicy` decides; foxglove-sdk's own server checks neither.
"""

from __future__ import annotations

import re
import socket
import threading
from contextlib import suppress

from .origins import FOXGLOVE_ORIGINS, OriginPolicy

__all__ = ['NEW_SUBPROTOCOL', 'OLD_SUBPROTOCOL', 'SubprotocolFront', 'header', 'rewrite_request', 'rewrite_response']

OLD_SUBPROTOCOL = 'foxglove.websocket.v1'
NEW_SUBPROTOCOL = 'foxglove.sdk.v1'
#: The longest HTTP handshake accepted (a browser's is about 1 KiB), bytes.
MAX_HEADER = 64 * 1024
#: How long a client may take to send its handshake, s.
HANDSHAKE_TIMEOUT_S = 10.0
_PROTOCOL_LINE = re.compile(rb'^sec-websocket-protocol:(.*)$', re.IGNORECASE | re.MULTILINE)


def rewrite_request(head: bytes) -> tuple[bytes, bool]:
    """The request head for the server, and whether the answer must be renamed back.

    >>> rewrite_request(b'GET / HTTP/1.1\\r\\nSec-WebSocket-Protocol: foxglove.websocket.v1\\r\\n\\r\\n')
    (b'GET / HTTP/1.1\\r\\nSec-WebSocket-Protocol: foxglove.sdk.v1\\r\\n\\r\\n', True)
    >>> rewrite_request(b'GET / HTTP/1.1\\r\\nSec-WebSocket-Protocol: foxglove.sdk.v1, x\\r\\n\\r\\n')[1]
    False
    """
    offered = [p.strip() for m in _PROTOCOL_LINE.finditer(head) for p in m.group(1).decode('latin-1').split(',')]
    if NEW_SUBPROTOCOL in offered or OLD_SUBPROTOCOL not in offered:
        return head, False
    return _PROTOCOL_LINE.sub(f'Sec-WebSocket-Protocol: {NEW_SUBPROTOCOL}\r'.encode(), head, count=1), True


def header(head: bytes, name: str) -> list[str]:
    """Every value of the header ``name`` in an HTTP head (normally none or one).

    >>> header(b'GET / HTTP/1.1\\r\\nHost: 127.0.0.1:8765\\r\\norigin: https://a.b\\r\\n\\r\\n', 'Origin')
    ['https://a.b']
    """
    found = re.findall(rb'^' + re.escape(name.encode()) + rb':[ \t]*(.*?)[ \t]*\r?$', head,
                       re.IGNORECASE | re.MULTILINE)
    return [value.decode('latin-1') for value in found]


def _forbidden(reason: str) -> bytes:
    body = f'refused: {reason}\n'.encode()
    return (b'HTTP/1.1 403 Forbidden\r\nContent-Type: text/plain; charset=utf-8\r\nConnection: close\r\n'
            b'Content-Length: ' + str(len(body)).encode() + b'\r\n\r\n' + body)


def rewrite_response(head: bytes) -> bytes:
    """The server's answer with the subprotocol renamed to the one the client asked for.

    >>> rewrite_response(b'HTTP/1.1 101 Switching Protocols\\r\\nsec-websocket-protocol: foxglove.sdk.v1\\r\\n\\r\\n')
    b'HTTP/1.1 101 Switching Protocols\\r\\nSec-WebSocket-Protocol: foxglove.websocket.v1\\r\\n\\r\\n'
    """
    return _PROTOCOL_LINE.sub(f'Sec-WebSocket-Protocol: {OLD_SUBPROTOCOL}\r'.encode(), head, count=1)


def _read_head(sock: socket.socket) -> tuple[bytes, bytes]:
    """An HTTP head (up to and with the blank line) and the bytes read after it; ValueError if too long/cut."""
    data = b''
    while b'\r\n\r\n' not in data:
        chunk = sock.recv(4096)
        if not chunk or len(data) > MAX_HEADER:
            raise ValueError('the connection ended or sent more than a handshake before its end')
        data += chunk
    end = data.index(b'\r\n\r\n') + 4
    return data[:end], data[end:]


def _pump(source: socket.socket, sink: socket.socket) -> None:
    """Copy ``source`` to ``sink`` until either closes; then end both directions."""
    with suppress(OSError):
        while chunk := source.recv(1 << 16):
            sink.sendall(chunk)
    for sock in (sink, source):
        with suppress(OSError):
            sock.shutdown(socket.SHUT_RDWR)


class SubprotocolFront:
    """Listens on ``host:port`` and forwards every connection to the server on ``127.0.0.1:backend_port``.

    Raises (from the constructor): OSError when ``host:port`` cannot be bound.

    Attributes:
        port: the port it listens on (the one given, or the free one picked for 0).
        renamed: connections whose handshake asked for ``foxglove.websocket.v1`` only.
        policy: the Host and Origin checks; ``policy.refused`` counts the handshakes refused.
    """

    def __init__(self, host: str, port: int, backend_port: int, allowed_origins: tuple[str, ...] = ()) -> None:
        self.backend_port = backend_port
        self.renamed = 0
        self.policy = OriginPolicy(host, allowed_origins, FOXGLOVE_ORIGINS)
        self._listener = socket.create_server((host, port), reuse_port=False)
        self.port = self._listener.getsockname()[1]
        self._connections: set[socket.socket] = set()
        self._lock = threading.Lock()
        self._closed = False
        self._thread = threading.Thread(target=self._accept, name=f'foxglove-front-{self.port}', daemon=True)
        self._thread.start()

    def _accept(self) -> None:
        while not self._closed:
            try:
                client, _ = self._listener.accept()
            except OSError:
                return
            threading.Thread(target=self._serve, args=(client,), name='foxglove-front-client', daemon=True).start()

    def _track(self, *socks: socket.socket) -> bool:
        with self._lock:
            if self._closed:
                return False
            self._connections.update(socks)
            return True

    def _serve(self, client: socket.socket) -> None:
        server = None
        try:
            client.settimeout(HANDSHAKE_TIMEOUT_S)
            head, rest = _read_head(client)
            refusal = self.policy.refusal(header(head, 'Host'), header(head, 'Origin'))
            if refusal is not None:
                client.sendall(_forbidden(refusal))
                return
            head, rename = rewrite_request(head)
            server = socket.create_connection(('127.0.0.1', self.backend_port), timeout=HANDSHAKE_TIMEOUT_S)
            if not self._track(client, server):
                return
            server.sendall(head + rest)
            answer, rest = _read_head(server)
            if rename:
                self.renamed += 1
                answer = rewrite_response(answer)
            client.sendall(answer + rest)
            client.settimeout(None)
            server.settimeout(None)
            for sock in (client, server):
                sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            upstream = threading.Thread(target=_pump, args=(client, server), daemon=True)
            upstream.start()
            _pump(server, client)
            upstream.join()
        except (OSError, ValueError):
            pass  # a client that left mid-handshake, a server that refused it: nothing to keep
        finally:
            for sock in (client, server):
                if sock is not None:
                    with self._lock:
                        self._connections.discard(sock)
                    sock.close()

    def close(self) -> None:
        """Stop listening and end every connection. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
            connections = list(self._connections)
        with suppress(OSError):
            self._listener.shutdown(socket.SHUT_RDWR)
        self._listener.close()
        for sock in connections:
            with suppress(OSError):
                sock.shutdown(socket.SHUT_RDWR)
        self._thread.join(timeout=5.0)
