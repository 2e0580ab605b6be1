"""Helpers for tests of the virtual devices: a port opened on a clock the test moves by hand."""

from __future__ import annotations

import serial

import touch_sim  # noqa: F401  (registers the URL handlers)


class Clock:
    """Device time in seconds, set by the test (``clock.t = 1.5``)."""

    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def open_port(url: str) -> tuple[serial.SerialBase, Clock]:
    """Open a virtual-device URL on a fresh :class:`Clock` at 0 s."""
    port = serial.serial_for_url(url, do_not_open=True)
    clock = Clock()
    port.attach_clock(clock)
    port.open()
    return port, clock
