"""Fuzz the shared wire framing (touch_driver.framing.FrameDecoder) with random, truncated and corrupted streams."""

from __future__ import annotations

import itertools

from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from touch_driver.framing import HEADER_SIZE, OVERHEAD, SYNC, Frame, FrameDecoder, crc16, crc32, encode_frame

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
    """Frames of the specs, a sequence number an id already used bumped until it is new: a frame with the
    number of the id's last good one is a repeat, dropped by design (test_driver_sequence.py), and when
    the tests lose frames on purpose any earlier one may be the last good one."""
    used: dict[int, set[int]] = {}
    frames = []
    for sid, seq, rnd in specs:
        while seq in used.setdefault(sid, set()):
            seq = (seq + 1) & 0xFFFF
        used[sid].add(seq)
        frames.append((sid, seq, rnd.randbytes(SIZES[sid])))
    return frames


# ---------------------------------------------------------------------- byte literals
def test_crc_check_values_and_known_frame() -> None:
    assert crc16(b'123456789') == 0x29B1
    assert crc32(b'123456789') == 0xCBF43926          # CRC-32/ISO-HDLC check value
    wire = encode_frame(0x01, 0x0102, b'\x00\x01\x02')
    assert wire[:8] == bytes.fromhex('a55a 02 01 0300 0201')   # sync, version 2, id, length, seq
    assert int.from_bytes(wire[8:10], 'little') == crc16(wire[2:8])
    assert wire[10:13] == b'\x00\x01\x02'
    assert int.from_bytes(wire[-4:], 'little') == crc32(wire[2:-4])
    assert len(wire) == 3 + OVERHEAD == 17


def test_resync_after_garbage_and_false_sync() -> None:
    good = encode_frame(0x01, 5, b'abc')
    # a false sync whose header claims an unknown id, then a stray half sync, then the frame
    stream = b'\x00\xff' + SYNC + b'\x07\x03\x00\x00\x00\x00\x00' + b'\xa5' + good
    dec = FrameDecoder(SIZES)
    frames = dec.update(stream)
    assert frames == [Frame(0x01, 5, b'abc')]
    assert dec.stats.header_errors == 1
    check_accounting(dec, frames, len(stream))


def test_checksum_error_counted_and_next_frame_kept() -> None:
    bad = bytearray(encode_frame(0x01, 1, b'xyz'))
    bad[HEADER_SIZE + 1] ^= 0x10                      # a payload bit: the header still checks
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
    # A frame cut short whose missing tail happens to be the bytes that follow it on the wire (e.g. a last CRC
    # byte 0xA5 before the next sync, or 0x00 before the zero flush) cannot be told from a whole frame: it
    # arrives, and the frames whose bytes completed it are lost. The decoder goes on after those bytes, so a
    # piece that starts inside them (two frames cut to nothing before a whole twin) completes nothing.
    owner = [k for k, piece in enumerate(pieces) for _ in piece]      # which frame each byte came from
    kept_index = {k for k, truncate in enumerate(cut) if not truncate}
    end = consumed = 0
    for k, (wire, piece) in enumerate(zip(wires, pieces, strict=True)):
        start, end = end, end + len(piece)
        tail = wire[len(piece):]
        if cut[k] and start >= consumed and stream[end:end + len(tail)] == tail:
            kept_index.add(k)
            kept_index.difference_update(owner[end:end + len(tail)])
            consumed = end + len(tail)
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
    for seq in range(3000):
        wire = encode(0x42, seq, bytes([seq % 256, seq // 256, 2, 3]))
        assert len(decoder.update(wire)) == 1
        assert decoder.stats.dropped_bytes == 0
    assert any(encode(0x42, s, bytes([s % 256, s // 256, 2, 3]))[-1] == 0xA5 for s in range(3000))


# ---------------------------------------------------------------------- protocol version 2
def test_a_version_1_frame_is_counted_as_a_version_error_not_read() -> None:
    # Version 1: sync, id, length, seq, payload, CRC-16 over bytes 2.. (what old firmware sends).
    body = bytes([0x01]) + (3).to_bytes(2, 'little') + (9).to_bytes(2, 'little') + b'abc'
    v1 = SYNC + body + crc16(body).to_bytes(2, 'little')
    good = encode_frame(0x01, 10, b'abc')
    dec = FrameDecoder(SIZES)
    frames = dec.update(v1 + good)
    assert frames == [Frame(0x01, 10, b'abc')]
    assert dec.stats.version_errors == 1 and dec.stats.checksum_errors == 0
    check_accounting(dec, frames, len(v1) + len(good))


def test_a_checked_header_of_another_version_is_refused() -> None:
    wire = bytearray(encode_frame(0x01, 1, b'abc'))
    wire[2] = 3                                                 # version 3, header check recomputed
    wire[8:10] = crc16(wire[2:8]).to_bytes(2, 'little')
    dec = FrameDecoder(SIZES)
    assert dec.update(bytes(wire) + FLUSH) == []
    assert dec.stats.version_errors == 1


@FUZZ
@given(frame_specs, st.lists(st.tuples(st.sampled_from(sorted(SIZES)), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF),
                                       st.integers(0, 0xFFFF)), max_size=30), st.randoms())
def test_fake_headers_between_frames_neither_pass_nor_hide_a_frame(specs, fakes, rnd) -> None:
    """A flood of plausible headers (right sync, version, id and length; random seq and check) between real frames."""
    frames = make_frames(specs)
    units = [SYNC + bytes([2, sid]) + SIZES[sid].to_bytes(2, 'little') + seq.to_bytes(2, 'little')
             + check.to_bytes(2, 'little') for sid, seq, check, _ in fakes] + [encode_frame(*f) for f in frames]
    order = list(range(len(units)))
    rnd.shuffle(order)
    # real frames keep their order among themselves
    real_positions = sorted(k for k in order if k >= len(fakes))
    placed, real_iter = [], iter(real_positions)
    for k in order:
        placed.append(units[next(real_iter)] if k >= len(fakes) else units[k])
    stream = b''.join(placed) + FLUSH
    dec = FrameDecoder(SIZES)
    got = dec.update(stream)
    fake_checks = sum(crc16(u[2:8]) == int.from_bytes(u[8:10], 'little') for u in units[:len(fakes)])
    if fake_checks == 0:        # a fake whose random check is right (1 in 65,536) leaves only the CRC-32
        assert [(f.sensor_id, f.seq, f.payload) for f in got] == frames
    check_accounting(dec, got, len(stream))
