"""Byte framing shared by the three sensors' serial protocols, protocol version 2 (docs/protocols.md).

Every frame on the wire is::

    offset  size  field
    0       2     sync, 0xA5 0x5A
    2       1     protocol version, 2
    3       1     sensor id (0x42 'B' bear, 0x50 'P' patch, 0x51 'Q' patch raw scan, 0x53 'S' skin)
    4       2     payload length n, uint16 little endian
    6       2     sequence counter, uint16 little endian, +1 per frame, wraps at 65536
    8       2     header check: CRC-16/CCITT-FALSE over bytes 2..7, little endian
    10      n     payload, as the sensor's firmware sends it
    10+n    4     CRC-32 (ISO-HDLC, as zlib.crc32) over bytes 2..10+n-1, little endian

Version 1 (no version byte, no header check, one CRC-16 over the frame) accepted bogus frames under
a flood of fake headers: every fake sync made the decoder wait for and checksum a whole payload, and
one in 65,536 of those passed. In version 2 a fake header is refused by its own check (all but one
in 65,536) before any payload is awaited, and a payload must then pass a 32-bit CRC.

:class:`FrameDecoder` is a Packetizer in the manner of ``serial.threaded``: it is fed
arbitrary chunks of bytes and returns whole, checked frames. It never raises on bad
bytes: garbage, truncated frames and corrupt checksums are counted and skipped, and
it resynchronises on the next sync pattern.

>>> wire = encode_frame(0x53, 7, b'hi')
>>> wire.hex(' ')
'a5 5a 02 53 02 00 07 00 4f 0a 68 69 d3 07 2a a4'
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
from typing import Generic, NamedTuple, TypeVar
from zlib import crc32

__all__ = ['HEADER_SIZE', 'MAX_WRAP_GAP', 'OVERHEAD', 'PROTOCOL_VERSION', 'START_SEQ', 'SYNC', 'DecoderStats',
           'Frame', 'FrameDecoder', 'ScanT', 'SensorStreamDecoder', 'crc16', 'crc32', 'encode_frame']

SYNC = b'\xa5\x5a'
PROTOCOL_VERSION = 2
_HEADER = struct.Struct('<2sBBHHH')   # sync, version, id, length, seq, header check
HEADER_SIZE = _HEADER.size            # 10
_CRC = struct.Struct('<I')
OVERHEAD = HEADER_SIZE + _CRC.size    # 14: header + CRC-32
_V1_HEADER = struct.Struct('<2sBH')   # version 1: sync, id, length (told apart to name an old firmware)
#: What a sensor's stream decoder yields per frame (BearScan, PatchScan, SkinScan).
ScanT = TypeVar('ScanT')


def crc16(data: bytes | bytearray | memoryview) -> int:
    """CRC-16/CCITT-FALSE of ``data`` (check value of b'123456789' is 0x29B1).

    >>> hex(crc16(b'123456789'))
    '0x29b1'
    """
    return crc_hqx(data, 0xFFFF)


def encode_frame(sensor_id: int, seq: int, payload: bytes) -> bytes:
    """One version-2 wire frame carrying ``payload``; ``seq`` is taken modulo 65536."""
    if not 0 <= sensor_id <= 255:
        raise ValueError(f'sensor_id must be 0..255, got {sensor_id}')
    if len(payload) > 0xFFFF:
        raise ValueError(f'payload of {len(payload)} bytes exceeds the 65535-byte limit')
    fields = struct.pack('<BBHH', PROTOCOL_VERSION, sensor_id, len(payload), seq & 0xFFFF)
    head = SYNC + fields + struct.pack('<H', crc16(fields))
    return head + payload + _CRC.pack(crc32(payload, crc32(head[2:])))


class Frame(NamedTuple):
    """A checked frame: sensor id, sequence counter (0..65535) and raw payload bytes (immutable; a named
    tuple, cheaper to make than a frozen dataclass, one per frame)."""

    sensor_id: int
    seq: int
    payload: bytes


@dataclass
class DecoderStats:
    """Counters of a :class:`FrameDecoder`, all since it was made."""

    frames: int = 0            # good frames returned
    dropped_bytes: int = 0     # bytes discarded: garbage, bad frames, overflow
    header_errors: int = 0     # a sync whose header failed its check (a false sync in garbage or payload)
    version_errors: int = 0    # headers of another protocol version (version 1: a firmware to update)
    length_errors: int = 0     # checked headers with an id this port does not carry, or a length that id never has
    checksum_errors: int = 0   # frames with a good header whose CRC-32 did not match
    sequence_gaps: int = 0     # times the counter skipped frames that never arrived (nor arrived corrupt)
    frames_missed: int = 0     # frames lost, summed over the gaps (a corrupt frame is a checksum error only)
    repeated_frames: int = 0   # frames resent with the last frame's sequence number: dropped, not returned
    sequence_resets: int = 0   # times the counter jumped back or restarted (a sensor that rebooted)
    last_seq: dict[int, int] = field(default_factory=dict)


#: A sensor's first sequence number after power-up.
START_SEQ = 0
#: A jump onto :data:`START_SEQ` skipping more frames than this is a restart, not a gap across the wrap.
MAX_WRAP_GAP = 64
#: Sequence numbers of corrupt frames remembered per sensor until its next good frame (bounded memory).
_MAX_BAD_SEQS = 256


class FrameDecoder:
    """Split a byte stream into checked frames, resynchronising after garbage.

    Every frame is accounted once, under the cause that lost it. The sequence counter tells apart

    - a **repeat**: the last frame's number again (a resent frame): counted in ``repeated_frames``,
      its bytes in ``dropped_bytes``, not returned, so it is never data twice;
    - a **reset**: the counter jumped back, or onto :data:`START_SEQ` skipping more than
      :data:`MAX_WRAP_GAP` frames (a sensor that rebooted): counted in ``sequence_resets``, and
      counting restarts from the new number (nothing is counted lost). A 16-bit counter cannot tell
      a jump back from a loss of more than half its range (32,767 frames), so such a loss is a reset
      too, never a made-up count of frames lost;
    - a **gap**: frames skipped forward. Those whose header arrived but whose CRC-32 failed are
      checksum errors already; only the others are ``frames_missed``.

    A sync is trusted only once the header after it passes its own check, so a fake header costs
    a CRC over 6 bytes, not a wait for and a CRC over a payload. After a bad header or a bad
    frame the search resumes at the byte after the sync (the real next frame may start inside
    the bad one; the sync's second byte, 0x5A, cannot start a sync).

    Args:
        payload_sizes: sensor id -> the payload length that id always carries. Frames of
            other ids, or with another length, are treated as garbage (``length_errors``).
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
        # sensor id -> sequence numbers of its frames that failed their CRC-32 since its last good frame.
        self._bad_seqs: dict[int, list[int]] = {}

    def reset(self) -> None:
        """Forget buffered bytes and sequence history (after a reconnect); keep the counters."""
        self.stats.dropped_bytes += len(self._buf)
        self._buf.clear()
        self.stats.last_seq.clear()
        self._bad_seqs.clear()

    @property
    def buffered(self) -> int:
        """Bytes held while waiting for the rest of a frame."""
        return len(self._buf)

    def _header_fault(self, buf: bytearray, pos: int, header: tuple) -> str | None:
        """Which counter the header at ``pos`` (``header``: its fields unpacked) fails, or None if it is good."""
        _, version, sensor_id, length, _, check = header
        if crc16(memoryview(buf)[pos + 2:pos + 8]) != check:
            _, v1_id, v1_length = _V1_HEADER.unpack_from(buf, pos)
            return 'version_errors' if self.payload_sizes.get(v1_id) == v1_length else 'header_errors'
        if version != PROTOCOL_VERSION:
            return 'version_errors'
        if self.payload_sizes.get(sensor_id) != length:
            return 'length_errors'
        return None

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
            header = _HEADER.unpack_from(buf, pos)
            fault = self._header_fault(buf, pos, header)
            if fault is not None:
                setattr(stats, fault, getattr(stats, fault) + 1)
                stats.dropped_bytes += 2
                pos += 2
                continue
            _, _, sensor_id, length, seq, _ = header
            end = pos + HEADER_SIZE + length + _CRC.size
            if end > n:
                break
            view = memoryview(buf)
            if crc32(view[pos + 2:end - _CRC.size]) != _CRC.unpack_from(buf, end - _CRC.size)[0]:
                view.release()
                # Drop only the sync: the real next frame may start inside this one.
                stats.checksum_errors += 1
                bad = self._bad_seqs.setdefault(sensor_id, [])
                if len(bad) < _MAX_BAD_SEQS:
                    bad.append(seq)
                stats.dropped_bytes += 2
                pos += 2
                continue
            if self._is_repeat(sensor_id, seq):
                view.release()
                stats.repeated_frames += 1
                stats.dropped_bytes += end - pos
                pos = end
                continue
            out.append(Frame(sensor_id, seq, bytes(view[pos + HEADER_SIZE:end - _CRC.size])))
            view.release()
            stats.frames += 1
            self._count_sequence(sensor_id, seq)
            pos = end
        del buf[:pos]
        if len(buf) > self.max_buffer:
            excess = len(buf) - self.max_buffer
            stats.dropped_bytes += excess
            del buf[:excess]
        return out


    def _is_repeat(self, sensor_id: int, seq: int) -> bool:
        return self.stats.last_seq.get(sensor_id) == seq

    def _count_sequence(self, sensor_id: int, seq: int) -> None:
        """Account the jump from the sensor's last good frame to ``seq`` (a gap, a reset or nothing)."""
        stats = self.stats
        last = stats.last_seq.get(sensor_id)
        stats.last_seq[sensor_id] = seq
        bad = self._bad_seqs.pop(sensor_id, ())
        if last is None:
            return
        skipped = (seq - last - 1) & 0xFFFF
        if skipped >= 0x7FFF or (seq == START_SEQ and skipped > MAX_WRAP_GAP):
            stats.sequence_resets += 1
            return
        # Frames of the gap that arrived corrupt are checksum errors already: count each loss once.
        corrupt = {s for s in bad if 1 <= (s - last) & 0xFFFF <= skipped}
        missed = skipped - len(corrupt)
        if missed:
            stats.sequence_gaps += 1
            stats.frames_missed += missed


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
