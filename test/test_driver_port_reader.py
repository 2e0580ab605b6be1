"""PortReader on a POSIX port (a pty), which it reads with select and os.read: every byte comes out in
order with a trigger per piece, a stop ends the blocked wait at once, and a port whose other end is
gone ends the thread with the error."""

from __future__ import annotations

import os
import time

import serial

from touch_driver.port_reader import READ_TIMEOUT_S, PortReader, _is_plain_posix
from touch_lab.bench.replay import PtyPort


class _Guard:
    def __init__(self) -> None:
        self.triggers = 0

    def trigger(self) -> None:
        self.triggers += 1


def _wait_for(predicate, timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not predicate() and time.monotonic() < deadline:
        time.sleep(0.005)
    return predicate()


def test_a_pty_is_read_in_one_piece_per_arrival_and_stops_at_once() -> None:
    pty = PtyPort()
    port = serial.serial_for_url(pty.path, timeout=0)
    guard = _Guard()
    reader = PortReader(port, guard, 'test reader')
    assert _is_plain_posix(port) and not _is_plain_posix(serial.serial_for_url('loop://'))
    reader.start()
    try:
        chunks = [bytes(range(256)) + bytes([k]) * 46 for k in range(3)]   # 302 bytes, a skin frame's size
        pieces: list[bytes] = []
        for k, chunk in enumerate(chunks):
            os.write(pty.master, chunk)
            want = len(chunk) * (k + 1)
            assert _wait_for(lambda want=want, pieces=pieces: sum(map(len, pieces + list(reader.received))) == want)
            pieces += reader.take()
        assert b''.join(pieces) == b''.join(chunks) and guard.triggers == len(pieces)
        started = time.monotonic()
        reader.stop()
        assert not reader.alive and time.monotonic() - started < READ_TIMEOUT_S   # cancel_read woke the wait
        assert reader.take() == []
    finally:
        reader.stop()
        port.close()
        pty.close()


def test_a_port_whose_device_went_away_ends_the_reader_with_the_error() -> None:
    pty = PtyPort()
    port = serial.serial_for_url(pty.path, timeout=0)
    guard = _Guard()
    reader = PortReader(port, guard, 'test reader')
    reader.start()
    try:
        os.close(pty.master)                 # the other end hangs up: the device is gone
        assert _wait_for(lambda: not reader.alive)
        taken = reader.take()
        assert len(taken) == 1 and isinstance(taken[0], (serial.SerialException, OSError)) and guard.triggers == 1
    finally:
        reader.stop()
        port.close()
