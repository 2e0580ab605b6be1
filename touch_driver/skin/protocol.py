"""Wire protocol of the optoelectronic skin (cirillo2017 2.2): geometry, scanning order, payload codec.

The skin is 12 x 12 taxels made of 36 sensing modules of 2 x 2 taxels under one silicone dome.
The modules form 3 groups of 12 that share 4 A/D channels per group; in scan step ``s`` the MCU
powers module ``s`` of every group and samples the 12 channels (cirillo2017 2.2, Eq. 1 with
n = 36, m = 3, p = 12). The firmware sends the samples in that order, so the 288-byte payload is::

    for s in 0..11:            # scan step = module index inside its group
        for g in 0..2:         # group, one set of 4 A/D channels each
            for t in 0..3:     # taxel of module g*12 + s: 0 top-left, 1 top-right, 2 bottom-left, 3 bottom-right
                uint16 little endian

Taxel arrays in the rest of the project are row-major: ``index = row * 12 + col``, row 0 at the
connector edge. Module ``m`` covers rows ``2*(m // 6)..+1`` and cols ``2*(m % 6)..+1``.
Coordinates are mm from the outer corner of taxel (0, 0), x along columns, y along rows.

Each payload travels in one frame of :mod:`touch_driver.framing` with sensor id 0x53 ('S'),
150 frames per second. Reordering is a precomputed index permutation, so decoding a frame is
one ``np.frombuffer`` and one gather.

>>> wire = np.arange(N_TAXELS, dtype=np.uint16)          # wire position k carries value k
>>> taxels = decode_payload(wire.astype('<u2').tobytes())
>>> taxels.reshape(12, 12)[:2, :4]                       # module 0 then module 1 (scan step 1)
array([[ 0,  1, 12, 13],
       [ 2,  3, 14, 15]], dtype=uint16)
>>> encode_payload(taxels) == wire.astype('<u2').tobytes()
True
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from ..framing import Frame, SensorStreamDecoder, encode_frame

__all__ = [
    'ACTIVE_SIDE_MM', 'FRAME_PERIOD_S', 'FRAME_RATE_HZ', 'MODULES_PER_GROUP', 'MODULE_TAXELS', 'N_COLS',
    'N_GROUPS', 'N_MODULES', 'N_ROWS', 'N_TAXELS', 'PAYLOAD_SIZE', 'ROW_MAJOR_FROM_WIRE', 'SENSOR_ID',
    'TAXEL_PITCH_MM', 'TAXEL_XY_MM', 'WIRE_FROM_ROW_MAJOR', 'SkinScan', 'SkinStreamDecoder',
    'decode_payload', 'encode_payload', 'encode_skin_frame', 'module_of_taxel',
]

N_ROWS = 12
N_COLS = 12
N_TAXELS = N_ROWS * N_COLS        # 144
N_MODULES = 36                    # sensing modules of 2 x 2 taxels (cirillo2017 2.2)
N_GROUPS = 3                      # m = 3 groups sharing 4 A/D channels each (cirillo2017 Eq. 1)
MODULES_PER_GROUP = 12            # p = 12 digital I/O lines, one scan step each
MODULES_PER_ROW = N_COLS // 2     # 6 modules across
SENSOR_ID = 0x53                  # 'S' in the shared framing
PAYLOAD_SIZE = 2 * N_TAXELS       # 288 bytes, "the sensor provides 288 bytes" (cirillo2017 3)
FRAME_RATE_HZ = 150.0             # cirillo2017 2.2, STM32F303 scanning all 144 taxels
FRAME_PERIOD_S = 1.0 / FRAME_RATE_HZ
ACTIVE_SIDE_MM = 47.0             # active surface about 47 x 47 mm^2 (cirillo2017 2.2)
TAXEL_PITCH_MM = ACTIVE_SIDE_MM / N_COLS


def _module_taxels() -> np.ndarray:
    """(36, 4) int: row-major taxel indices of each module, taxels in order TL, TR, BL, BR."""
    m = np.arange(N_MODULES)[:, None]
    t = np.arange(4)[None, :]
    rows = 2 * (m // MODULES_PER_ROW) + t // 2
    cols = 2 * (m % MODULES_PER_ROW) + t % 2
    return (rows * N_COLS + cols).astype(np.intp)


#: (36, 4) intp: row-major index of taxel t (0 TL, 1 TR, 2 BL, 3 BR) of module m.
MODULE_TAXELS = _module_taxels()


def _wire_order() -> np.ndarray:
    """(144,) intp: the row-major taxel index carried at each wire position."""
    s = np.arange(MODULES_PER_GROUP)[:, None, None]
    g = np.arange(N_GROUPS)[None, :, None]
    t = np.arange(4)[None, None, :]
    module = g * MODULES_PER_GROUP + s
    return MODULE_TAXELS[module, t].reshape(-1)


#: (144,) intp: ``row_major = wire[ROW_MAJOR_FROM_WIRE]`` (gather on decode).
ROW_MAJOR_FROM_WIRE = np.argsort(_wire_order()).astype(np.intp)
#: (144,) intp: ``wire = row_major[WIRE_FROM_ROW_MAJOR]`` (gather on encode).
WIRE_FROM_ROW_MAJOR = _wire_order()
ROW_MAJOR_FROM_WIRE.setflags(write=False)
WIRE_FROM_ROW_MAJOR.setflags(write=False)
MODULE_TAXELS.setflags(write=False)


def _taxel_xy() -> np.ndarray:
    rows, cols = np.divmod(np.arange(N_TAXELS), N_COLS)
    return np.stack([(cols + 0.5) * TAXEL_PITCH_MM, (rows + 0.5) * TAXEL_PITCH_MM], axis=1)


#: (144, 2) float64: centre of each taxel in mm, columns (x, y), row-major.
TAXEL_XY_MM = _taxel_xy()
TAXEL_XY_MM.setflags(write=False)

_LE_U16 = np.dtype('<u2')


def module_of_taxel(index: int) -> tuple[int, int]:
    """``(module, taxel-in-module)`` of a row-major taxel index.

    >>> module_of_taxel(0), module_of_taxel(13), module_of_taxel(143)
    ((0, 0), (0, 3), (35, 3))
    """
    if not 0 <= index < N_TAXELS:
        raise ValueError(f'taxel index must be 0..{N_TAXELS - 1}, got {index}')
    row, col = divmod(index, N_COLS)
    return (row // 2) * MODULES_PER_ROW + col // 2, 2 * (row % 2) + col % 2


def decode_payload(payload: bytes | bytearray | memoryview) -> np.ndarray:
    """288 payload bytes in scanning order -> (144,) uint16 ADC counts, row-major.

    Raises:
        ValueError: when the payload is not 288 bytes (the stream decoder never passes such a payload).
    """
    if len(payload) != PAYLOAD_SIZE:
        raise ValueError(f'a skin payload is {PAYLOAD_SIZE} bytes (144 taxels x uint16); got {len(payload)}')
    wire = np.frombuffer(payload, dtype=_LE_U16)
    # The gather copies into a fresh native-order array, so the result does not alias the bytes.
    return wire[ROW_MAJOR_FROM_WIRE].astype(np.uint16, copy=False)


def encode_payload(taxels: np.ndarray) -> bytes:
    """(144,) or (12, 12) ADC counts, row-major, integers in 0..65535 -> 288 bytes in scanning order.

    Raises:
        ValueError: on another shape, non-integer values or values outside 0..65535.
    """
    arr = np.asarray(taxels)
    if arr.size != N_TAXELS or arr.shape not in ((N_TAXELS,), (N_ROWS, N_COLS)):
        raise ValueError(f'expected 144 taxel counts as shape (144,) or (12, 12); got shape {arr.shape}')
    arr = arr.reshape(N_TAXELS)
    if arr.dtype != np.uint16:
        if not np.issubdtype(arr.dtype, np.integer):
            raise ValueError(f'taxel counts must be integers (uint16 ADC counts); got dtype {arr.dtype}; '
                             'round and clip to 0..65535 first')
        if arr.min() < 0 or arr.max() > 0xFFFF:
            raise ValueError(f'taxel counts must be in 0..65535; got {arr.min()}..{arr.max()}')
    return arr[WIRE_FROM_ROW_MAJOR].astype(_LE_U16, copy=False).tobytes()


def encode_skin_frame(seq: int, taxels: np.ndarray) -> bytes:
    """A whole wire frame (framing header, payload in scanning order, CRC) for one skin scan."""
    return encode_frame(SENSOR_ID, seq, encode_payload(taxels))


class SkinScan(NamedTuple):
    """One decoded skin scan: wire sequence counter (0..65535) and (144,) uint16 counts, row-major."""

    seq: int
    raw: np.ndarray


class SkinStreamDecoder(SensorStreamDecoder[SkinScan]):
    """Bytes from the serial port -> :class:`SkinScan` objects; never raises on bad bytes.

    A thin layer over :class:`touch_driver.framing.FrameDecoder` that accepts only id 0x53 with
    a 288-byte payload (anything else is garbage to resynchronise past) and reorders each payload
    to row-major. Counters are in :attr:`stats` (dropped bytes, checksum errors, sequence gaps).

    >>> dec = SkinStreamDecoder()
    >>> wire = encode_skin_frame(9, np.full(144, 1000, dtype=np.uint16))
    >>> frames = dec.update(b'\\x00\\xa5garbage' + wire + wire[:100])
    >>> [(f.seq, int(f.raw[0])) for f in frames], dec.stats.dropped_bytes, dec.buffered
    ([(9, 1000)], 9, 100)
    """

    def __init__(self, max_buffer: int = 1 << 16) -> None:
        super().__init__({SENSOR_ID: PAYLOAD_SIZE}, max_buffer=max_buffer)

    def decode(self, frame: Frame) -> SkinScan:
        """The scan of one checked frame (the framing checked id and length), reordered to row-major."""
        return SkinScan(frame.seq, decode_payload(frame.payload))
