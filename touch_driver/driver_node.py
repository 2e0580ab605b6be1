"""The part every sensor driver node shares: port, polling, reconnects, diagnostics.

A sensor's node subclasses :class:`SerialDriverNode`, gives the sensor's stream decoder
(:meth:`SerialDriverNode.make_decoder`) and turns each decoded scan into its calibrated message
in :meth:`SerialDriverNode.handle_frame`. This base

- reads the port from a timer at ``poll_rate_hz`` (twice the sensor rate by default) with
  :meth:`~touch_driver.serial_driver.SerialDriver.read_frame`, so a frame is published at most
  half a period after it arrives, on the graph's clock (a virtual device on a simulated clock
  then runs as fast as the graph);
- survives an unplugged port: it logs once, reports ``connected: false``, and tries to
  reopen every ``reconnect_period_s`` until the device is back;
- publishes a ``DriverStatus`` on ``~/status`` and a ``diagnostic_msgs/DiagnosticArray`` on
  ``/diagnostics`` every ``status_period_s`` (frames, dropped bytes, checksum errors,
  sequence gaps, reconnects, rate), the latter for rqt_robot_monitor and aggregators.

Parameters set while it runs (``ros2 param set``, ``social-touch param set``): those in
:attr:`SerialDriverNode.live_parameters` take effect at once; every other one is read when
the driver starts (the port, the timers, the calibration), so a change is refused with that
reason instead of being accepted and ignored.
"""

from __future__ import annotations

from typing import Any, Generic

from touch_graph.compat import USING_ROS, Node, ParameterDescriptor, SetParametersResult, get_message

from .framing import ScanT, SensorStreamDecoder
from .serial_driver import DecodedFrame, DriverError, SerialDriver

__all__ = ['SerialDriverNode']

DriverStatus = get_message('social_touch_msgs/msg/DriverStatus')
DiagnosticArray = get_message('diagnostic_msgs/msg/DiagnosticArray')
DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')
KeyValue = get_message('diagnostic_msgs/msg/KeyValue')

_OK, _WARN, _ERROR = 0, 1, 2
# diagnostic_msgs/DiagnosticStatus.level is a `byte`: an int in our classes, bytes under rclpy.
_BYTE_LEVEL = USING_ROS


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
    live_parameters = frozenset({'frame_id', 'reconnect_period_s'})

    def __init__(self, node_name: str, **kwargs: Any) -> None:
        super().__init__(node_name, **kwargs)
        self.port = self.declare_parameter(
            'port', self.default_port,
            ParameterDescriptor(description='serial device or pyserial URL, e.g. /dev/ttyACM0 or '
                                            f'{self.default_port}', read_only=True)).value
        self.baudrate = self.declare_parameter('baudrate', 115200).value
        self.frame_id = self.declare_parameter('frame_id', f'{self.sensor}_link').value
        expected = self.declare_parameter('expected_rate_hz', float(self.frame_rate_hz)).value
        poll_rate = self.declare_parameter('poll_rate_hz', 2.0 * expected).value
        self.reconnect_period_s = self.declare_parameter('reconnect_period_s', 1.0).value
        status_period = self.declare_parameter('status_period_s', 1.0).value
        for name, value in (('expected_rate_hz', expected), ('poll_rate_hz', poll_rate),
                            ('reconnect_period_s', self.reconnect_period_s), ('status_period_s', status_period)):
            if not value > 0:
                raise ValueError(f"parameter '{name}' of {self.get_fully_qualified_name()} must be > 0, got {value}")
        self.expected_rate_hz = expected

        self.driver: SerialDriver[ScanT] = SerialDriver(self.port, self.make_decoder(), baudrate=self.baudrate,
                                                        clock=self._clock_s)
        self.status_pub = self.create_publisher(DriverStatus, '~/status', 10)
        self.diagnostics_pub = self.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self.frames = 0
        self.reconnects = 0
        self.last_error = ''
        self._frames_at_status = 0
        self._status_period = status_period
        self._next_attempt_s = 0.0
        self._was_connected = False
        self._try_open()
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

    def header(self) -> Any:
        """A header stamped now with this driver's frame id."""
        return get_message('std_msgs/msg/Header')(stamp=self.get_clock().now().to_msg(), frame_id=self.frame_id)

    # ------------------------------------------------------------------ internals
    def _on_set_parameters(self, params: list[Any]) -> Any:
        """Apply :attr:`live_parameters` at once; refuse the ones read at start (use_sim_time is the runtime's)."""
        for param in params:
            if param.name == 'use_sim_time':
                continue
            if param.name not in self.live_parameters:
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

    def _try_open(self) -> None:
        try:
            self.driver.open()
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

    def _poll(self) -> None:
        if not self.driver.is_open:
            if self._clock_s() >= self._next_attempt_s:
                self._try_open()
            if not self.driver.is_open:
                return
        read_frame = self.driver.read_frame
        while True:
            try:
                frame = read_frame(0)        # what has arrived; never waits
            except DriverError as err:
                self.last_error = str(err)
                self._next_attempt_s = self._clock_s() + self.reconnect_period_s
                self.get_logger().warning(f'{err}; reconnecting every {self.reconnect_period_s:g} s')
                return
            if frame is None:
                return
            self.frames += 1
            self.handle_frame(frame)

    def status(self) -> Any:
        """The current :class:`DriverStatus` message."""
        stats = self.driver.stats
        rate = (self.frames - self._frames_at_status) / self._status_period
        return DriverStatus(header=self.header(), port=self.port, connected=self.driver.is_open,
                            frames=self.frames, dropped_bytes=stats.dropped_bytes,
                            checksum_errors=stats.checksum_errors, sequence_gaps=stats.sequence_gaps,
                            reconnects=self.reconnects, rate_hz=rate, last_error=self.last_error)

    def _publish_status(self) -> None:
        status = self.status()
        self._frames_at_status = self.frames
        self.status_pub.publish(status)
        if not status.connected:
            level, text = _ERROR, f'disconnected: {status.last_error}'
        elif status.rate_hz < 0.8 * self.expected_rate_hz:
            level, text = _WARN, f'{status.rate_hz:.1f} Hz, expected {self.expected_rate_hz:g} Hz'
        else:
            level, text = _OK, f'{status.rate_hz:.1f} Hz'
        values = [KeyValue(key=key, value=str(getattr(status, key))) for key in
                  ('frames', 'dropped_bytes', 'checksum_errors', 'sequence_gaps', 'reconnects', 'rate_hz')]
        self.diagnostics_pub.publish(DiagnosticArray(header=status.header, status=[DiagnosticStatus(
            level=bytes([level]) if _BYTE_LEVEL else level,
            name=f'social_touch: {self.get_fully_qualified_name()}', message=text, hardware_id=self.port,
            values=values)]))

    def destroy_node(self) -> None:
        self.driver.close()
        super().destroy_node()

