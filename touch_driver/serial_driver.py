"""A serial sensor driver in the manner of python-can's ``BusABC``.

:class:`SerialDriver` opens a port URL with ``serial.serial_for_url`` (real hardware such
as ``/dev/ttyACM0``, pyserial's ``loop://``, or one of our virtual devices such as
``skinsim://demo``) and hands the bytes to the sensor's stream decoder
(:class:`~touch_driver.framing.SensorStreamDecoder`: framing, checksum, payload decode), the
one object every path from bytes to a scan goes through. It has no graph code: the driver
nodes wrap it, and read it with :meth:`SerialDriver.read_frame`.

::

    with SerialDriver('skinsim://demo', SkinStreamDecoder()) as driver:
        frame = driver.read_frame(timeout=1.0)     # DecodedFrame[SkinScan] or None

Bad bytes never raise: they are counted in :attr:`stats` and the decoder's ``corrupt_frames``.
A port that fails (unplugged, removed) raises :class:`PortDisconnected` from ``read_frame``;
``open()`` again reconnects, and ``close()`` is safe to call twice.

URL schemes beyond pyserial's own (the virtual sensors ``bearsim://``, ``patchsim://``,
``skinsim://`` of the simulation package) are found through the ``social_touch.serial_url_handlers``
entry point group, ``scheme = package`` (the package holding ``protocol_<scheme>.py``): the driver
adds that package to ``serial.protocol_handler_packages`` when a port uses the scheme, so the
runtime imports no simulator until a URL asks for one, and says which package is missing when
it cannot be imported (:class:`PortURLError`).
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import time
import urllib.parse
from collections import deque
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any, Generic, NamedTuple

import serial

from touch_graph.errors import SocialTouchError

from .framing import DecoderStats, ScanT, SensorStreamDecoder

__all__ = ['URL_HANDLER_GROUP', 'DecodedFrame', 'DriverError', 'PortDisconnected', 'PortURLError', 'SerialDriver',
           'prepare_port_url', 'url_handler_packages']

#: Entry point group of pyserial URL handlers: ``scheme = package`` (pyproject.toml).
URL_HANDLER_GROUP = 'social_touch.serial_url_handlers'


class DriverError(SocialTouchError):
    """A port cannot be opened or read."""


class PortDisconnected(DriverError):
    """The port went away while open (cable pulled, device reset)."""


class PortURLError(DriverError, ValueError):
    """A port that can never open here: an unknown URL scheme, a handler package that cannot be imported,
    an option the device does not have, a baud rate no port takes. Not retried: fix the configuration."""


@functools.cache
def url_handler_packages() -> dict[str, str]:
    """``scheme -> package`` of the URL handlers installed through :data:`URL_HANDLER_GROUP`."""
    return {ep.name: ep.value for ep in entry_points(group=URL_HANDLER_GROUP)}


def prepare_port_url(port: str) -> None:
    """Make ``port`` openable by ``serial.serial_for_url`` when its scheme is one of the installed handlers.

    Device paths and pyserial's own URLs pass through untouched.

    Raises:
        PortURLError: the scheme's handler package (e.g. ``touch_sim.urlhandlers`` for
            ``bearsim://``) cannot be imported.
    """
    scheme = urllib.parse.urlsplit(port).scheme if '://' in port else ''
    package = url_handler_packages().get(scheme)
    if package is None:
        return
    try:
        importlib.import_module(package)
    except ImportError as err:
        top = package.split('.')[0]
        raise PortURLError(
            f"{port}: '{scheme}://' is a virtual device of the '{top}' package, which cannot be imported here "
            f'({err}). Install social_touch with its simulator (pip install social_touch), or point the '
            'driver at a real port (e.g. /dev/ttyACM0)') from err
    if package not in serial.protocol_handler_packages:
        serial.protocol_handler_packages.append(package)


class DecodedFrame(NamedTuple, Generic[ScanT]):
    """A sensor's decoded scan, the time it was read (``clock()`` seconds) and, once the driver node
    has stamped it, its header stamp (ns on the graph's clock; None before). Immutable; a named tuple
    rather than a frozen dataclass because two are made for every frame."""

    scan: ScanT
    received_s: float
    stamp_ns: int | None = None


class SerialDriver(Generic[ScanT]):
    """Read a sensor's scans from a serial port URL.

    Args:
        port: a pyserial URL or device path.
        decoder: the sensor's stream decoder (``BearDecoder()``, ``PatchDecoder()``,
            ``SkinStreamDecoder()``); its counters are the driver's (:attr:`stats`).
        baudrate: ignored by USB CDC devices and virtual ports, used by real UARTs.
        clock: seconds; virtual devices run on it (a graph's simulated clock), and read times use it.
        max_pending: decoded frames kept for ``read_frame``; older ones are dropped and counted.
    """

    def __init__(self, port: str, decoder: SensorStreamDecoder[ScanT], *, baudrate: int = 115200,
                 clock: Callable[[], float] | None = None, max_pending: int = 1024) -> None:
        if not isinstance(port, str) or not port:
            raise ValueError(f'port must be a device path or URL, got {port!r}')
        prepare_port_url(port)
        self.port = port
        self.baudrate = baudrate
        self.decoder = decoder
        self._clock = clock or time.monotonic
        self._clock_given = clock is not None
        self._serial: Any = None
        # Bounded: a reader that falls behind loses the oldest frames (counted), not memory.
        self._pending: deque[DecodedFrame[ScanT]] = deque(maxlen=max_pending)
        self.overflow_frames = 0
        self.opens = 0

    # ------------------------------------------------------------------ lifecycle
    @property
    def is_open(self) -> bool:
        return self._serial is not None and self._serial.is_open

    @property
    def stats(self) -> DecoderStats:
        """The decoder's framing counters (frames, dropped bytes, checksum errors, sequence gaps)."""
        return self.decoder.stats

    def open(self) -> None:
        """Open (or reopen) the port; raises :class:`DriverError` naming the port and the cause."""
        self.close()
        try:
            port = serial.serial_for_url(self.port, baudrate=self.baudrate, timeout=0, do_not_open=True)
            if hasattr(port, 'attach_clock') and self._clock_given:
                port.attach_clock(self._clock)  # a virtual device runs on our clock from its first byte
            port.open()
        except ValueError as err:
            # pyserial's unknown scheme or bad baud rate, a virtual device's bad option: retrying cannot help.
            raise PortURLError(f'{self.port} can never open: {err}') from err
        except (serial.SerialException, OSError) as err:
            raise DriverError(f'cannot open {self.port}: {err}. Is the sensor plugged in, and is the '
                              'URL right (e.g. /dev/ttyACM0, loop://, bearsim://, patchsim://, skinsim://)?') from err
        self._serial = port
        self.decoder.reset()  # bytes from before a reconnect belong to no frame
        self._pending.clear()
        self.opens += 1

    def close(self) -> None:
        port, self._serial = self._serial, None
        if port is not None:
            with contextlib.suppress(serial.SerialException, OSError):  # a port that vanished
                port.close()

    def __enter__(self) -> SerialDriver:
        self.open()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ------------------------------------------------------------------ reading
    def _read_available(self, timeout: float) -> bytes:
        port = self._serial
        if port is None:
            raise DriverError(f'{self.port} is not open; call open() first')
        try:
            if timeout > 0:
                port.timeout = timeout
                first = port.read(1)
                port.timeout = 0
                if not first:
                    return b''
                waiting = port.in_waiting
                return first + (port.read(waiting) if waiting else b'')
            waiting = port.in_waiting
            return port.read(waiting) if waiting else b''
        except (serial.SerialException, OSError) as err:
            self.close()
            raise PortDisconnected(f'{self.port} stopped answering: {err}') from err

    def read_frame(self, timeout: float | None = None) -> DecodedFrame[ScanT] | None:
        """The next frame, waiting up to ``timeout`` seconds (None: until one comes; 0: only what has
        arrived, as the driver node's poll timer asks); None on timeout."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while not self._pending:
            wait = 0.1 if deadline is None else deadline - time.monotonic()
            if wait <= 0:
                self._decode(self._read_available(0))
                break
            self._decode(self._read_available(min(wait, 0.1)))
        return self._pending.popleft() if self._pending else None

    @property
    def serial(self) -> Any:
        """The open pyserial port (None when closed), for a thread that blocks on its reads."""
        return self._serial

    def feed(self, data: bytes) -> None:
        """Decode ``data``, bytes read from the port by someone else (a reader thread); the frames wait
        for :meth:`read_frame`."""
        self._decode(data)

    def take_frames(self) -> list[DecodedFrame[ScanT]]:
        """The frames decoded and not read yet, oldest first (without reading the port)."""
        frames = list(self._pending)
        self._pending.clear()
        return frames

    def _decode(self, data: bytes) -> None:
        if not data:
            return
        now = self._clock()
        for scan in self.decoder.update(data):
            if len(self._pending) == self._pending.maxlen:
                self.overflow_frames += 1
            self._pending.append(DecodedFrame(scan, now))
