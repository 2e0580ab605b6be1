"""A TCP front for the Foxglove WebSocket server that also serves clients asking for ``foxglove.websocket.v1``.

foxglove-sdk's server accepts only the subprotocol ``foxglove.sdk.v1`` and answers HTTP 400 to a
client asking for the older name of the same protocol, ``foxglove.websocket.v1`` (foxglove-sdk
discussion 1131). :class:`SubprotocolFront` listens where the server should and rewrites only the
handshake: the request names ``foxglove.sdk.v1`` for the server, the answer names what the client
asked for; then bytes pass through unchanged, so the server still sees a slow client as slow.

A subscribe sent right after an advertisement may be answered ``Unknown channel ID: N``; the front
reads the frames both ways (:class:`SubscribeReplay`) and sends such a subscribe again once the
channel is advertised, up to :data:`MAX_REPLAYS` times.

Before anything reaches the server, a handshake from a page of another site (``Origin``) or to a
name that is not this machine (``Host``) is refused with 403 (:class:`~touch_view.origins.OriginPolicy`).
"""

from __future__ import annotations

import json
import os
import re
import socket
import struct
import threading
import time
from collections.abc import Callable
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
    _end(source, sink)


def _end(*socks: socket.socket) -> None:
    for sock in socks:
        with suppress(OSError):
            sock.shutdown(socket.SHUT_RDWR)


#: How often one refused subscribe is sent again at most.
MAX_REPLAYS = 20
#: How long after a refusal (or after the channel's advertisement, when it came later) the subscribe is sent again, s.
REPLAY_DELAY_S = 0.1
_UNKNOWN_CHANNEL = re.compile(r'Unknown channel ID: (\d+)')


class FrameReader:
    """Whole WebSocket frames (RFC 6455 section 5.2) out of a byte stream: ``feed(bytes)`` returns the frames
    completed, each as ``(raw bytes, fin, opcode, payload unmasked)``."""

    def __init__(self) -> None:
        self._buf = bytearray()

    def feed(self, data: bytes) -> list[tuple[bytes, bool, int, bytes]]:
        self._buf += data
        frames = []
        while (frame := self._next()) is not None:
            frames.append(frame)
        return frames

    def _next(self) -> tuple[bytes, bool, int, bytes] | None:
        buf = self._buf
        if len(buf) < 2:
            return None
        fin, opcode, masked, length = buf[0] >> 7, buf[0] & 0x0F, buf[1] >> 7, buf[1] & 0x7F
        at = 2
        if length == 126:
            if len(buf) < 4:
                return None
            length, at = struct.unpack_from('!H', buf, 2)[0], 4
        elif length == 127:
            if len(buf) < 10:
                return None
            length, at = struct.unpack_from('!Q', buf, 2)[0], 10
        key = bytes(buf[at:at + 4]) if masked else b''
        at += len(key) if masked else 0
        if (masked and len(key) < 4) or len(buf) < at + length:
            return None
        payload = bytes(buf[at:at + length])
        if masked and opcode == 1:  # only text is read (JSON); binary payloads stay masked
            payload = _unmask(payload, key)
        raw = bytes(buf[:at + length])
        del buf[:at + length]
        return raw, bool(fin), opcode, payload


def _unmask(payload: bytes, key: bytes) -> bytes:
    return bytes(b ^ key[i % 4] for i, b in enumerate(payload))


def masked_text_frame(text: str) -> bytes:
    """A client's text frame (masked, as RFC 6455 requires of a client) carrying ``text``."""
    payload, key = text.encode(), os.urandom(4)
    n = len(payload)
    if n < 126:
        length = bytes([0x80 | n])
    elif n < 1 << 16:
        length = bytes([0x80 | 126]) + struct.pack('!H', n)
    else:
        length = bytes([0x80 | 127]) + struct.pack('!Q', n)
    return bytes([0x81]) + length + key + _unmask(payload, key)


def _json(opcode: int, fin: bool, payload: bytes) -> dict | None:
    """A whole text frame's JSON object (None for anything else: binary, fragments, control frames)."""
    if opcode != 1 or not fin:
        return None
    try:
        message = json.loads(payload)
    except ValueError:
        return None
    return message if isinstance(message, dict) else None


class SubscribeReplay:
    """One connection's client-to-server and server-to-client streams, frame by frame: forwards every frame as
    it came, and sends the server again a subscribe it refused with ``Unknown channel ID`` (see the module doc).

    Attributes:
        replayed: subscribes sent again.
    """

    def __init__(self, client: socket.socket, server: socket.socket, on_replay: Callable[[], None] = lambda: None,
                 ) -> None:
        self.client, self.server, self.on_replay = client, server, on_replay
        self.replayed = 0
        self._lock = threading.Lock()           # one frame at a time to the server
        self._subscribed: dict[int, list[int]] = {}   # channel -> subscription ids the client asked for
        self._advertised: set[int] = set()
        self._refused: dict[int, int] = {}      # channel -> replays so far
        self._waiting: set[int] = set()         # refused channels not advertised yet
        self._fragmented = False                # the client is between the frames of one message

    def upstream(self) -> None:
        """Client to server (run in its own thread)."""
        reader = FrameReader()
        with suppress(OSError):
            while chunk := self.client.recv(1 << 16):
                for raw, fin, opcode, payload in reader.feed(chunk):
                    message = _json(opcode, fin, payload)
                    if message is not None and message.get('op') == 'subscribe':
                        for sub in message.get('subscriptions', []):
                            if isinstance(sub, dict) and isinstance(sub.get('channelId'), int):
                                self._subscribed.setdefault(sub['channelId'], []).append(sub.get('id'))
                    elif message is not None and message.get('op') == 'unsubscribe':
                        gone = set(message.get('subscriptionIds', []))
                        for ids in self._subscribed.values():
                            ids[:] = [i for i in ids if i not in gone]
                    with self._lock:
                        if opcode in (0, 1, 2):
                            self._fragmented = not fin
                        self.server.sendall(raw)
        _end(self.client, self.server)

    def downstream(self, forwarded: bytes = b'') -> None:
        """Server to client (in the serving thread). ``forwarded``: frames the server sent in the same read as its
        handshake answer (an advertise may come with it), already forwarded to the client: they are read here."""
        reader = FrameReader()
        self._read_server(reader, forwarded)
        with suppress(OSError):
            while chunk := self.server.recv(1 << 16):
                self.client.sendall(chunk)      # unchanged, at once; read after
                self._read_server(reader, chunk)
        _end(self.server, self.client)

    def _read_server(self, reader: FrameReader, chunk: bytes) -> None:
        for _, fin, opcode, payload in reader.feed(chunk):
            message = _json(opcode, fin, payload)
            if message is not None:
                self._on_server_message(message)

    def _on_server_message(self, message: dict) -> None:
        op = message.get('op')
        if op == 'advertise':
            channels = {c.get('id') for c in message.get('channels', []) if isinstance(c, dict)}
            self._advertised |= channels
            for channel in self._waiting & channels:
                self._waiting.discard(channel)
                self._replay_later(channel)
        elif op == 'unadvertise':
            self._advertised -= set(message.get('channelIds', []))
        elif op == 'status' and (found := _UNKNOWN_CHANNEL.search(str(message.get('message', '')))):
            channel = int(found.group(1))
            if not self._subscribed.get(channel) or self._refused.get(channel, 0) >= MAX_REPLAYS:
                return
            self._refused[channel] = self._refused.get(channel, 0) + 1
            if channel in self._advertised:
                self._replay_later(channel)
            else:
                self._waiting.add(channel)

    def _replay_later(self, channel: int) -> None:
        timer = threading.Timer(REPLAY_DELAY_S, self._replay, args=(channel,))
        timer.daemon = True
        timer.start()

    def _replay(self, channel: int) -> None:
        ids = list(self._subscribed.get(channel, []))
        if not ids or channel not in self._advertised:
            return
        frame = masked_text_frame(json.dumps({'op': 'subscribe', 'subscriptions': [
            {'id': sid, 'channelId': channel} for sid in ids]}))
        deadline = time.monotonic() + 1.0
        while True:
            with self._lock:
                if not self._fragmented:
                    with suppress(OSError):
                        self.server.sendall(frame)
                        self.replayed += 1
                        self.on_replay()
                    return
            if time.monotonic() > deadline:
                return
            time.sleep(0.01)


class SubprotocolFront:
    """Listens on ``host:port`` and forwards every connection to the server on ``127.0.0.1:backend_port``.

    Raises (from the constructor): OSError when ``host:port`` cannot be bound.

    Attributes:
        port: the port it listens on (the one given, or the free one picked for 0).
        renamed: connections whose handshake asked for ``foxglove.websocket.v1`` only.
        replayed: subscribes the server refused as ``Unknown channel ID`` and the front sent again.
        policy: the Host and Origin checks; ``policy.refused`` counts the handshakes refused.
    """

    def __init__(self, host: str, port: int, backend_port: int, allowed_origins: tuple[str, ...] = ()) -> None:
        self.backend_port = backend_port
        self.renamed = 0
        self.replayed = 0
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
            streams = SubscribeReplay(client, server, self._count_replay)
            upstream = threading.Thread(target=streams.upstream, daemon=True)
            upstream.start()
            streams.downstream(forwarded=rest)
            upstream.join()
        except (OSError, ValueError):
            pass  # a client that left mid-handshake, a server that refused it: nothing to keep
        finally:
            for sock in (client, server):
                if sock is not None:
                    with self._lock:
                        self._connections.discard(sock)
                    sock.close()

    def _count_replay(self) -> None:
        with self._lock:
            self.replayed += 1

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
