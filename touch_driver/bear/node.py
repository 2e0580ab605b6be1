"""``bear_driver``: the Sensate Bear's serial driver node.

Reads scans from ``port`` (``/dev/ttyACM0`` on the robot, ``bearsim://...`` for the virtual
bear), calibrates them (:class:`~touch_driver.bear.calibration.BearCalibrator`: baseline and
gain to 0..1, activation over 30 % as in knight2009 V.A, fault flags) and publishes a
``BearFrame`` per scan on ``frame`` (``/bear/frame`` in the ``bear`` namespace), plus status and diagnostics.
"""

from __future__ import annotations

from typing import Any

from touch_graph.compat import get_message, sensor_data_qos
from touch_graph.node_main import run_node

from ..driver_node import SerialDriverNode, ranged
from ..serial_driver import DecodedFrame
from .body_map import BodyMap
from .calibration import BearCalibrator
from .protocol import REAL_RATE_HZ, BearDecoder, BearScan

__all__ = ['BearDriverNode', 'main']

BearFrame = get_message('social_touch_msgs/msg/BearFrame')


class BearDriverNode(SerialDriverNode[BearScan]):
    sensor = 'bear'
    default_port = 'bearsim://bear'
    frame_rate_hz = REAL_RATE_HZ

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('bear_driver', **kwargs)
        body_map_path = self.declare_parameter('body_map', '').value
        self.body_map = BodyMap.load(body_map_path) if body_map_path else BodyMap.default()
        self.get_logger().info(f'body map {self.body_map.source}')
        self.calibrator = BearCalibrator(
            self.body_map,
            threshold=self.declare_parameter('threshold', 0.3, ranged('activation level, 0..1', 0.001, 0.999)).value,
            baseline_frames=self.declare_parameter('baseline_frames', 10, ranged('scans averaged into the baseline',
                                                                                 1, 100_000, integer=True)).value,
            rate_hz=self.expected_rate_hz,
            drift_tau_s=self.declare_parameter('drift_tau_s', 120.0, ranged('baseline drift time constant, s',
                                                                            0.1, 1e6)).value,
            fault_after_s=self.declare_parameter('fault_after_s', 60.0, ranged('s stuck before a fault', 0.1,
                                                                               1e6)).value,
            saturated_after_s=self.declare_parameter('saturated_after_s', 300.0, ranged('s saturated before a fault',
                                                                                        0.1, 1e6)).value)
        self.frame_pub = self.create_publisher(BearFrame, 'frame', sensor_data_qos())

    def make_decoder(self) -> BearDecoder:
        return BearDecoder()

    def handle_frame(self, frame: DecodedFrame[BearScan]) -> None:
        levels = self.calibrator.update(frame.scan.raw)
        self.frame_pub.publish(BearFrame(
            header=self.header(frame), sequence=frame.scan.seq, raw=levels.raw, level=levels.level,
            active=levels.active.tolist(), fitted=levels.fitted.tolist(), faults=levels.faults))  # bool[]: bools


def main(args: list[str] | None = None) -> int:
    return run_node(BearDriverNode, args)
