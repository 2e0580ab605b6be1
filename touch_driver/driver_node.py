"""The part every sensor driver node shares: port, polling, reconnects, diagnostics.

A sensor's node subclasses :class:`SerialDriverNode`, gives the sensor's stream decoder
(:meth:`SerialDriverNode.make_decoder`) and turns each decoded scan into its calibrated message
in :meth:`SerialDriverNode.handle_frame`. This base

- reads the port when bytes arrive, on the wall clock with a real port (a device path, a pty, a
  ``socket://`` or ``rfc2217://`` URL): a thread blocks on the port's reads
  (:class:`~touch_driver.port_reader.PortReader`) and triggers a guard condition, and the executor
  decodes and publishes in its own thread, so no timer wakes the process for nothing. On a
  simulated clock (``get_clock().ros_time_is_active``), on a virtual device (``skinsim://`` ...,
  ``loop://``) or with ``read_on_arrival:=false`` it polls the port from a timer at
  ``poll_rate_hz`` (twice the sensor rate by default) with
  :meth:`~touch_driver.serial_driver.SerialDriver.read_frame`, so a frame is published at most
  half a period after it arrives, on the graph's clock (a virtual device on a simulated clock
  then runs as fast as the graph, and a scene gives the same frames on every run);
- stamps every frame of a read with its own time (:func:`frame_stamps_ns`): the last one read
  now, the ones before it a nominal period (``1 / expected_rate_hz``) apart, never at or before
  the previous frame's stamp. A poll that finds several frames (a late timer, a USB burst) thus
  still gives each its own increasing stamp, which rate and dwell estimates downstream rely on;
- checks every parameter at start against its range (``ParameterError`` naming the range and,
  for a value from a file, the file and line) and refuses a port that can never open (unknown
  URL scheme, an option the device lacks, a virtual device of another sensor, a bad baud rate):
  such a node does not start;
- survives an unplugged port: it logs once, reports ``connected: false``, and tries to
  reopen every ``reconnect_period_s`` until the device is back;
- counts a frame once its message is published; a frame whose handling raises is counted in
  ``handle_errors`` and its reason reported, never silently;
- publishes a ``DriverStatus`` on ``~/status`` and a ``diagnostic_msgs/DiagnosticArray`` on
  ``/diagnostics`` every ``status_period_s`` (frames published, every kind of bad or lost
  frame, reconnects, rate), the latter for rqt_robot_monitor and aggregators. The level is
  ERROR when disconnected, when frames arrive but none is published, or when no frame came in a
  period that should hold two or more; WARN or ERROR when the
  share of bad or lost frames in the period passes ``warn_error_fraction`` /
  ``error_error_fraction``, WARN when the rate falls below ``min_rate_fraction`` of the expected
  or passes ``max_rate_factor`` times it (a device that is not the one configured, or a flood);
- publishes each frame once: a frame resent with the last one's sequence number is counted
  (``repeated_frames`` on /diagnostics, WARN in that period) and dropped; a sequence counter that
  jumps back or restarts (a sensor that rebooted) is logged and reported at WARN once, in the
  period it happened (``sequence_resets``), and counting goes on from the new number. A frame lost
  is counted once, under its cause: a corrupt one is a checksum error, not also a sequence gap.

Parameters set while it runs (``ros2 param set``, ``social-touch param set``): those in
:attr:`SerialDriverNode.LIVE_PARAMETERS` take effect at once; every other one is read when
the driver starts (the port, the timers, the calibration), so a change is refused with that
reason instead of being accepted and ignored.
"""

from __future__ import annotations

from typing import Any, Generic

from touch_graph.compat import (
    FloatingPointRange,
    IntegerRange,
    Node,
    ParameterDescriptor,
    SetParametersResult,
    get_message,
)
from touch_graph.errors import ParameterError
from touch_graph.subscriber_drops import dropped_by_topic

from .framing import ScanT, SensorStreamDecoder
from .port_reader import PortReader
from .serial_driver import DecodedFrame, DriverError, PortURLError, SerialDriver, url_handler_packages

__all__ = ['SerialDriverNode', 'frame_stamps_ns', 'ranged']

DriverStatus = get_message('social_touch_msgs/msg/DriverStatus')
DiagnosticArray = get_message('diagnostic_msgs/msg/DiagnosticArray')
DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')
KeyValue = get_message('diagnostic_msgs/msg/KeyValue')
Header = get_message('std_msgs/msg/Header')
TimeMsg = get_message('builtin_interfaces/msg/Time')
_NS_PER_S = 1_000_000_000

_OK, _WARN, _ERROR = 0, 1, 2
#: Bad or lost frames counted in a status period's error fraction (DriverStatus fields).
_BAD_FRAME_COUNTERS = ('frames_missed', 'checksum_errors', 'decode_errors', 'length_errors', 'handle_errors')
_DIAGNOSTIC_KEYS = ('frames', 'dropped_bytes', 'header_errors', 'version_errors', 'length_errors', 'checksum_errors',
                    'decode_errors', 'sequence_gaps', 'frames_missed', 'handle_errors', 'subscriber_drops',
                    'repeated_frames', 'sequence_resets', 'reconnects', 'error_fraction', 'rate_hz')
#: Counters of frames that are not new data (resent, or a counter that restarted): WARN in their period.
_SEQUENCE_COUNTERS = ('repeated_frames', 'sequence_resets')


def frame_stamps_ns(count: int, now_ns: int, period_ns: int, last_ns: int | None) -> list[int]:
    """Stamps (ns) for ``count`` frames read together at ``now_ns``, oldest first.

    The last frame is stamped ``now_ns`` and each earlier one ``period_ns`` before the next (they
    arrived at the sensor's rate; the read found them together), but no stamp is at or before
    ``last_ns``, the previous frame's (a burst denser than the nominal rate is squeezed into the time
    since it). No stamp is after ``now_ns`` either, which wins over ``last_ns`` when the clock went
    back (a simulated clock restarted): stamps follow the clock, as the header's did before. None is
    negative (a simulated clock starts at zero).

    >>> frame_stamps_ns(3, 1_000, 100, None)
    [800, 900, 1000]
    >>> frame_stamps_ns(3, 1_000, 100, 850)
    [851, 900, 1000]
    >>> frame_stamps_ns(2, 1_000, 100, 5_000)     # the clock went back
    [999, 1000]
    """
    floor = -1 if last_ns is None else last_ns
    stamps = []
    for i in range(count):
        left = count - 1 - i                      # frames still to stamp after this one
        floor = min(max(now_ns - left * period_ns, floor + 1), now_ns - left)
        stamps.append(max(floor, 0))
    return stamps


def ranged(description: str, low: float, high: float, *, integer: bool = False,
           read_only: bool = False) -> ParameterDescriptor:
    """A descriptor whose value must lie in ``[low, high]`` (rcl_interfaces ranges; the runtime refuses
    others, and NaN, at declaration with the range and the value's file and line in the message)."""
    if integer:
        return ParameterDescriptor(description=description, read_only=read_only,
                                   integer_range=[IntegerRange(from_value=int(low), to_value=int(high), step=0)])
    return ParameterDescriptor(description=description, read_only=read_only,
                               floating_point_range=[FloatingPointRange(from_value=float(low), to_value=float(high),
                                                                        step=0.0)])


class SerialDriverNode(Node, Generic[ScanT]):
    """Base of the three driver nodes.

    Subclasses set :attr:`sensor` (e.g. ``'skin'``), :attr:`default_port`, :attr:`frame_rate_hz`
    and implement :meth:`make_decoder` and :meth:`handle_frame`.

    Attributes:
        driver: the :class:`SerialDriver` reading the port (its ``decoder`` is the sensor's).
    """

    sensor = 'sensor'
    default_port = 'loop://'
    frame_rate_hz = 10.0
    #: Parameters the driver applies at once when set; the others are read at start.
    LIVE_PARAMETERS = frozenset({'frame_id', 'reconnect_period_s'})

    def __init__(self, node_name: str, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.port = self.declare_parameter(
            'port', self.default_port,
            ParameterDescriptor(description='serial device or pyserial URL, e.g. /dev/ttyACM0 or '
                                            f'{self.default_port}', read_only=True)).value
        self.baudrate = self.declare_parameter(
            'baudrate', 115200, ranged('UART baud rate (ignored by USB CDC and virtual ports)', 50, 12_000_000,
                                       integer=True)).value
        self.frame_id = self.declare_parameter('frame_id', f'{self.sensor}_link').value
        expected = self.declare_parameter(
            'expected_rate_hz', float(self.frame_rate_hz), ranged('frames/s the sensor sends', 0.01, 10_000.0)).value
        poll_rate = self.declare_parameter(
            'poll_rate_hz', 2.0 * expected, ranged('port reads per second where the driver polls (a simulated '
                                                   'clock, a virtual device, or read_on_arrival false)',
                                                   0.01, 100_000.0)).value
        read_on_arrival = self.declare_parameter(
            'read_on_arrival', True,
            ParameterDescriptor(description='on the wall clock with a real port, read when bytes arrive (a thread '
                                            'blocked on the port) rather than polling at poll_rate_hz')).value
        self.reconnect_period_s = self.declare_parameter(
            'reconnect_period_s', 1.0, ranged('s between attempts to reopen a lost port', 0.001, 3600.0)).value
        status_period = self.declare_parameter(
            'status_period_s', 1.0, ranged('s between status and diagnostics messages', 0.001, 3600.0)).value
        self.warn_error_fraction = self.declare_parameter(
            'warn_error_fraction', 0.01, ranged('share of bad or lost frames in a status period that is WARN',
                                                0.0, 1.0)).value
        self.error_error_fraction = self.declare_parameter(
            'error_error_fraction', 0.2, ranged('share of bad or lost frames in a status period that is ERROR',
                                                0.0, 1.0)).value
        self.min_rate_fraction = self.declare_parameter(
            'min_rate_fraction', 0.8, ranged('rate below this share of expected_rate_hz is WARN', 0.0, 1.0)).value
        self.max_rate_factor = self.declare_parameter(
            'max_rate_factor', 2.0, ranged('rate above this multiple of expected_rate_hz is WARN', 1.0, 1000.0)).value
        if not isinstance(self.port, str) or not self.port.strip():
            raise ParameterError(f"parameter 'port' of {self.get_fully_qualified_name()} must be a device path or "
                                 f"URL (e.g. /dev/ttyACM0 or {self.default_port}); got {self.port!r}")
        if self.warn_error_fraction > self.error_error_fraction:
            raise ParameterError(f'warn_error_fraction ({self.warn_error_fraction:g}) must not exceed '
                                 f'error_error_fraction ({self.error_error_fraction:g}) of '
                                 f'{self.get_fully_qualified_name()}')
        self._check_port_is_ours()
        self.expected_rate_hz = expected

        self.driver: SerialDriver[ScanT] = SerialDriver(self.port, self.make_decoder(), baudrate=self.baudrate,
                                                        clock=self._clock_s)
        self.status_pub = self.create_publisher(DriverStatus, '~/status', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.frames = 0
        self._last_stamp_ns: int | None = None
        self.handle_errors = 0
        self.reconnects = 0
        self.last_error = ''
        self._frames_at_status = 0
        self._bad_at_status = 0
        self._arrived_at_status = 0
        self._sequence_at_status = dict.fromkeys(_SEQUENCE_COUNTERS, 0)
        self._status_period = status_period
        self._next_attempt_s = 0.0
        self._was_connected = False
        #: True: a thread reads the port when bytes arrive; False: a timer polls it at poll_rate_hz.
        self.reads_on_arrival = (read_on_arrival is True and not self.get_clock().ros_time_is_active
                                 and not self._is_virtual_port())
        self._reader: PortReader | None = None
        self._reopen_timer: Any = None
        if self.reads_on_arrival:
            self._arrival = self.create_guard_condition(self._on_arrival)
            if poll_rate != 2.0 * expected:
                self.get_logger().warning(f'poll_rate_hz ({poll_rate:g}) is not used: this driver reads {self.port} '
                                          'when bytes arrive (read_on_arrival:=false polls it)')
        self._try_open(at_start=True)
        if self.reads_on_arrival:
            if not self.driver.is_open:
                self._watch_port()
        else:
            self.create_timer(1.0 / poll_rate, self._poll)
        self.create_timer(status_period, self._publish_status)
        self.add_on_set_parameters_callback(self._on_set_parameters)

    # ------------------------------------------------------------------ for subclasses
    def make_decoder(self) -> SensorStreamDecoder[ScanT]:
        """The sensor's stream decoder (bytes -> scans)."""
        raise NotImplementedError

    def handle_frame(self, frame: DecodedFrame[ScanT]) -> None:
        """Calibrate ``frame.scan`` and publish it."""
        raise NotImplementedError

    def header(self, frame: DecodedFrame[ScanT] | None = None) -> Any:
        """A header with this driver's frame id, stamped with ``frame``'s stamp (see :meth:`_poll`), or
        now without a frame or before the frame is stamped."""
        if frame is None or frame.stamp_ns is None:
            return Header(stamp=self.get_clock().now().to_msg(), frame_id=self.frame_id)
        # Time(nanoseconds=...).to_msg() without the Time: every frame's path (stamps are >= 0)
        sec, nanosec = divmod(frame.stamp_ns, _NS_PER_S)
        return Header(stamp=TimeMsg(sec=sec, nanosec=nanosec), frame_id=self.frame_id)

    # ------------------------------------------------------------------ internals
    def _on_set_parameters(self, params: list[Any]) -> Any:
        """Apply :attr:`LIVE_PARAMETERS` at once; refuse the ones read at start (use_sim_time is the runtime's).

        A parameter not declared yet is being declared (rclpy runs these callbacks on each
        declaration, and a subclass declares its own after this is registered): accepted."""
        for param in params:
            if param.name == 'use_sim_time' or not self.has_parameter(param.name):
                continue
            if param.name not in self.LIVE_PARAMETERS:
                return SetParametersResult(successful=False, reason=f"'{param.name}' is read when the driver "
                                           'starts; relaunch the node to change it')
            if param.name == 'reconnect_period_s' and not param.value > 0:
                return SetParametersResult(successful=False, reason='reconnect_period_s must be > 0 s')
        for param in params:
            if param.name == 'frame_id':
                self.frame_id = param.value
            elif param.name == 'reconnect_period_s':
                self.reconnect_period_s = param.value
        return SetParametersResult(successful=True)

    def _clock_s(self) -> float:
        return self.get_clock().now().nanoseconds * 1e-9

    def _check_port_is_ours(self) -> None:
        """Refuse a virtual device of another sensor (``bearsim://`` given to the skin driver)."""
        scheme = self.port.split('://', 1)[0] if '://' in self.port else ''
        if scheme in url_handler_packages() and scheme != f'{self.sensor}sim':
            raise PortURLError(f"{self.port} is a virtual device of another sensor; the {self.sensor} driver reads "
                               f"{self.sensor}sim:// URLs or a real port (parameter 'port' of "
                               f'{self.get_fully_qualified_name()})')

    def _is_virtual_port(self) -> bool:
        """A simulated device or pyserial's loopback: bytes made on a read, nothing a thread could wait for."""
        scheme = self.port.split('://', 1)[0] if '://' in self.port else ''
        return scheme in url_handler_packages() or scheme == 'loop'

    def _try_open(self, at_start: bool = False) -> None:
        try:
            self.driver.open()
        except PortURLError as err:
            if at_start:
                raise               # a configuration that can never work: the node does not start
            self.last_error = str(err)
            self._next_attempt_s = float('inf')     # not retried; reported as ERROR on /diagnostics
            self.get_logger().error(str(err), once=True)
            return
        except DriverError as err:
            self.last_error = str(err)
            self._next_attempt_s = self._clock_s() + self.reconnect_period_s
            self.get_logger().warning(f'{err}; retrying every {self.reconnect_period_s:g} s', once=True)
            return
        if self._was_connected:
            self.reconnects += 1
            self.get_logger().info(f'{self.port} is back (reconnect {self.reconnects})')
        else:
            self.get_logger().info(f'reading {self.sensor} frames from {self.port}')
        self._was_connected = True
        self.last_error = ''
        if self.reads_on_arrival:
            self._start_reader()

    # ------------------------------------------------------------------ reading when bytes arrive
    def _start_reader(self) -> None:
        if self._reopen_timer is not None:
            self.destroy_timer(self._reopen_timer)
            self._reopen_timer = None
        self._reader = PortReader(self.driver.serial, self._arrival, name=f'{self.get_name()} reader')
        self._reader.start()

    def _watch_port(self) -> None:
        """Try to reopen the port every ``reconnect_period_s`` until it is back (then the reader runs)."""
        if self._reopen_timer is None:
            self._reopen_timer = self.create_timer(self.reconnect_period_s, self._reopen)

    def _reopen(self) -> None:
        if not self.driver.is_open and self._clock_s() >= self._next_attempt_s:
            self._try_open()

    def _on_arrival(self) -> None:
        """The reader's bytes, in the executor's thread: decode them and publish the frames."""
        reader = self._reader
        if reader is None:
            return
        for item in reader.take():
            if isinstance(item, Exception):
                self._reader = None
                self.driver.close()
                self._port_lost(f'{self.port} stopped answering: {item}')
                self._watch_port()
                break
            self.driver.feed(item)
        self._publish_frames(self.driver.take_frames())

    def _port_lost(self, error: str) -> None:
        self.last_error = error
        self._next_attempt_s = self._clock_s() + self.reconnect_period_s
        self.get_logger().warning(f'{error}; reconnecting every {self.reconnect_period_s:g} s')

    def _poll(self) -> None:
        if not self.driver.is_open:
            if self._clock_s() >= self._next_attempt_s:
                self._try_open()
            if not self.driver.is_open:
                return
        read_frame = self.driver.read_frame
        frames: list[DecodedFrame[ScanT]] = []
        while True:
            try:
                frame = read_frame(0)        # what has arrived; never waits
            except DriverError as err:
                self._port_lost(str(err))
                break                        # the frames read before the port went are still published
            if frame is None:
                break
            frames.append(frame)
        self._publish_frames(frames)

    def _publish_frames(self, frames: list[DecodedFrame[ScanT]]) -> None:
        """Stamp the frames read together now (:func:`frame_stamps_ns`), handle and count each."""
        if not frames:
            return
        stamps = frame_stamps_ns(len(frames), self.get_clock().now().nanoseconds,
                                 round(1e9 / self.expected_rate_hz), self._last_stamp_ns)
        self._last_stamp_ns = stamps[-1]
        for frame, stamp_ns in zip(frames, stamps, strict=True):
            try:
                self.handle_frame(DecodedFrame(frame.scan, frame.received_s, stamp_ns))
            except Exception as err:  # a frame the node cannot handle is counted and reported, never fatal
                self.handle_errors += 1
                self.last_error = f'cannot handle a frame: {type(err).__name__}: {err}'
                self.get_logger().error(self.last_error, throttle_duration_sec=10.0)
                continue
            self.frames += 1                 # counted once its message went out

    def counters(self) -> dict[str, int]:
        """Every counter of :class:`DriverStatus` since the driver started (frames = published)."""
        stats = self.driver.stats
        return {'frames': self.frames, 'dropped_bytes': stats.dropped_bytes, 'header_errors': stats.header_errors,
                'version_errors': stats.version_errors, 'length_errors': stats.length_errors,
                'checksum_errors': stats.checksum_errors, 'decode_errors': self.driver.decoder.corrupt_frames,
                'sequence_gaps': stats.sequence_gaps, 'frames_missed': stats.frames_missed,
                'repeated_frames': stats.repeated_frames, 'sequence_resets': stats.sequence_resets,
                'handle_errors': self.handle_errors, 'reconnects': self.reconnects}

    def status(self) -> Any:
        """The current :class:`DriverStatus` message (rate and error fraction over the period so far)."""
        counts = self.counters()
        published = counts['frames'] - self._frames_at_status
        bad = sum(counts[key] for key in _BAD_FRAME_COUNTERS) - self._bad_at_status
        fraction = bad / (bad + published) if bad + published else 0.0
        return DriverStatus(header=self.header(), port=self.port, connected=self.driver.is_open, **counts,
                            error_fraction=fraction, rate_hz=published / self._status_period,
                            last_error=self.last_error)

    def _level(self, status: Any, new: dict[str, int] | None = None) -> tuple[int, str]:
        """Diagnostic level and message of one status (thresholds are parameters); ``new`` holds the
        repeated frames and sequence resets of this period."""
        level, text = self._frame_level(status)
        new = new or {}
        notes = []
        if new.get('sequence_resets'):
            notes.append(f'sequence counter jumped back {new["sequence_resets"]} time(s): the sensor rebooted, '
                         'another one took the port, or over 32767 frames were lost; counting goes on from it')
        if new.get('repeated_frames'):
            notes.append(f'{new["repeated_frames"]} frames resent with the last sequence number, not published')
        if notes and level < _WARN:
            return _WARN, '; '.join(notes)
        return level, '; '.join([text, *notes])

    def _frame_level(self, status: Any) -> tuple[int, str]:
        """Level and message from the frames published and lost in the period."""
        if not status.connected:
            return _ERROR, f'disconnected: {status.last_error}'
        if status.error_fraction >= 1.0 and status.rate_hz == 0:
            return _ERROR, f'frames arrive but none is published: {status.last_error or "all bad"}'
        bad = (f'{100 * status.error_fraction:.1f} % of frames bad or lost '
               f'(missed {status.frames_missed}, checksum {status.checksum_errors}, decode {status.decode_errors}, '
               f'length {status.length_errors}, handle {status.handle_errors} since start)')
        if status.error_fraction > self.error_error_fraction:
            return _ERROR, bad
        if status.version_errors and status.frames == 0:
            return _ERROR, (f'{status.version_errors} frames of another protocol version and none of version 2: '
                            'update the sensor firmware')
        if status.error_fraction > self.warn_error_fraction:
            return _WARN, bad
        if status.rate_hz == 0 and self._status_period * self.expected_rate_hz >= 2:
            # Connected, at least two frames due, none published: a dead sensor, not a slow one.
            return _ERROR, (f'no frame in {self._status_period:g} s (expected {self.expected_rate_hz:g} Hz); '
                            f'{status.dropped_bytes} bytes dropped since start')
        if status.rate_hz < self.min_rate_fraction * self.expected_rate_hz:
            return _WARN, f'{status.rate_hz:.1f} Hz, expected {self.expected_rate_hz:g} Hz'
        if status.rate_hz > self.max_rate_factor * self.expected_rate_hz:
            return _WARN, (f'{status.rate_hz:.1f} Hz, more than {self.max_rate_factor:g} x the expected '
                           f'{self.expected_rate_hz:g} Hz: is this the configured sensor?')
        return _OK, f'{status.rate_hz:.1f} Hz'

    def subscriber_drops(self) -> int:
        """Messages this node's subscriptions dropped with a full queue (none unless a subclass subscribes)."""
        return sum(dropped_by_topic(self).values())

    def _publish_status(self) -> None:
        sequence = {key: getattr(self.driver.stats, key) for key in _SEQUENCE_COUNTERS}
        new = {key: sequence[key] - self._sequence_at_status[key] for key in _SEQUENCE_COUNTERS}
        self._sequence_at_status = sequence
        if new['sequence_resets']:
            self.last_error = f'sequence counter jumped back ({sequence["sequence_resets"]} times since start)'
            self.get_logger().warning(f'{self.port}: sequence counter jumped back {new["sequence_resets"]} '
                                      'time(s) (a reboot?); counting goes on from it')
        status = self.status()                # after last_error names a reset, so ~/status carries it
        counts = self.counters()
        self._frames_at_status = counts['frames']
        self._bad_at_status = sum(counts[key] for key in _BAD_FRAME_COUNTERS)
        self.status_pub.publish(status)
        level, text = self._level(status, new)
        extra = {'subscriber_drops': self.subscriber_drops()}
        values = [KeyValue(key=key, value=str(extra[key] if key in extra else getattr(status, key)))
                  for key in _DIAGNOSTIC_KEYS]
        self.diagnostics_pub.publish(DiagnosticArray(header=status.header, status=[DiagnosticStatus(
            level=bytes([level]),
            name=f'social_touch: {self.get_fully_qualified_name()}', message=text, hardware_id=self.port,
            values=values)]))

    def destroy_node(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.stop()
        self.driver.close()
        super().destroy_node()

