"""Skin wire protocol: geometry, scanning order on byte literals, stream decoding and fuzzing."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.framing import OVERHEAD, encode_frame
from touch_driver.skin.protocol import (
    MODULE_TAXELS,
    N_TAXELS,
    PAYLOAD_SIZE,
    ROW_MAJOR_FROM_WIRE,
    SENSOR_ID,
    TAXEL_XY_MM,
    WIRE_FROM_ROW_MAJOR,
    SkinStreamDecoder,
    decode_payload,
    encode_payload,
    encode_skin_frame,
    module_of_taxel,
)

FRAME_SIZE = PAYLOAD_SIZE + OVERHEAD


def test_module_geometry_matches_skinframe_msg():
    # Module m covers rows 2*(m//6)..+1 and cols 2*(m%6)..+1; taxels TL, TR, BL, BR.
    assert MODULE_TAXELS[0].tolist() == [0, 1, 12, 13]
    assert MODULE_TAXELS[5].tolist() == [10, 11, 22, 23]
    assert MODULE_TAXELS[6].tolist() == [24, 25, 36, 37]
    assert MODULE_TAXELS[35].tolist() == [130, 131, 142, 143]
    assert sorted(MODULE_TAXELS.ravel().tolist()) == list(range(N_TAXELS))
    for m in range(36):
        for t in range(4):
            assert module_of_taxel(int(MODULE_TAXELS[m, t])) == (m, t)
    with pytest.raises(ValueError, match=r'0\.\.143'):
        module_of_taxel(144)


def test_taxel_coordinates_in_mm():
    pitch = 47.0 / 12
    assert TAXEL_XY_MM[0] == pytest.approx([pitch / 2, pitch / 2])
    assert TAXEL_XY_MM[1] == pytest.approx([1.5 * pitch, pitch / 2])      # x along columns
    assert TAXEL_XY_MM[12] == pytest.approx([pitch / 2, 1.5 * pitch])     # y along rows
    assert TAXEL_XY_MM[143] == pytest.approx([47 - pitch / 2, 47 - pitch / 2])


def test_permutations_are_inverse():
    assert np.array_equal(WIRE_FROM_ROW_MAJOR[ROW_MAJOR_FROM_WIRE], np.arange(N_TAXELS))
    assert np.array_equal(ROW_MAJOR_FROM_WIRE[WIRE_FROM_ROW_MAJOR], np.arange(N_TAXELS))


def test_scanning_order_on_byte_literals():
    # Wire position 23 = step s=1, group g=2, taxel t=3: module 2*12+1 = 25 (rows 8-9, cols 2-3),
    # bottom-right taxel -> row 9, col 3 -> index 111. Bytes 46..47, little endian.
    payload = b'\x00' * 46 + b'\x34\x12' + b'\x00' * 240
    raw = decode_payload(payload)
    assert raw.dtype == np.uint16 and raw.shape == (144,)
    assert raw[111] == 0x1234 and np.count_nonzero(raw) == 1
    # The first 12 wire values: scan step 0 of groups 0, 1, 2 = modules 0, 12, 24.
    payload = bytes(range(1, 25)) + b'\x00' * 264
    raw = decode_payload(payload).reshape(12, 12)
    assert raw[0, 0] == 0x0201 and raw[0, 1] == 0x0403 and raw[1, 0] == 0x0605 and raw[1, 1] == 0x0807
    assert raw[4, 0] == 0x0A09 and raw[5, 1] == 0x100F          # module 12: rows 4-5, cols 0-1
    assert raw[8, 0] == 0x1211 and raw[9, 1] == 0x1817          # module 24: rows 8-9, cols 0-1


def test_whole_frame_byte_literal():
    raw = np.zeros(144, dtype=np.uint16)
    raw[111] = 0x1234
    wire = encode_skin_frame(0x0102, raw)
    assert len(wire) == FRAME_SIZE == 302
    assert wire[:8] == b'\xa5\x5a\x02\x53\x20\x01\x02\x01'   # sync, version 2, id 'S', length 288 LE, seq 0x0102 LE
    assert wire[10 + 46:10 + 48] == b'\x34\x12'
    assert wire[-4:] == b'\xe8\xec)o'                # CRC-32, LE
    frames = SkinStreamDecoder().update(wire)
    assert len(frames) == 1 and frames[0].seq == 0x0102 and np.array_equal(frames[0].raw, raw)


def test_decode_does_not_alias_the_bytes():
    payload = bytearray(PAYLOAD_SIZE)
    raw = decode_payload(payload)
    payload[0] = 7
    assert raw[0] == 0


def test_codec_rejects_bad_arguments():
    with pytest.raises(ValueError, match='288 bytes'):
        decode_payload(b'\x00' * 287)
    with pytest.raises(ValueError, match=r'shape \(144,\) or \(12, 12\)'):
        encode_payload(np.zeros(143, dtype=np.uint16))
    with pytest.raises(ValueError, match=r'0\.\.65535'):
        encode_payload(np.full(144, 70000))
    with pytest.raises(ValueError, match='integers'):
        encode_payload(np.full(144, 1.5))
    assert encode_payload(np.zeros((12, 12), dtype=np.int64)) == b'\x00' * 288


@settings(max_examples=60, deadline=None)
@given(st.lists(st.integers(0, 0xFFFF), min_size=144, max_size=144))
def test_roundtrip_any_counts(values):
    raw = np.array(values, dtype=np.uint16)
    assert np.array_equal(decode_payload(encode_payload(raw)), raw)


def _frame(seq: int) -> tuple[bytes, np.ndarray]:
    raw = ((np.arange(144) * 131 + seq * 7) % 65536).astype(np.uint16)
    return encode_skin_frame(seq, raw), raw


def test_decoder_counts_garbage_checksum_errors_and_gaps():
    dec = SkinStreamDecoder()
    f0, r0 = _frame(0)
    f1, _ = _frame(1)
    f2, r2 = _frame(2)
    bad = bytearray(f1)
    bad[100] ^= 0x40                                     # corrupt frame 1's payload
    frames = dec.update(b'\x11\x22\x33' + f0 + bytes(bad) + f2)
    assert [f.seq for f in frames] == [0, 2]
    assert np.array_equal(frames[0].raw, r0) and np.array_equal(frames[1].raw, r2)
    s = dec.stats
    assert s.checksum_errors == 1 and s.sequence_gaps == 0 and s.frames_missed == 0   # lost once: as corrupt
    assert s.dropped_bytes == 3 + len(bad)


def test_decoder_ignores_other_sensor_ids_and_lengths():
    dec = SkinStreamDecoder()
    other = encode_frame(0x42, 0, b'\x00' * 56)          # a bear frame on the wrong port
    short = encode_frame(SENSOR_ID, 1, b'\x00' * 10)     # skin id, wrong length
    f, _ = _frame(5)
    frames = dec.update(other + short + f)
    assert [x.seq for x in frames] == [5]
    assert dec.stats.length_errors >= 2 and dec.stats.dropped_bytes == len(other) + len(short)


def test_decoder_reset_forgets_partial_frame():
    dec = SkinStreamDecoder()
    f, _ = _frame(3)
    assert dec.update(f[:150]) == [] and dec.buffered == 150
    dec.reset()
    assert dec.buffered == 0 and dec.stats.dropped_bytes == 150
    assert [x.seq for x in dec.update(f)] == [3]


@settings(max_examples=80, deadline=None)
@given(st.binary(max_size=2000), st.integers(1, 400))
def test_fuzz_garbage_never_raises_and_bytes_are_accounted(data, chunk):
    dec = SkinStreamDecoder()
    frames = []
    for i in range(0, len(data), chunk):
        frames += dec.update(data[i:i + chunk])
    assert dec.stats.dropped_bytes + dec.buffered + len(frames) * FRAME_SIZE == len(data)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.binary(max_size=80), min_size=1, max_size=6), st.lists(st.integers(1, 700), min_size=1,
                                                                             max_size=8))
def test_fuzz_frames_between_garbage_are_all_recovered(garbage, chunks):
    wires = [_frame(i) for i in range(len(garbage))]
    stream = b''.join(g + w for g, (w, _) in zip(garbage, wires, strict=True))
    dec = SkinStreamDecoder()
    out, pos, k = [], 0, 0
    while pos < len(stream):                            # arbitrary read sizes, as a serial port gives
        size = chunks[k % len(chunks)]
        out += dec.update(stream[pos:pos + size])
        pos, k = pos + size, k + 1
    assert [f.seq for f in out] == list(range(len(garbage)))
    for f, (_, raw) in zip(out, wires, strict=True):
        assert np.array_equal(f.raw, raw)
    assert dec.stats.dropped_bytes == sum(len(g) for g in garbage)
