"""A frame is data once: repeats, sequence resets and gaps told apart, each loss counted once (issue 25).

The wire literals are version-2 frames of sensor id 0x53 with the 2-byte payload b'hi'
(docs/protocols.md section 1); the number after ``F`` is the frame's sequence counter.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.framing import FrameDecoder, encode_frame

F7 = bytes.fromhex('a5 5a 02 53 02 00 07 00 4f 0a 68 69 d3 07 2a a4')
F8 = bytes.fromhex('a5 5a 02 53 02 00 08 00 71 1a 68 69 e4 99 ae 59')
F9 = bytes.fromhex('a5 5a 02 53 02 00 09 00 40 29 68 69 4c 8e 48 fc')
F10 = bytes.fromhex('a5 5a 02 53 02 00 0a 00 13 7c 68 69 f5 b0 13 c9')
F0 = bytes.fromhex('a5 5a 02 53 02 00 00 00 d8 93 68 69 09 6d 7a 6b')
F1 = bytes.fromhex('a5 5a 02 53 02 00 01 00 e9 a0 68 69 a1 7a 9c ce')
F500 = bytes.fromhex('a5 5a 02 53 02 00 f4 01 fc 5c 68 69 a2 f6 ba 6d')


def corrupt(frame: bytes) -> bytes:
    """``frame`` with one payload bit flipped: the header still checks, the CRC-32 fails."""
    bad = bytearray(frame)
    bad[10] ^= 0x01
    return bytes(bad)


def decode(wire: bytes) -> tuple[list[int], FrameDecoder]:
    dec = FrameDecoder({0x53: 2})
    frames = dec.update(wire)
    assert sum(len(encode_frame(f.sensor_id, f.seq, f.payload)) for f in frames) + dec.stats.dropped_bytes \
        + dec.buffered == len(wire)                # every byte accounted once
    return [f.seq for f in frames], dec


def test_the_literals_are_what_the_encoder_sends() -> None:
    assert [encode_frame(0x53, s, b'hi') for s in (7, 8, 9, 10, 0, 1, 500)] == [F7, F8, F9, F10, F0, F1, F500]


def test_a_replayed_frame_is_returned_once_and_counted() -> None:
    seqs, dec = decode(F7 * 733)
    assert seqs == [7]
    assert (dec.stats.repeated_frames, dec.stats.frames_missed, dec.stats.sequence_gaps) == (732, 0, 0)
    assert dec.stats.dropped_bytes == 732 * len(F7)


def test_a_repeat_between_new_frames_is_dropped() -> None:
    seqs, dec = decode(F7 + F8 + F8 + F9)
    assert seqs == [7, 8, 9]
    assert (dec.stats.repeated_frames, dec.stats.sequence_resets, dec.stats.frames_missed) == (1, 0, 0)


@pytest.mark.parametrize(('wire', 'seqs'), [
    (F7 + F8 + F9 + F0 + F1, [7, 8, 9, 0, 1]),      # rebooted: restarted at its start value
    (F500 + F7 + F8, [500, 7, 8]),                  # the counter jumped back
])
def test_a_reset_is_counted_once_and_nothing_is_lost(wire: bytes, seqs: list[int]) -> None:
    got, dec = decode(wire)
    assert got == seqs
    assert (dec.stats.sequence_resets, dec.stats.frames_missed, dec.stats.sequence_gaps) == (1, 0, 0)


def test_a_corrupt_frame_is_a_checksum_error_not_also_a_gap() -> None:
    seqs, dec = decode(F7 + corrupt(F8) + F9 + F10)
    assert seqs == [7, 9, 10]
    assert (dec.stats.checksum_errors, dec.stats.frames_missed, dec.stats.sequence_gaps) == (1, 0, 0)


def test_a_frame_never_sent_is_a_gap() -> None:
    seqs, dec = decode(F7 + corrupt(F8) + F10)            # 8 arrived corrupt, 9 never came
    assert seqs == [7, 10]
    assert (dec.stats.checksum_errors, dec.stats.frames_missed, dec.stats.sequence_gaps) == (1, 1, 1)


def test_a_frame_whose_header_is_corrupt_is_a_gap_once() -> None:
    bad = bytearray(F8)
    bad[6] ^= 0x01                                         # the sequence counter: the header check fails
    seqs, dec = decode(F7 + bytes(bad) + F9)
    assert seqs == [7, 9]
    assert (dec.stats.header_errors, dec.stats.checksum_errors, dec.stats.frames_missed) == (1, 0, 1)


def test_a_gap_across_the_wrap_onto_the_start_value_is_a_gap() -> None:
    wire = b''.join(encode_frame(0x53, s, b'hi') for s in (65533, 0))
    seqs, dec = decode(wire)
    assert seqs == [65533, 0]
    assert (dec.stats.sequence_resets, dec.stats.frames_missed) == (0, 2)


def test_reset_forgets_the_last_sequence_number() -> None:
    dec = FrameDecoder({0x53: 2})
    assert [f.seq for f in dec.update(F7)] == [7]
    dec.reset()                                           # a reconnect: the same frame again is new data
    assert [f.seq for f in dec.update(F7)] == [7]
    assert dec.stats.repeated_frames == 0


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 0xFFFF), st.booleans()), max_size=40))
def test_any_mix_returns_each_new_frame_once_and_counts_each_corrupt_one_once(specs) -> None:
    wire = b''.join(corrupt(encode_frame(0x53, s, b'hi')) if bad else encode_frame(0x53, s, b'hi') for s, bad in specs)
    seqs, dec = decode(wire)
    good = [s for s, bad in specs if not bad]
    assert seqs == [s for i, s in enumerate(good) if i == 0 or s != good[i - 1]]
    assert dec.stats.repeated_frames == len(good) - len(seqs)
    assert dec.stats.checksum_errors == len(specs) - len(good)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.booleans(), min_size=1, max_size=60), st.integers(0, 0xFFFF))
def test_corruption_is_never_also_a_gap(hit: list[bool], first: int) -> None:
    hit[-1] = False                                        # a last whole frame closes the count
    wire = b''.join(corrupt(f) if h else f for f, h in
                    zip((encode_frame(0x53, (first + i) & 0xFFFF, b'hi') for i in range(len(hit))), hit, strict=True))
    seqs, dec = decode(wire)
    assert len(seqs) == hit.count(False)
    assert (dec.stats.checksum_errors, dec.stats.frames_missed, dec.stats.sequence_gaps) == (sum(hit), 0, 0)
