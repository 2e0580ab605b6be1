"""Robustness: diagnostics tell the truth (issue 12, build items 1 and 2), on a real pseudo-terminal.

Frames are written to a pty's master; the driver node reads the terminal side as its serial port.
"""

from __future__ import annotations

import pytest

from touch_driver.bear.protocol import encode_scan
from touch_lab.robustness.pty_run import (
    ERROR,
    RAW,
    WARN,
    FailingBearDriver,
    bad_bits_frame,
    level_of,
    run_bear,
    v1_frame,
)


def values(diagnostic) -> dict[str, str]:
    return {kv.key: kv.value for kv in diagnostic.values}


def test_frames_failing_their_payload_check_are_counted_and_turn_diagnostics_to_warn() -> None:
    wire = b''.join(bad_bits_frame(i) if i % 5 == 0 else encode_scan(i, RAW) for i in range(40))
    _node, statuses, diagnostics = run_bear(wire, error_error_fraction=0.5)
    first = statuses[0]
    assert (first.frames, first.decode_errors, first.checksum_errors) == (32, 8, 0)
    assert first.error_fraction == pytest.approx(0.2)
    assert level_of(diagnostics[0]) == WARN and '20.0 % of frames bad' in diagnostics[0].message
    assert values(diagnostics[0])['decode_errors'] == '8'
    assert set(values(diagnostics[0])) >= {'header_errors', 'version_errors', 'length_errors', 'checksum_errors',
                                           'sequence_gaps', 'frames_missed', 'handle_errors', 'subscriber_drops'}


def test_the_error_threshold_is_a_parameter() -> None:
    wire = b''.join(bad_bits_frame(i) if i % 5 == 0 else encode_scan(i, RAW) for i in range(40))
    _, _, diagnostics = run_bear(wire, error_error_fraction=0.1)
    assert level_of(diagnostics[0]) == ERROR


def test_only_bad_frames_is_error_not_healthy() -> None:
    _, statuses, diagnostics = run_bear(b''.join(bad_bits_frame(i) for i in range(40)))
    assert statuses[0].frames == 0 and statuses[0].decode_errors == 40
    assert level_of(diagnostics[0]) == ERROR and 'none is published' in diagnostics[0].message


def test_lost_frames_and_checksum_errors_are_reported() -> None:
    frames = [bytearray(encode_scan(i, RAW)) for i in range(100) if i % 10 != 3]   # 10 frames never sent
    frames[20][50] ^= 0x01                                                          # one corrupted on the way
    _, statuses, diagnostics = run_bear(b''.join(frames))
    status = statuses[-1]                     # counters since start
    assert (status.frames, status.checksum_errors, status.sequence_gaps) == (89, 1, 10)
    assert status.frames_missed == 10         # the 10 never sent; the corrupted one is a checksum error only
    assert {level_of(d) for d in diagnostics[:2]} == {WARN}   # ~12 % bad or lost while they came: above 1 %


def test_a_node_failing_at_run_time_reports_error_with_the_reason() -> None:
    _node, statuses, diagnostics = run_bear(b''.join(encode_scan(i, RAW) for i in range(20)),
                                           node_class=FailingBearDriver)
    assert statuses[0].frames == 0 and statuses[0].handle_errors == 20      # counted after publishing: none
    assert statuses[0].rate_hz == 0.0
    assert level_of(diagnostics[0]) == ERROR and 'calibration diverged' in diagnostics[0].message


def test_a_device_of_protocol_version_1_is_named() -> None:
    wire = b''.join(v1_frame(i) for i in range(10))
    _, statuses, diagnostics = run_bear(wire)
    assert statuses[0].version_errors == 10 and statuses[0].frames == 0
    assert level_of(diagnostics[0]) == ERROR and 'firmware' in diagnostics[0].message


def test_a_connected_port_sending_only_garbage_is_error_not_a_slow_sensor() -> None:
    import os
    _, statuses, diagnostics = run_bear(os.urandom(4096))
    assert statuses[0].frames == 0 and statuses[0].dropped_bytes > 3000
    assert level_of(diagnostics[0]) == ERROR and 'no frame in 1 s' in diagnostics[0].message
