"""Sensate Bear wire protocol: one frame per full scan of the 8 Midplanes (docs/protocols.md).

Frames use the shared framing of :mod:`touch_driver.framing` with sensor id 0x42 ('B').
The payload is the scan as the Somatic board sends it (knight2009 IV.A, V.C)::

    offset  size  field
    0       128   64 x uint16 little endian, channel = midplane * 8 + input,
                  10-bit ADC counts 0..1023; bits 10-15 are zero

A payload with any of bits 10-15 set cannot come from a 10-bit converter: the stream
decoder counts it as a corrupt frame and does not decode it.

>>> raw = np.arange(64, dtype=np.uint16) * 16
>>> payload = encode_payload(raw)
>>> len(payload), payload[:6].hex(' ')
(128, '00 00 10 00 20 00')
>>> bool((decode_payload(payload) == raw).all())
True
>>> dec = BearDecoder()
>>> scans = dec.update(b'noise' + encode_frame(BEAR_ID, 9, payload))
>>> [(s.seq, int(s.raw[1])) for s in scans], dec.stats.dropped_bytes
([(9, 16)], 5)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from touch_driver.framing import Frame, SensorStreamDecoder, encode_frame
from touch_graph.errors import MessageError

__all__ = ['ADC_MAX', 'BEAR_ID', 'N_CHANNELS', 'PAYLOAD_SIZE', 'REAL_RATE_HZ', 'BearDecoder', 'BearPayloadError',
           'BearScan', 'decode_payload', 'encode_payload', 'encode_scan']

#: The real bear's scan rate, scans/s: 58 channels x 5 ms = 0.29 s, "3.4 Hz" (knight2009 VI.B).
REAL_RATE_HZ = 3.4
#: Sensor id of a bear scan frame ('B').
BEAR_ID = 0x42
#: Channels in a scan: 8 Midplanes x 8 inputs (knight2009 IV.A).
N_CHANNELS = 64
#: Bytes of payload: 64 x uint16.
PAYLOAD_SIZE = 2 * N_CHANNELS
#: Full scale of the 10-bit converter (knight2009 III: "10-bit resolution").
ADC_MAX = 1023

_WIRE = np.dtype('<u2')


class BearPayloadError(MessageError, ValueError):
    """A bear payload that does not decode: wrong length or bits above the 10-bit range."""


@dataclass(frozen=True, slots=True)
class BearScan:
    """One decoded scan.

    Attributes:
        seq: frame sequence counter, 0..65535 (wraps).
        raw: (64,) uint16 ADC counts 0..1023 indexed by channel (midplane * 8 + input).
    """

    seq: int
    raw: np.ndarray


def encode_payload(raw: np.ndarray) -> bytes:
    """(64,) counts 0..1023 -> the 128-byte payload; ValueError on a wrong shape or range."""
    values = np.asarray(raw)
    if values.shape != (N_CHANNELS,):
        raise ValueError(f'a bear scan has shape ({N_CHANNELS},); got {values.shape}')
    if values.dtype.kind not in 'iu' or values.min(initial=0) < 0 or values.max(initial=0) > ADC_MAX:
        raise ValueError(f'bear counts must be integers 0..{ADC_MAX}; got dtype {values.dtype}, '
                         f'range {values.min()}..{values.max()}')
    return values.astype(_WIRE, copy=False).tobytes()


def decode_payload(payload: bytes | bytearray | memoryview) -> np.ndarray:
    """128 payload bytes -> (64,) uint16 counts (a new, writable array, native byte order).

    Raises:
        BearPayloadError: on a length other than 128 or a value above 1023.
    """
    if len(payload) != PAYLOAD_SIZE:
        raise BearPayloadError(f'a bear payload is {PAYLOAD_SIZE} bytes (64 x uint16); got {len(payload)}')
    raw = np.frombuffer(payload, dtype=_WIRE).astype(np.uint16)
    if (raw > ADC_MAX).any():
        bad = int(np.flatnonzero(raw > ADC_MAX)[0])
        raise BearPayloadError(f'channel {bad} carries {int(raw[bad])}, above the 10-bit range 0..{ADC_MAX} '
                               '(bits 10-15 must be zero): corrupt frame')
    return raw


def encode_scan(seq: int, raw: np.ndarray) -> bytes:
    """A whole wire frame (framing + payload) for one scan."""
    return encode_frame(BEAR_ID, seq, encode_payload(raw))


class BearDecoder(SensorStreamDecoder[BearScan]):
    """Bytes from the bear's port -> :class:`BearScan` objects; never raises on bad bytes.

    Wraps a :class:`~touch_driver.framing.FrameDecoder` (resynchronisation, checksum,
    sequence gaps) and counts checked frames whose payload is still invalid
    (:attr:`corrupt_frames`: bits above the 10-bit range).
    """

    def __init__(self, max_buffer: int = 1 << 16) -> None:
        super().__init__({BEAR_ID: PAYLOAD_SIZE}, max_buffer=max_buffer)

    def decode(self, frame: Frame) -> BearScan | None:
        """The scan of one checked frame; None when a count is above 1023."""
        raw = np.frombuffer(frame.payload, dtype=_WIRE)
        if raw.max() > ADC_MAX:
            return None
        return BearScan(frame.seq, raw.astype(np.uint16))
