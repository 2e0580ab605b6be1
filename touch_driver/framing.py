"""Byte framing shared by the three sensors' serial protocols (see docs/protocols.md).

Every frame on the wire is::

    offset  size  field
    0       2     sync, 0xA5 0x5A
    2       1     sensor id (0x42 'B' bear, 0x50 'P' patch, 0x51 'Q' patch raw scan, 0x53 'S' skin)
    3       2     payload length n, uint16 little endian
    5       2     sequence counter, uint16 little endian, +1 per frame, wraps at 65536
    7       n     payload, as the sensor's firmware sends it
    7+n     2     CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF) over bytes 2..7+n-1, little endian

:class:`FrameDecoder` is a Packetizer in the manner of ``serial.threaded``: it is fed
arbitrary chunks of bytes and returns whole, checked frames. It never raises on bad
bytes: garbage, truncated frames and corrupt checksums are counted and skipped, and
it resynchronises on the next sync pattern.

>>> wire = encode_frame(0x53, 7, b'hi')
>>> wire.hex(' ')
'a5 5a 53 02 00 07 00 68 69 ba 66'
>>> dec = FrameDecoder({0x53: 2})
>>> dec.update(b'junk' + wire[:5]), dec.update(wire[5:])
([], [Frame(sensor_id=83, seq=7, payload=b'hi')])
>>> dec.stats.dropped_bytes, dec.stats.frames
(4, 1)
"""

from __future__ import annotations

import struct
from binascii import crc_hqx
from dataclasses import dataclass, field
from typing import Generic, TypeVar

__all__ = ['HEADER_SIZE', 'OVERHEAD', 'SYNC', 'DecoderStats', 'Frame', 'FrameDecoder', 'ScanT', 'SensorStreamDecoder',
           'crc16', 'encode_frame']

SYNC = b'\xa5\x5a'
_HEADER = struct.Struct('<2sBHH')
HEADER_SIZE = _HEADER.size  # 7
OVERHEAD = HEADER_SIZE + 2  # header + CRC
#: What a sensor's stream decoder yields per frame (BearScan, PatchScan, SkinScan).
ScanT = TypeVar('ScanT')


def crc16(data: bytes | bytearray | memoryview) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of b'123456789' is 0x29B1).

    >>> hex(crc16(b'123456789'))
    '0x29b1'
    """
    return crc_hqx(data, 0xFFFF)


def encode_frame(sensor_id: int, seq: int, payload: bytes) -> bytes:
    """One wire frame carrying ``payload``; ``seq`` is taken modulo 65536."""
    if not 0 <= sensor_id <= 255:
        raise ValueError(f'sensor_id must be 0..255, got {sensor_id}')
    if len(payload) > 0xFFFF:
        raise ValueError(f'payload of {len(payload)} bytes exceeds the 65535-byte limit')
    head = _HEADER.pack(SYNC, sensor_id, len(payload), seq & 0xFFFF)
    body = head[2:] + payload
    return head + payload + struct.pack('<H', crc16(body))


@dataclass(frozen=True, slots=True)
class Frame:
    """A checked frame: sensor id, sequence counter (0..65535) and raw payload bytes."""

    sensor_id: int
    seq: int
    payload: bytes


@dataclass
class DecoderStats:
    """Counters of a :class:`FrameDecoder`, all since it was made."""

    frames: int = 0            # good frames returned
    dropped_bytes: int = 0     # bytes discarded: garbage, bad frames, overflow
    checksum_errors: int = 0   # frames whose CRC did not match
    length_errors: int = 0     # headers with a length the sensor never sends
    sequence_gaps: int = 0     # times the counter jumped (frames lost on the way)
    frames_missed: int = 0     # frames lost, summed over the gaps
    last_seq: dict[int, int] = field(default_factory=dict)


class FrameDecoder:
    """Split a byte stream into checked frames, resynchronising after garbage.

    Args:
        payload_sizes: sensor id -> the payload length that id always carries. Frames of
            other ids, or with another length, are treated as garbage (a false sync).
        max_buffer: bytes kept while waiting for the rest of a frame; beyond that the
            oldest bytes are dropped (and counted), so memory stays bounded on any input.
    """

    def __init__(self, payload_sizes: dict[int, int], max_buffer: int = 1 << 16) -> None:
        if not payload_sizes:
            raise ValueError('payload_sizes must name at least one sensor id')
        self.payload_sizes = dict(payload_sizes)
        self.max_buffer = max(max_buffer, max(payload_sizes.values()) + OVERHEAD)
        self._buf = bytearray()
        self.stats = DecoderStats()

    def reset(self) -> None:
        """Forget buffered bytes and sequence history (after a reconnect); keep the counters."""
        self.stats.dropped_bytes += len(self._buf)
        self._buf.clear()
        self.stats.last_seq.clear()

    @property
    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)

    def update(self, data: bytes | bytearray | memoryview) -> list[Frame]:
        """Add bytes; return the frames completed by them, in order."""
        buf = self._buf
        buf += data
        stats = self.stats
        out: list[Frame] = []
        pos = 0
        n = len(buf)
        while True:
            start = buf.find(SYNC, pos)
            if start < 0:
                # Keep a trailing 0xA5: it may be the first half of the next sync.
                # (never a byte of the frame just returned: pos may already be at the end).
                keep_from = max(pos, n - 1) if n and buf[-1] == SYNC[0] else n
                stats.dropped_bytes += keep_from - pos
                pos = keep_from
                break
            stats.dropped_bytes += start - pos
            pos = start
            if n - pos < HEADER_SIZE:
                break
            _, sensor_id, length, seq = _HEADER.unpack_from(buf, pos)
            if self.payload_sizes.get(sensor_id) != length:
                stats.length_errors += 1
                stats.dropped_bytes += 1
                pos += 1
                continue
            end = pos + HEADER_SIZE + length + 2
            if end > n:
                break
            crc = buf[end - 2] | (buf[end - 1] << 8)
            if crc16(memoryview(buf)[pos + 2:end - 2]) != crc:
                # Drop only the sync byte: the real next frame may start inside this one.
                stats.checksum_errors += 1
                stats.dropped_bytes += 1
                pos += 1
                continue
            out.append(Frame(sensor_id, seq, bytes(buf[pos + HEADER_SIZE:end - 2])))
            stats.frames += 1
            last = stats.last_seq.get(sensor_id)
            if last is not None:
                missed = (seq - last - 1) & 0xFFFF
                if missed:
                    stats.sequence_gaps += 1
                    stats.frames_missed += missed
            stats.last_seq[sensor_id] = seq
            pos = end
        del buf[:pos]
        if len(buf) > self.max_buffer:
            excess = len(buf) - self.max_buffer
            stats.dropped_bytes += excess
            del buf[:excess]
        return out


class SensorStreamDecoder(Generic[ScanT]):
    """Base of the sensors' stream decoders: bytes from a port -> the sensor's decoded scans.

    A :class:`FrameDecoder` for the sensor's frame ids does the framing (resynchronisation,
    checksum, sequence gaps); a subclass implements :meth:`decode` for one checked frame. The
    driver (:class:`~touch_driver.serial_driver.SerialDriver`), the benchmarks and the
    simulation all update the same decoder object, so there is one path from bytes to a scan.

    Args:
        payload_sizes: sensor id -> payload length, as for :class:`FrameDecoder`.
        max_buffer: bytes kept while waiting for the rest of a frame.

    Attributes:
        corrupt_frames: checked frames whose payload still makes no sense (e.g. bits above
            the converter's range), skipped.
    """

    def __init__(self, payload_sizes: dict[int, int], max_buffer: int = 1 << 16) -> None:
        self._frames = FrameDecoder(payload_sizes, max_buffer=max_buffer)
        self.corrupt_frames = 0

    def decode(self, frame: Frame) -> ScanT | None:
        """The scan of one checked frame, or None for a corrupt payload (counted by :meth:`update`)."""
        raise NotImplementedError

    def update(self, data: bytes | bytearray | memoryview) -> list[ScanT]:
        """Add bytes read from the port; return the scans they complete, oldest first. Never raises on bytes."""
        out = []
        for frame in self._frames.update(data):
            scan = self.decode(frame)
            if scan is None:
                self.corrupt_frames += 1
            else:
                out.append(scan)
        return out

    @property
    def stats(self) -> DecoderStats:
        """Framing counters since construction (frames, dropped_bytes, checksum_errors, sequence_gaps, ...)."""
        return self._frames.stats

    @property
    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame (bounded by ``max_buffer``)."""
        return self._frames.buffered

    def reset(self) -> None:
        """Forget partial frames and sequence history (after a reconnect); counters are kept."""
        self._frames.reset()
