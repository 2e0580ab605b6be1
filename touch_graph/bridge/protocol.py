"""The bridge's wire protocol: length-prefixed frames over a Unix stream socket.

Every frame is ``u32 payload length | u8 kind | payload`` (little endian). Kinds:

- ``HELLO``: JSON ``{"protocol": 1, "peer": id, "name": ..., "pid": ..., "socket": path}``,
  the first frame each side sends on a new connection;
- ``GRAPH``: JSON snapshot of the sender's graph (see :mod:`touch_graph.bridge.graph`),
  sent after HELLO and again whenever the sender's graph changes;
- ``DATA``: ``u16 topic length | topic (UTF-8) | i64 publisher-side ROS time, ns | CDR bytes``.

Encoding is pure; :class:`FrameReader` turns a byte stream back into frames and raises
:class:`ProtocolError` (never anything deeper) on a stream that is not this protocol.

>>> reader = FrameReader()
>>> frames = reader.feed(encode_data('/touch/gesture', 1_700_000_000_000_000_000, b'\\x00\\x01\\x00\\x00'))
>>> kind, payload = frames[0]
>>> kind == DATA, decode_data(payload)
(True, ('/touch/gesture', 1700000000000000000, b'\\x00\\x01\\x00\\x00'))
>>> reader.feed(encode_json(HELLO, {'peer': 'a'})[:3])  # a partial frame waits for the rest
[]
"""

from __future__ import annotations

import json
import struct
from typing import Any

from ..errors import GraphError

__all__ = [
    'DATA', 'GRAPH', 'HELLO', 'KIND_NAMES', 'MAX_PAYLOAD', 'PROTOCOL_VERSION', 'FrameReader', 'ProtocolError',
    'decode_data', 'decode_json', 'encode_data', 'encode_json',
]

PROTOCOL_VERSION = 1
HELLO, GRAPH, DATA = 1, 2, 3
KIND_NAMES = {HELLO: 'HELLO', GRAPH: 'GRAPH', DATA: 'DATA'}
#: Largest payload accepted (bytes): far above any sensor frame, small enough that a
#: corrupt length cannot make a reader allocate gigabytes.
MAX_PAYLOAD = 64 * 1024 * 1024

_HEAD = struct.Struct('<IB')
_TOPIC_LEN = struct.Struct('<H')
_STAMP = struct.Struct('<q')


class ProtocolError(GraphError):
    """Bytes from a peer that are not this protocol (the connection is closed)."""


def encode_json(kind: int, obj: Any) -> bytes:
    """A HELLO or GRAPH frame carrying ``obj`` as compact JSON."""
    payload = json.dumps(obj, separators=(',', ':')).encode()
    return _HEAD.pack(len(payload), kind) + payload


def decode_json(payload: bytes) -> Any:
    try:
        return json.loads(payload)
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise ProtocolError(f'expected a JSON payload, got {payload[:40]!r}...: {err}') from err


def encode_data(topic: str, stamp_ns: int, cdr: bytes) -> bytes:
    """A DATA frame: topic, publisher-side ROS time (ns), CDR bytes."""
    name = topic.encode()
    size = _TOPIC_LEN.size + len(name) + _STAMP.size + len(cdr)
    return b''.join((_HEAD.pack(size, DATA), _TOPIC_LEN.pack(len(name)), name, _STAMP.pack(stamp_ns), cdr))


def decode_data(payload: bytes | memoryview) -> tuple[str, int, bytes]:
    """``(topic, stamp_ns, cdr)`` of a DATA payload."""
    if len(payload) < _TOPIC_LEN.size + _STAMP.size:
        raise ProtocolError(f'DATA frame of {len(payload)} bytes is shorter than its header (10 bytes)')
    (name_len,) = _TOPIC_LEN.unpack_from(payload, 0)
    start = _TOPIC_LEN.size + name_len
    if len(payload) < start + _STAMP.size:
        raise ProtocolError(f'DATA frame of {len(payload)} bytes cannot hold a {name_len}-byte topic name')
    try:
        topic = bytes(payload[_TOPIC_LEN.size:start]).decode()
    except UnicodeDecodeError as err:
        raise ProtocolError(f'DATA frame topic name is not UTF-8: {err}') from err
    (stamp,) = _STAMP.unpack_from(payload, start)
    return topic, stamp, bytes(payload[start + _STAMP.size:])


class FrameReader:
    """Splits a byte stream into ``(kind, payload)`` frames; keeps partial frames for the next feed."""

    def __init__(self, max_payload: int = MAX_PAYLOAD) -> None:
        self._buffer = bytearray()
        self._max_payload = max_payload

    def feed(self, data: bytes) -> list[tuple[int, bytes]]:
        """Append ``data``; return the frames it completes.

        Raises:
            ProtocolError: an unknown kind or a length above ``max_payload``.
        """
        buffer = self._buffer
        buffer += data
        frames = []
        pos = 0
        head = _HEAD.size
        while len(buffer) - pos >= head:
            size, kind = _HEAD.unpack_from(buffer, pos)
            if kind not in KIND_NAMES:
                raise ProtocolError(f'unknown frame kind {kind} (expected one of {sorted(KIND_NAMES)}); '
                                    'is the peer another program or another protocol version?')
            if size > self._max_payload:
                raise ProtocolError(f'frame of {size} bytes is above the limit of {self._max_payload}')
            if len(buffer) - pos - head < size:
                break
            frames.append((kind, bytes(buffer[pos + head:pos + head + size])))
            pos += head + size
        if pos:
            del buffer[:pos]  # one compaction per feed, not one per frame
        return frames

    @property
    def pending(self) -> int:
        """Bytes of an incomplete frame held back."""
        return len(self._buffer)
