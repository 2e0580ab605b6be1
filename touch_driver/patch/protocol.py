"""Textile patch wire protocol: the 16x16 pressure matrix and the 11 capacitive panels (docs/protocols.md).

Frames use the shared framing of :mod:`touch_driver.framing`. Two sensor ids carry the
same payload layout:

- 0x50 ('P'): a frame as the paper's firmware sends it, the moving average of the 100 Hz
  scans sub-sampled to 20 Hz (sympartner2018 6.1);
- 0x51 ('Q'): every raw 100 Hz scan, for firmware that streams all scans; the driver's
  calibration then does the averaging and the 5:1 sub-sampling.

Payload (342 bytes)::

    offset  size  field
    0       320   256 cells x 10 bits, packed little-endian, row-major (cell = row * 16 + col):
                  cell i occupies bits 10*i .. 10*i+9 of the payload read as one
                  little-endian integer, so every 4 cells fill 5 bytes
    320     22    11 panel signals x uint16 little endian (AT42QT1111 signal counts, sympartner2018 4)

Any bit pattern decodes (10-bit fields cannot overflow), so a checked frame is never corrupt.

>>> cells = np.zeros((16, 16), dtype=np.uint16); cells[0, :4] = [1, 2, 3, 1023]
>>> payload = encode_payload(cells, np.arange(11, dtype=np.uint16))
>>> len(payload), payload[:5].hex(' ')
(342, '01 08 30 c0 ff')
>>> got_cells, got_panels = decode_payload(payload)
>>> got_cells[0, :4].tolist(), got_panels[:3].tolist()
([1, 2, 3, 1023], [0, 1, 2])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from touch_driver.framing import Frame, SensorStreamDecoder, encode_frame
from touch_graph.errors import MessageError

__all__ = ['ADC_MAX', 'GRID', 'N_PANELS', 'PATCH_FRAME_ID', 'PATCH_SCAN_ID', 'PAYLOAD_SIZE', 'PatchDecoder',
           'PatchPayloadError', 'PatchScan', 'decode_payload', 'encode_payload', 'encode_scan']

#: Sensor id of a 20 Hz averaged frame ('P').
PATCH_FRAME_ID = 0x50
#: Sensor id of a raw 100 Hz scan ('Q').
PATCH_SCAN_ID = 0x51
#: Rows and columns of the matrix (two 16-way multiplexers, sympartner2018 5.2).
GRID = (16, 16)
N_CELLS = GRID[0] * GRID[1]
#: Capacitive panels on the shell (sympartner2018 4).
N_PANELS = 11
#: Full scale of the 10-bit converter (sympartner2018 6.1).
ADC_MAX = 1023
_CELL_BYTES = N_CELLS * 10 // 8  # 320
PAYLOAD_SIZE = _CELL_BYTES + 2 * N_PANELS  # 342
_SHIFTS = np.array([0, 10, 20, 30], dtype=np.uint64)
_MASK = np.uint64(0x3FF)


class PatchPayloadError(MessageError, ValueError):
    """A patch payload of the wrong length."""


@dataclass(frozen=True, slots=True)
class PatchScan:
    """One decoded frame.

    Attributes:
        seq: frame sequence counter, 0..65535 (wraps; separate per sensor id).
        raw_scan: True for a raw 100 Hz scan (0x51), False for a 20 Hz averaged frame (0x50).
        cells: (16, 16) uint16 ADC counts 0..1023, row-major.
        panels: (11,) uint16 panel signal counts.
    """

    seq: int
    raw_scan: bool
    cells: np.ndarray
    panels: np.ndarray


def encode_payload(cells: np.ndarray, panels: np.ndarray) -> bytes:
    """(16, 16) counts 0..1023 and (11,) counts 0..65535 -> the 342-byte payload.

    Raises:
        ValueError: on a wrong shape, a non-integer dtype or a value out of range.
    """
    cells, panels = np.asarray(cells), np.asarray(panels)
    if cells.shape != GRID or panels.shape != (N_PANELS,):
        raise ValueError(f'a patch frame is cells {GRID} and panels ({N_PANELS},); '
                         f'got {cells.shape} and {panels.shape}')
    for name, values, top in (('cells', cells, ADC_MAX), ('panels', panels, 0xFFFF)):
        if values.dtype.kind not in 'iu' or values.min() < 0 or values.max() > top:
            raise ValueError(f'{name} must be integers 0..{top}; got dtype {values.dtype}, '
                             f'range {values.min()}..{values.max()}')
    groups = cells.reshape(-1, 4).astype(np.uint64)
    packed = (groups << _SHIFTS).sum(axis=1, dtype=np.uint64)  # fields do not overlap: sum == or
    packed_bytes = packed.astype('<u8').view(np.uint8).reshape(-1, 8)[:, :5]
    return packed_bytes.tobytes() + panels.astype('<u2').tobytes()


def decode_payload(payload: bytes | bytearray | memoryview) -> tuple[np.ndarray, np.ndarray]:
    """342 payload bytes -> ((16, 16) uint16 cells, (11,) uint16 panels), new arrays.

    Raises:
        PatchPayloadError: on a length other than 342.
    """
    if len(payload) != PAYLOAD_SIZE:
        raise PatchPayloadError(f'a patch payload is {PAYLOAD_SIZE} bytes (320 packed cells + 11 x uint16); '
                                f'got {len(payload)}')
    wide = np.zeros((N_CELLS // 4, 8), dtype=np.uint8)
    wide[:, :5] = np.frombuffer(payload, dtype=np.uint8, count=_CELL_BYTES).reshape(-1, 5)
    packed = wide.view('<u8')  # (64, 1)
    cells = ((packed >> _SHIFTS) & _MASK).astype(np.uint16).reshape(GRID)
    panels = np.frombuffer(payload, dtype='<u2', offset=_CELL_BYTES).astype(np.uint16)
    return cells, panels


def encode_scan(seq: int, cells: np.ndarray, panels: np.ndarray, raw_scan: bool = True) -> bytes:
    """A whole wire frame: id 0x51 for a raw scan, 0x50 for an averaged 20 Hz frame."""
    return encode_frame(PATCH_SCAN_ID if raw_scan else PATCH_FRAME_ID, seq, encode_payload(cells, panels))


class PatchDecoder(SensorStreamDecoder[PatchScan]):
    """Bytes from the patch's port -> :class:`PatchScan` objects; never raises on bad bytes.

    Accepts both frame kinds (0x50 averaged, 0x51 raw scans); resynchronisation, checksum
    and sequence-gap counting are those of :class:`~touch_driver.framing.FrameDecoder`.
    """

    def __init__(self, max_buffer: int = 1 << 16) -> None:
        super().__init__({PATCH_FRAME_ID: PAYLOAD_SIZE, PATCH_SCAN_ID: PAYLOAD_SIZE}, max_buffer=max_buffer)

    def decode(self, frame: Frame) -> PatchScan:
        """The scan of one checked frame (every bit pattern decodes; the framing checked the length)."""
        cells, panels = decode_payload(frame.payload)
        return PatchScan(frame.seq, frame.sensor_id == PATCH_SCAN_ID, cells, panels)
