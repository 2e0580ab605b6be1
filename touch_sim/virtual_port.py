"""Virtual serial devices: a sensor simulator behind a pyserial URL.

``serial.serial_for_url('skinsim://demo')`` opens a virtual device that yields the bytes the
hardware would send, paced by a clock. A :class:`DeviceModel` (``touch_sim/<sensor>/device.py``)
turns a scene's stimulus into wire frames; this module is the pyserial plumbing the three share:

- **time**: the wall clock from the moment the port opens, or with ``SOCIAL_TOUCH_SIM_EPOCH=T``
  (Unix time, s) from ``T`` on, so devices in several processes play in step
  (:func:`set_wall_epoch` moves it, :func:`set_wall_end` ends what they play);
  ``port.attach_clock(fn)`` (``fn() -> seconds``) puts it on another clock, e.g. a graph's
  simulated clock.
- **faults**, as URL query options: ``garbage=P`` (probability per frame of a burst of random bytes
  before it), ``corrupt=P`` (of one flipped byte), ``drop=P`` (of losing it),
  ``unplug_at=S&replug_at=S`` (device seconds during which reads and ``open()`` fail), ``seed=N``.
- **bounded buffers**: a reader more than ``buffer_s`` (default 2 s) behind loses the oldest frames.

Device state lives in a registry keyed by the URL's host part, so a port reopened after an unplug
finds the same device, and a test can reach it: ``device_state('demo').unplug()``.
"""

from __future__ import annotations

import math
import os
import random
import threading
import time
import urllib.parse
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

from serial.serialutil import PortNotOpenError, SerialBase, SerialException

__all__ = ['EPOCH_ENV', 'DeviceModel', 'DeviceState', 'PortOptionError', 'VirtualSerial', 'device_state',
           'forget_device', 'forget_devices', 'parse_url', 'set_wall_end', 'set_wall_epoch']


class DeviceModel(Protocol):
    """What a sensor simulator provides to :class:`VirtualSerial`."""

    #: seconds between frames (1/150 for the skin)
    frame_period: float

    def frame_bytes(self, index: int, t: float) -> bytes:
        """The wire bytes of frame ``index``, sampled at device time ``t`` seconds."""

    def command(self, data: bytes) -> None:
        """Bytes the host wrote to the device (firmware commands); may ignore them."""


@dataclass
class DeviceState:
    """A virtual device that outlives the ports opened on it (for unplug/replug)."""

    name: str
    model: Any
    options: dict[str, float] = field(default_factory=dict)
    plugged: bool = True
    next_index: int = 0
    rng: random.Random = field(default_factory=random.Random)
    overrun_frames: int = 0
    #: the device's time zero, in the units of the clock it runs on (set by the first port)
    epoch: float | None = None
    epoch_clock: object = None
    #: the clock it runs on (None: the wall clock, ``time.monotonic``)
    clock: Callable[[], float] | None = None

    def unplug(self) -> None:
        """Pull the cable: reads fail and opens fail until :meth:`replug`."""
        self.plugged = False

    def replug(self) -> None:
        self.plugged = True

    def is_plugged(self, t: float) -> bool:
        if not self.plugged:
            return False
        start, end = self.options.get('unplug_at'), self.options.get('replug_at')
        if start is None or t < start:
            return True
        return end is not None and t >= end


_registry: dict[str, DeviceState] = {}
_registry_lock = threading.Lock()
#: The environment variable with the wall-clock devices' common time zero (a Unix time, s).
EPOCH_ENV = 'SOCIAL_TOUCH_SIM_EPOCH'
_FAULT_OPTIONS = ('garbage', 'corrupt', 'drop', 'unplug_at', 'replug_at', 'buffer_s', 'seed')


def device_state(name: str) -> DeviceState:
    """The registered virtual device ``name`` (KeyError if none was opened)."""
    return _registry[name]


def forget_device(name: str) -> None:
    """Drop the registered virtual device ``name``, if any (a run that made its own device)."""
    with _registry_lock:
        _registry.pop(name, None)


def forget_devices() -> None:
    """Drop every registered virtual device (tests call this between cases)."""
    with _registry_lock:
        _registry.clear()


class PortOptionError(SerialException, ValueError):
    """A virtual device URL that can never open (bad option, unknown scene): a SerialException for
    pyserial's callers, and a ValueError so a driver tells it from a device that is merely absent."""


def parse_url(url: str, scheme: str) -> tuple[str, dict[str, str]]:
    """``scheme://name?k=v&...`` -> ``(name, {k: v})``; the name defaults to ``'default'``.

    >>> parse_url('skinsim://demo?noise=2&seed=3', 'skinsim')
    ('demo', {'noise': '2', 'seed': '3'})
    """
    parts = urllib.parse.urlsplit(url)
    if parts.scheme != scheme:
        raise PortOptionError(f'expected a URL of the form {scheme}://NAME?option=value&...; got {url!r}')
    query = urllib.parse.parse_qs(parts.query, keep_blank_values=True)
    options = {}
    for key, values in query.items():
        if len(values) != 1:
            raise PortOptionError(f'option {key!r} given {len(values)} times in {url!r}')
        options[key] = values[0]
    name = (parts.netloc + parts.path).strip('/') or 'default'
    return name, options


class VirtualSerial(SerialBase):
    """pyserial port whose bytes come from a :class:`DeviceModel`.

    Subclasses (one per sensor, named ``Serial`` in ``touch_sim/urlhandlers/protocol_<scheme>.py``)
    set :attr:`scheme` and implement :meth:`make_model`.
    """

    scheme = ''

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        self._state: DeviceState | None = None
        self._clock: Callable[[], float] | None = None
        self._out = bytearray()
        self._fresh = True
        self._start_index = 0
        super().__init__(*args, **kwargs)

    # ---------------------------------------------------------------- sensor-specific
    def make_model(self, name: str, options: dict[str, str], seed: int = 0) -> Any:
        """Build the device model from the URL options (fault options removed) and the URL's
        ``seed``, which also seeds the fault injection; raise ValueError on bad options."""
        raise NotImplementedError

    # ---------------------------------------------------------------- pyserial API
    def open(self) -> None:
        if self.is_open:
            raise SerialException('Port is already open.')
        if self._port is None:
            raise SerialException('Port must be configured before it can be used.')
        name, options = parse_url(self.port, self.scheme)
        with _registry_lock:
            state = _registry.get(name)
            if state is None:
                faults = {k: _float_option(options, k) for k in _FAULT_OPTIONS if k in options}
                model_options = {k: v for k, v in options.items() if k not in _FAULT_OPTIONS}
                seed = faults.get('seed', 0)
                if seed != int(seed):
                    raise PortOptionError(f'option seed={options["seed"]!r} must be an integer')
                try:
                    model = self.make_model(name, model_options, seed=int(seed))
                except (ValueError, KeyError, OSError) as err:
                    raise PortOptionError(f'cannot open {self.port}: {err}') from err
                state = DeviceState(name, model, faults)
                state.rng.seed(int(faults.get('seed', 0)))
                _registry[name] = state
        self._state = state
        self._fresh = True
        self._use_epoch(self._clock)
        if not state.is_plugged(self._device_time()):
            raise SerialException(f'could not open port {self.port}: [Errno 2] No such file or directory')
        self._out.clear()
        self.is_open = True

    def close(self) -> None:
        self.is_open = False
        super().close()

    def _reconfigure_port(self) -> None:
        """Baud rate and framing mean nothing to a virtual device."""

    def attach_clock(self, clock: Callable[[], float]) -> None:
        """Run the device on ``clock`` (seconds). Device time 0 is the clock's value when the
        device was first opened on it: a port reopened after an unplug finds the device's time
        running on, not restarted."""
        self._clock = clock
        if self._state is not None:
            self._use_epoch(clock)

    def _use_epoch(self, clock: Callable[[], float] | None) -> None:
        state = self._state
        key = getattr(clock, '__self__', clock)  # bound methods of one object count as one clock
        if state.epoch is None or state.epoch_clock is not key:
            state.epoch = _epoch_on(clock)
            state.epoch_clock, state.clock = key, clock
        self._start_index = int(max(0.0, self._device_time()) / state.model.frame_period)

    def _device_time(self) -> float:
        now = self._clock() if self._clock is not None else time.monotonic()
        return now - self._state.epoch  # the device's, which set_wall_epoch may move

    def _pump(self) -> None:
        """Append the frames due by now to the output buffer."""
        state = self._state
        assert state is not None
        t = self._device_time()
        if not state.is_plugged(t):
            self.is_open = False
            raise SerialException('device reports readiness to read but returned no data '
                                  '(device disconnected or multiple access on port?)')
        if _wall_end is not None and (self._clock is None or _reads_unix_time(self._clock)):
            t = min(t, t - (time.time() - _wall_end))   # the stretch of the scene played ends there
        model = state.model
        period = model.frame_period
        due = math.floor(t / period) + 1  # frames 0..due-1 are due (none before device time 0)
        if self._fresh:
            # Nothing was sent to a closed or unplugged port: start from the frame due at opening.
            self._fresh = False
            state.next_index = max(state.next_index, self._start_index)
        backlog = int(state.options.get('buffer_s', 2.0) / period) + 1
        if due - state.next_index > backlog:
            state.overrun_frames += due - backlog - state.next_index
            state.next_index = due - backlog
        opts, rng = state.options, state.rng
        while state.next_index < due:
            index = state.next_index
            state.next_index += 1
            frame = model.frame_bytes(index, index * period)
            if opts.get('drop') and rng.random() < opts['drop']:
                continue
            if opts.get('corrupt') and rng.random() < opts['corrupt']:
                buf = bytearray(frame)
                buf[rng.randrange(len(buf))] ^= 1 << rng.randrange(8)
                frame = bytes(buf)
            if opts.get('garbage') and rng.random() < opts['garbage']:
                self._out += bytes(rng.randrange(256) for _ in range(rng.randrange(1, 64)))
            self._out += frame
            # A reader that leaves bytes unread overruns the buffer too: drop the oldest.
            excess = len(self._out) - backlog * len(frame)
            if excess > 0:
                del self._out[:excess]
                state.overrun_frames += 1

    @property
    def in_waiting(self) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        self._pump()
        return len(self._out)

    def read(self, size: int = 1) -> bytes:
        """Up to ``size`` bytes. On the wall clock, waits up to ``timeout`` for the next frame;
        on an attached clock it never waits (the clock, not this call, moves time)."""
        if not self.is_open:
            raise PortNotOpenError()
        self._pump()
        if not self._out and self._clock is None and self._timeout != 0:
            deadline = None if self._timeout is None else time.monotonic() + self._timeout
            while not self._out:
                period = self._state.model.frame_period
                wait = period - (self._device_time() % period) + 1e-4
                if deadline is not None:
                    wait = min(wait, deadline - time.monotonic())
                    if wait <= 0:
                        break
                time.sleep(wait)
                self._pump()
        data = bytes(self._out[:size])
        del self._out[:size]
        return data

    def write(self, data: bytes) -> int:
        if not self.is_open:
            raise PortNotOpenError()
        command = getattr(self._state.model, 'command', None)
        if command is not None:
            command(bytes(data))
        return len(data)

    def reset_input_buffer(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()
        self._out.clear()

    def reset_output_buffer(self) -> None:
        if not self.is_open:
            raise PortNotOpenError()

    @property
    def device(self) -> DeviceState:
        """The registered device behind this port (for tests and fault injection)."""
        if self._state is None:
            raise PortNotOpenError()
        return self._state


def set_wall_epoch(epoch: float) -> None:
    """Make Unix time ``epoch`` (s) the time zero of every wall-clock device of this process, those open
    now and those opened later: a scene's devices held back by a ``SOCIAL_TOUCH_SIM_EPOCH`` far ahead
    start together once every process of the scene is up."""
    os.environ[EPOCH_ENV] = repr(epoch)
    with _registry_lock:
        for state in _registry.values():
            if state.epoch_clock is None:
                state.epoch = _wall_epoch()
            elif _reads_unix_time(state.clock):
                state.epoch = _epoch_on(state.clock)


_wall_end: float | None = None


def set_wall_end(end: float | None) -> None:
    """From Unix time ``end`` (s) on, every wall-clock device of this process sends no more frames (its port
    stays open and plugged): processes that play a scene in step stop at one moment too, and whatever the
    graph does after it works on that stretch alone. None plays on."""
    global _wall_end
    _wall_end = end


#: How far an attached clock may read from ``time.time()`` and still count as the wall clock, s (a node's ROS
#: time without sim time reads the Unix time; a simulated clock starts at 0 or at a bag's time).
WALL_CLOCK_TOLERANCE_S = 1.0


def _reads_unix_time(clock: Callable[[], float] | None) -> bool:
    return clock is not None and abs(clock() - time.time()) < WALL_CLOCK_TOLERANCE_S


def _epoch_on(clock: Callable[[], float] | None) -> float:
    """Device time zero for a device opened now on ``clock`` (None: the wall clock), in that clock's seconds:
    ``$SOCIAL_TOUCH_SIM_EPOCH`` when set and the clock reads the Unix time, else now."""
    if clock is None:
        return _wall_epoch()
    now = clock()
    epoch = _env_epoch()
    if epoch is None or not _reads_unix_time(clock):
        return now
    return now - (time.time() - epoch)


def _wall_epoch() -> float:
    """Device time zero on the wall clock, in ``time.monotonic()`` seconds: now, or ``$SOCIAL_TOUCH_SIM_EPOCH``."""
    epoch = _env_epoch()
    return time.monotonic() if epoch is None else time.monotonic() - (time.time() - epoch)


def _env_epoch() -> float | None:
    """``$SOCIAL_TOUCH_SIM_EPOCH`` (a Unix time, s), None when unset; PortOptionError when it is not a time."""
    text = os.environ.get(EPOCH_ENV, '').strip()
    if not text:
        return None
    try:
        epoch = float(text)
    except ValueError:
        epoch = math.nan
    if not math.isfinite(epoch):
        raise PortOptionError(f'{EPOCH_ENV}={text!r} must be a Unix time in seconds (e.g. from time.time())')
    return epoch


def _float_option(options: dict[str, str], key: str) -> float:
    try:
        return float(options[key])
    except ValueError as err:
        raise PortOptionError(f'option {key}={options[key]!r} is not a number') from err
