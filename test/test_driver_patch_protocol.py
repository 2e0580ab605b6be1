"""Patch wire protocol: 10-bit packing on byte literals, both frame ids, the stream decoder on bad bytes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_driver.framing import OVERHEAD
from touch_driver.patch.protocol import (
    PATCH_FRAME_ID,
    PATCH_SCAN_ID,
    PAYLOAD_SIZE,
    PatchDecoder,
    PatchPayloadError,
    decode_payload,
    encode_payload,
    encode_scan,
)

cells_st = arrays(np.uint16, (16, 16), elements=st.integers(0, 1023))
panels_st = arrays(np.uint16, (11,), elements=st.integers(0, 0xFFFF))
ZERO_PANELS = np.zeros(11, dtype=np.uint16)


def test_packing_byte_literal() -> None:
    cells = np.zeros((16, 16), dtype=np.uint16)
    cells[0, 0], cells[0, 1], cells[0, 2], cells[0, 3] = 0x3FF, 0, 0x155, 0x001
    cells[15, 15] = 0x200  # last cell: bits 2550..2559 = the top 10 bits of byte 318..319
    panels = np.array([0x1234] + [0] * 9 + [0xFFFF], dtype=np.uint16)
    payload = encode_payload(cells, panels)
    assert len(payload) == PAYLOAD_SIZE == 342
    # 0x3FF | 0x000 << 10 | 0x155 << 20 | 0x001 << 30 = 0x00_5550_03FF (40 bits, little endian)
    assert payload[:5] == bytes([0xFF, 0x03, 0x50, 0x55, 0x00])
    assert payload[318:320] == b'\x00\x80'
    assert payload[320:322] == b'\x34\x12' and payload[-2:] == b'\xff\xff'
    got_cells, got_panels = decode_payload(payload)
    assert np.array_equal(got_cells, cells) and np.array_equal(got_panels, panels)


def test_row_major_cell_order() -> None:
    cells = np.zeros((16, 16), dtype=np.uint16)
    cells[1, 0] = 1  # cell 16: bits 160..169 = byte 20, bit 0
    payload = encode_payload(cells, ZERO_PANELS)
    assert payload[20] == 1 and sum(payload[:320]) == 1


@settings(max_examples=60, deadline=None)
@given(cells_st, panels_st)
def test_round_trip(cells: np.ndarray, panels: np.ndarray) -> None:
    got_cells, got_panels = decode_payload(encode_payload(cells, panels))
    assert got_cells.dtype == np.uint16 and got_cells.shape == (16, 16)
    assert np.array_equal(got_cells, cells) and np.array_equal(got_panels, panels)


@settings(max_examples=60, deadline=None)
@given(st.binary(min_size=PAYLOAD_SIZE, max_size=PAYLOAD_SIZE))
def test_any_payload_bytes_decode_and_re_encode(payload: bytes) -> None:
    cells, panels = decode_payload(payload)
    assert cells.max() <= 1023
    assert encode_payload(cells, panels) == payload  # the packing is a bijection


def test_payload_errors() -> None:
    with pytest.raises(PatchPayloadError, match='342 bytes'):
        decode_payload(bytes(341))
    with pytest.raises(ValueError, match=r'shape|cells'):
        encode_payload(np.zeros((16, 15), dtype=np.uint16), ZERO_PANELS)
    with pytest.raises(ValueError, match=r'0\.\.1023'):
        encode_payload(np.full((16, 16), 1024), ZERO_PANELS)
    with pytest.raises(ValueError, match='integers'):
        encode_payload(np.zeros((16, 16)), ZERO_PANELS)


def test_decoder_reads_both_frame_kinds_and_resyncs() -> None:
    cells = np.arange(256, dtype=np.uint16).reshape(16, 16)
    raw_frame = encode_scan(1, cells, ZERO_PANELS, raw_scan=True)
    avg_frame = encode_scan(1, cells, ZERO_PANELS + 7, raw_scan=False)
    assert raw_frame[3] == PATCH_SCAN_ID and avg_frame[3] == PATCH_FRAME_ID
    broken = bytearray(encode_scan(2, cells, ZERO_PANELS))
    broken[100] ^= 4
    stream = b'\x00garbage\xa5' + raw_frame + bytes(broken) + avg_frame + encode_scan(3, cells, ZERO_PANELS)
    dec = PatchDecoder()
    got = [s for i in range(0, len(stream), 50) for s in dec.update(stream[i:i + 50])]
    assert [(s.seq, s.raw_scan) for s in got] == [(1, True), (1, False), (3, True)]
    assert np.array_equal(got[1].cells, cells) and got[1].panels[0] == 7
    assert dec.stats.checksum_errors == 1
    # Raw scans 1 -> 3, ids counted apart: 2 arrived corrupt, a checksum error only (each loss counted once).
    assert dec.stats.sequence_gaps == 0 and dec.stats.frames_missed == 0
    frame_len = PAYLOAD_SIZE + OVERHEAD
    assert dec.stats.frames * frame_len + dec.stats.dropped_bytes + dec.buffered == len(stream)


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=3000))
def test_decoder_never_raises_on_random_bytes(data: bytes) -> None:
    dec = PatchDecoder()
    got = dec.update(data)
    assert dec.stats.frames == len(got)
    assert dec.stats.frames * (PAYLOAD_SIZE + OVERHEAD) + dec.stats.dropped_bytes + dec.buffered == len(data)
