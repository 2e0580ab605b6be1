"""Fuzz the shared wire framing (touch_driver.framing.FrameDecoder) with random, truncated and corrupted streams."""

from __future__ import annotations

import itertools

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from touch_driver.framing import OVERHEAD, SYNC, Frame, FrameDecoder, crc16, encode_frame

SIZES = {0x01: 3, 0x02: 10}  # two ids with different payload lengths; small, so hypothesis stays fast
# Zero bytes after the last frame: a false header met earlier may claim more bytes than remain, and the
# decoder rightly waits for them; the flush lets it give up on that header and find the real frames.
FLUSH = bytes(max(SIZES.values()) + OVERHEAD)
FUZZ = settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def frame_len(frame: Frame) -> int:
    return len(frame.payload) + OVERHEAD


def check_accounting(dec: FrameDecoder, frames: list[Frame], fed: int) -> None:
    """Every byte fed is in exactly one place: a good frame, the dropped count or the buffer."""
    assert sum(frame_len(f) for f in frames) + dec.stats.dropped_bytes + dec.buffered == fed
    assert dec.stats.frames == len(frames)


frame_specs = st.lists(st.tuples(st.sampled_from(sorted(SIZES)), st.integers(0, 0xFFFF), st.randoms()),
                       min_size=0, max_size=8)


def make_frames(specs) -> list[tuple[int, int, bytes]]:
    return [(sid, seq, rnd.randbytes(SIZES[sid])) for sid, seq, rnd in specs]


# ---------------------------------------------------------------------- byte literals
def test_crc_check_value_and_known_frame() -> None:
    assert crc16(b'123456789') == 0x29B1
    wire = encode_frame(0x01, 0x0102, b'\x00\x01\x02')
    assert wire == bytes.fromhex('a55a 01 0300 0201 000102') + wire[-2:]
    assert int.from_bytes(wire[-2:], 'little') == crc16(wire[2:-2])


def test_resync_after_garbage_and_false_sync() -> None:
    good = encode_frame(0x01, 5, b'abc')
    # a false sync whose header claims an unknown id, then a stray half sync, then the frame
    stream = b'\x00\xff' + SYNC + b'\x07\x03\x00' + b'\xa5' + good
    dec = FrameDecoder(SIZES)
    frames = dec.update(stream)
    assert frames == [Frame(0x01, 5, b'abc')]
    assert dec.stats.length_errors >= 1
    check_accounting(dec, frames, len(stream))


def test_checksum_error_counted_and_next_frame_kept() -> None:
    bad = bytearray(encode_frame(0x01, 1, b'xyz'))
    bad[8] ^= 0x10
    good = encode_frame(0x01, 2, b'abc')
    dec = FrameDecoder(SIZES)
    frames = dec.update(bytes(bad) + good)
    assert [f.seq for f in frames] == [2]
    assert dec.stats.checksum_errors == 1
    check_accounting(dec, frames, len(bad) + len(good))


def test_sequence_gap_and_wrap() -> None:
    dec = FrameDecoder(SIZES)
    stream = b''.join(encode_frame(0x01, s, b'abc') for s in (65534, 65535, 0, 3))
    frames = dec.update(stream)
    assert [f.seq for f in frames] == [65534, 65535, 0, 3]
    assert (dec.stats.sequence_gaps, dec.stats.frames_missed) == (1, 2)


def test_truncated_frame_waits_then_completes() -> None:
    wire = encode_frame(0x02, 9, bytes(range(10)))
    dec = FrameDecoder(SIZES)
    assert dec.update(wire[:-1]) == []
    assert dec.buffered == len(wire) - 1
    assert dec.update(wire[-1:]) == [Frame(0x02, 9, bytes(range(10)))]


def test_buffer_is_bounded_on_an_endless_partial_frame() -> None:
    dec = FrameDecoder(SIZES, max_buffer=64)
    fed = 0
    for _ in range(100):  # a header that never completes, then sync-like noise
        chunk = SYNC + b'\x02\x0a\x00' + b'\xa5' * 50
        dec.update(chunk)
        fed += len(chunk)
        assert dec.buffered <= dec.max_buffer
    check_accounting(dec, [], fed)


# ---------------------------------------------------------------------- properties
@FUZZ
@given(st.binary(max_size=600))
def test_random_bytes_never_raise_and_account(data: bytes) -> None:
    dec = FrameDecoder(SIZES)
    frames = dec.update(data)
    check_accounting(dec, frames, len(data))


@FUZZ
@given(st.binary(max_size=300), st.lists(st.integers(1, 40), max_size=20))
def test_chunking_does_not_matter(data: bytes, cuts: list[int]) -> None:
    bulk = FrameDecoder(SIZES)
    bulk_frames = bulk.update(data)
    parts, pos = [], 0
    for cut in cuts:
        parts.append(data[pos:pos + cut])
        pos += cut
    parts.append(data[pos:])
    chunked = FrameDecoder(SIZES)
    chunked_frames = [f for part in parts for f in chunked.update(part)]
    assert chunked_frames == bulk_frames
    assert chunked.stats == bulk.stats
    assert chunked.buffered == bulk.buffered


@FUZZ
@given(frame_specs, st.lists(st.binary(max_size=40), min_size=9, max_size=9))
def test_byte_by_byte_equals_bulk_on_frames_with_garbage(specs, garbage: list[bytes]) -> None:
    frames = make_frames(specs)
    stream = b''.join(garbage[i] + encode_frame(*f) for i, f in enumerate(frames)) + garbage[-1] + FLUSH
    bulk = FrameDecoder(SIZES)
    bulk_frames = bulk.update(stream)
    single = FrameDecoder(SIZES)
    single_frames = [f for i in range(len(stream)) for f in single.update(stream[i:i + 1])]
    assert single_frames == bulk_frames
    assert single.stats == bulk.stats
    # Every real frame survives the garbage around it (a false frame needs a CRC collision).
    assert [(f.sensor_id, f.seq, f.payload) for f in bulk_frames] == frames
    check_accounting(bulk, bulk_frames, len(stream))


@FUZZ
@given(frame_specs, st.data())
def test_truncated_frames_lose_only_themselves(specs, data) -> None:
    frames = make_frames(specs)
    cut = [data.draw(st.booleans()) for _ in frames]
    wires = [encode_frame(*f) for f in frames]
    pieces = [w[:data.draw(st.integers(0, len(w) - 1))] if truncate else w
              for w, truncate in zip(wires, cut, strict=True)]
    stream = b''.join(pieces) + FLUSH
    # A frame cut just before its last CRC byte, when that byte is 0xA5 and the next byte on the wire is a
    # sync (0xA5), cannot be told from a whole frame: it arrives, and the frame whose sync it took is lost.
    owner = [k for k, piece in enumerate(pieces) for _ in piece]      # which frame each byte came from
    kept_index = {k for k, truncate in enumerate(cut) if not truncate}
    end = 0
    for k, (wire, piece) in enumerate(zip(wires, pieces, strict=True)):
        end += len(piece)
        if cut[k] and len(piece) == len(wire) - 1 and wire[-1] == SYNC[0] and stream[end:end + 1] == SYNC[:1]:
            kept_index.add(k)
            kept_index.discard(owner[end] if end < len(owner) else -1)
    kept = [f for k, f in enumerate(frames) if k in kept_index]
    dec = FrameDecoder(SIZES)
    got = dec.update(stream)
    assert [(f.sensor_id, f.seq, f.payload) for f in got] == kept
    check_accounting(dec, got, len(stream))


@FUZZ
@given(frame_specs, st.data())
def test_a_flipped_bit_loses_exactly_that_frame(specs, data) -> None:
    frames = make_frames(specs)
    wires = [bytearray(encode_frame(*f)) for f in frames]
    hit = [data.draw(st.booleans()) for _ in frames]
    for wire, flip in zip(wires, hit, strict=True):
        if flip:
            wire[data.draw(st.integers(0, len(wire) - 1))] ^= 1 << data.draw(st.integers(0, 7))
    stream = b''.join(wires) + FLUSH
    dec = FrameDecoder(SIZES)
    got = dec.update(stream)
    assert [(f.sensor_id, f.seq, f.payload) for f in got] == [f for f, h in zip(frames, hit, strict=True) if not h]
    check_accounting(dec, got, len(stream))
    if any(hit):
        assert dec.stats.dropped_bytes > 0


@FUZZ
@given(st.lists(st.booleans(), min_size=1, max_size=30), st.integers(0, 0xFFFF))
def test_sequence_gaps_count_lost_frames(kept: list[bool], first_seq: int) -> None:
    stream = b''.join(encode_frame(0x01, (first_seq + i) & 0xFFFF, b'abc') for i, k in enumerate(kept) if k)
    dec = FrameDecoder(SIZES)
    dec.update(stream)
    seen = [i for i, k in enumerate(kept) if k]
    missed = (seen[-1] - seen[0] + 1 - len(seen)) if seen else 0
    gaps = sum(1 for a, b in itertools.pairwise(seen) if b - a > 1)
    assert (dec.stats.frames_missed, dec.stats.sequence_gaps) == (missed, gaps)


def test_reset_counts_buffered_bytes_as_dropped() -> None:
    dec = FrameDecoder(SIZES)
    wire = encode_frame(0x02, 1, bytes(10))
    dec.update(wire[:8])
    dec.reset()
    assert dec.buffered == 0
    check_accounting(dec, [], 8)
    assert dec.update(wire) == [Frame(0x02, 1, bytes(10))]


def test_a_frame_ending_in_the_first_sync_byte_is_not_counted_as_dropped():
    # Regression: the trailing 0xA5 kept for a possible next sync was the CRC of the frame just
    # returned, which made dropped_bytes go negative (and broke the uint64 status field).
    from touch_driver.framing import FrameDecoder as Decoder
    from touch_driver.framing import encode_frame as encode
    decoder = Decoder({0x42: 4})
    for seq in range(300):
        wire = encode(0x42, seq, bytes([seq % 256, 1, 2, 3]))
        assert len(decoder.update(wire)) == 1
        assert decoder.stats.dropped_bytes == 0
    assert any(encode(0x42, s, bytes([s % 256, 1, 2, 3]))[-1] == 0xA5 for s in range(300))
