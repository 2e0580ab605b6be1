"""Bear wire protocol: payload encoding on byte literals, the stream decoder on bad bytes."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_driver.bear.protocol import (
    BEAR_ID,
    PAYLOAD_SIZE,
    BearDecoder,
    BearPayloadError,
    decode_payload,
    encode_payload,
    encode_scan,
)
from touch_driver.framing import OVERHEAD, encode_frame
from touch_graph.errors import MessageError

counts = arrays(np.uint16, (64,), elements=st.integers(0, 1023))


def test_payload_byte_literal() -> None:
    raw = np.zeros(64, dtype=np.uint16)
    raw[0], raw[1], raw[8], raw[63] = 1, 0x3FF, 0x102, 513
    payload = encode_payload(raw)
    assert len(payload) == PAYLOAD_SIZE == 128
    assert payload[:4] == b'\x01\x00\xff\x03'        # channel 0 = 1, channel 1 = 1023, little endian
    assert payload[16:18] == b'\x02\x01'              # channel 8 = midplane 1 input 0 = 0x102
    assert payload[-2:] == b'\x01\x02'                # channel 63 = 513
    assert decode_payload(payload).tolist() == raw.tolist()


def test_whole_frame_literal() -> None:
    wire = encode_scan(0x1234, np.zeros(64, dtype=np.uint16))
    assert wire[:8] == bytes.fromhex('a55a 02 42 8000 3412')   # sync, version 2, id, length, seq
    assert len(wire) == PAYLOAD_SIZE + OVERHEAD


@settings(max_examples=50, deadline=None)
@given(counts)
def test_round_trip(raw: np.ndarray) -> None:
    decoded = decode_payload(encode_payload(raw))
    assert decoded.dtype == np.uint16 and np.array_equal(decoded, raw)


def test_payload_errors() -> None:
    with pytest.raises(BearPayloadError, match='128 bytes'):
        decode_payload(b'\x00' * 127)
    high = bytearray(128)
    high[7] = 0x04  # channel 3 = 0x0400 = 1024: bit 10 set
    with pytest.raises(BearPayloadError, match='channel 3 carries 1024') as err:
        decode_payload(bytes(high))
    assert isinstance(err.value, MessageError) and isinstance(err.value, ValueError)
    with pytest.raises(ValueError, match='shape'):
        encode_payload(np.zeros(63, dtype=np.uint16))
    with pytest.raises(ValueError, match=r'0\.\.1023'):
        encode_payload(np.full(64, 1024))
    with pytest.raises(ValueError, match='integers'):
        encode_payload(np.zeros(64, dtype=np.float32))


def test_decoder_counts_corrupt_frames_with_high_bits() -> None:
    bad = bytearray(128)
    bad[1] = 0x80  # bit 15 of channel 0
    good = np.arange(64, dtype=np.uint16)
    stream = encode_frame(BEAR_ID, 1, bytes(bad)) + encode_scan(2, good)
    dec = BearDecoder()
    scans = dec.update(stream)
    assert [s.seq for s in scans] == [2] and np.array_equal(scans[0].raw, good)
    assert dec.corrupt_frames == 1 and dec.stats.frames == 2


def test_decoder_resyncs_and_counts() -> None:
    raws = [np.full(64, i * 10, dtype=np.uint16) for i in range(4)]
    frames = [encode_scan(i, r) for i, r in enumerate(raws)]
    broken = bytearray(frames[1])
    broken[50] ^= 0xFF
    stream = b'\xa5\x5a\x42garbage' + frames[0] + bytes(broken) + b'\x00\x01' + frames[3]
    dec = BearDecoder()
    scans = []
    for i in range(0, len(stream), 7):  # odd chunk sizes, as a serial port delivers them
        scans += dec.update(stream[i:i + 7])
    assert [s.seq for s in scans] == [0, 3]
    # 1 arrived corrupt (a checksum error only), 2 never came (the gap): each loss counted once.
    assert dec.stats.checksum_errors == 1 and dec.stats.sequence_gaps == 1 and dec.stats.frames_missed == 1
    assert dec.stats.dropped_bytes == len(stream) - 2 * len(frames[0])
    dec.reset()
    assert dec.buffered == 0


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=2000))
def test_decoder_never_raises_on_random_bytes(data: bytes) -> None:
    dec = BearDecoder()
    scans = dec.update(data)
    assert all(s.raw.shape == (64,) and s.raw.max() <= 1023 for s in scans)
    assert dec.stats.frames * (PAYLOAD_SIZE + OVERHEAD) + dec.stats.dropped_bytes + dec.buffered == len(data)
