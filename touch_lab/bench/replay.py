"""Recorded sensor bytes replayed into the runtime through pseudo-terminals, for timing the runtime alone.

:func:`record` reads a virtual sensor's byte stream on a stepped clock, as a serial capture would;
:class:`Replay` plays it into ``os.openpty`` terminals that the driver nodes open as serial ports, the
graph in simulated time. Only the graph's work is timed (``time.process_time``).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import struct
import termios
import time
import tty
from dataclasses import dataclass
from typing import Any

import serial

from touch_graph.paths import share_file
from touch_sim.virtual_port import forget_device

__all__ = ['SCENES', 'PtyPort', 'Recording', 'Replay', 'record', 'record_scene']

#: sensor -> (URL scheme, the scene file of simulated people it plays).
SCENES = {'bear': ('bearsim', 'bear_people.yaml'), 'patch': ('patchsim', 'patch_people.yaml'),
          'skin': ('skinsim', 'skin_people.yaml')}


@dataclass(frozen=True)
class Recording:
    """A sensor's bytes as they arrived: ``chunks[i]`` became readable at ``i * period`` seconds.

    Attributes:
        sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
        period: the device's frame period, s (one wire frame per chunk).
        chunks: the bytes of each period (one frame, no faults).
        source: the URL recorded.
    """

    sensor: str
    period: float
    chunks: tuple[bytes, ...]
    source: str

    @property
    def duration_s(self) -> float:
        return len(self.chunks) * self.period

    @property
    def size(self) -> int:
        return sum(len(c) for c in self.chunks)


def record(sensor: str, url: str, duration_s: float) -> Recording:
    """The bytes the virtual device behind ``url`` sends over ``duration_s`` seconds (synthetic)."""
    now = [0.0]
    port: Any = serial.serial_for_url(url, do_not_open=True)
    port.attach_clock(lambda: now[0])
    port.open()
    try:
        period = float(port.device.model.frame_period)
        chunks = []
        for i in range(round(duration_s / period)):
            now[0] = (i + 0.5) * period      # mid-period: frame i is due, frame i + 1 not (no rounding at the edge)
            chunks.append(port.read(port.in_waiting))
    finally:
        port.close()
    return Recording(sensor, period, tuple(chunks), url)


def record_scene(sensor: str, duration_s: float = 60.0, seed: int = 1) -> Recording:
    """:func:`record` of the sensor's people scene (the demo's), a fresh device of its own."""
    scheme, scene = SCENES[sensor]
    name = f'bench-record-{sensor}-{os.getpid()}'
    try:
        return record(sensor, f'{scheme}://{name}?scene={share_file("config", "scenes", scene)}&seed={seed}',
                      duration_s)
    finally:
        forget_device(name)


class PtyPort:
    """A pseudo-terminal in raw mode: a driver opens :attr:`path` as a serial port; :meth:`write` puts
    bytes on its wire, and waits until they are readable (the kernel hands them over a little later in wall
    time, which a graph in simulated time would outrun). Close it after the driver is done.
    """

    def __init__(self, timeout_s: float = 5.0) -> None:
        self.master, self._slave = os.openpty()
        tty.setraw(self._slave)          # binary-clean before the driver opens it (it sets raw mode too)
        self.path = os.ttyname(self._slave)
        self.timeout_s = timeout_s

    def readable(self) -> int:
        """Bytes waiting on the terminal side (``TIOCINQ``)."""
        return struct.unpack('i', fcntl.ioctl(self._slave, termios.TIOCINQ, b'\0\0\0\0'))[0]

    def write(self, data: bytes) -> None:
        """Write ``data`` and return once the terminal side can read all of it."""
        want = self.readable() + len(data)
        view = memoryview(data)
        while view:
            view = view[os.write(self.master, view):]
        deadline = time.monotonic() + self.timeout_s
        while self.readable() < want:
            if time.monotonic() > deadline:
                raise TimeoutError(f'{self.path}: {want - self.readable()} written bytes not readable after '
                                   f'{self.timeout_s} s')
            time.sleep(1e-5)

    def close(self) -> None:
        for fd in (self.master, self._slave):
            with contextlib.suppress(OSError):
                os.close(fd)
        self.master = self._slave = -1


class Replay:
    """Play recordings into pseudo-terminals while a harness runs, timing the graph's CPU.

    Args:
        harness: the graph (a :class:`~touch_sim.harness.Harness`, simulated time).
        feeds: ``(port, recording)`` pairs; each recording's chunk ``i`` is written at ``i * period``.

    Attributes:
        cpu_s: CPU seconds the graph spent in :meth:`run` (the writes are not counted).
    """

    def __init__(self, harness: Any, feeds: list[tuple[PtyPort, Recording]]) -> None:
        self.harness = harness
        self.events = sorted(((i * rec.period, k, port, chunk) for k, (port, rec) in enumerate(feeds)
                              for i, chunk in enumerate(rec.chunks)), key=lambda e: (e[0], e[1]))
        self.duration_s = max((rec.duration_s for _, rec in feeds), default=0.0)
        self.cpu_s = 0.0

    def run(self, drain_s: float = 0.5) -> float:
        """Run the graph up to each chunk's time and write the chunk, so that a read at that very time sees it
        (as a virtual device's frame is due at its time); then ``drain_s`` more. Returns :attr:`cpu_s`."""
        harness, clock = self.harness, time.process_time
        spin, origin = harness.executor.spin_until_time, harness.start_ns
        cpu = 0.0
        for t, _, port, chunk in self.events:
            start = clock()
            spin(origin + round(t * 1e9) - 1)
            cpu += clock() - start
            port.write(chunk)
        start = clock()
        harness.spin_until(self.duration_s + drain_s)
        self.cpu_s = cpu + clock() - start
        return self.cpu_s
