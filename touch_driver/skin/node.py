"""``skin_driver``: the optoelectronic skin's serial driver node.

Reads 150 Hz frames from ``port`` (``skinsim://...`` for the virtual skin), calibrates them
(:class:`~touch_driver.skin.calibration.SkinCalibrator`: tare, drift tracking that keeps a
sustained press, contact point, module forces) and publishes a ``SkinFrame`` per frame on
``frame`` (``/skin/frame`` in the ``skin`` namespace), plus status and diagnostics.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from touch_graph.compat import get_message, sensor_data_qos
from touch_graph.node_main import run_node
from touch_graph.paths import share_file

from ..driver_node import SerialDriverNode
from ..serial_driver import DecodedFrame
from .calibration import SkinCalibrator
from .calibration_config import load_skin_calibration
from .protocol import FRAME_RATE_HZ, SkinScan, SkinStreamDecoder

__all__ = ['SkinDriverNode', 'main']

SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
Point = get_message('geometry_msgs/msg/Point')
Vector3 = get_message('geometry_msgs/msg/Vector3')


class SkinDriverNode(SerialDriverNode[SkinScan]):
    sensor = 'skin'
    default_port = 'skinsim://skin'
    frame_rate_hz = FRAME_RATE_HZ

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('skin_driver', **kwargs)
        config_path = self.declare_parameter('calibration', '').value
        self.calibrator = SkinCalibrator(load_skin_calibration(config_path or None))
        self.get_logger().info(f"calibration {config_path or share_file('config', 'skin_calibration.yaml')}")
        self.frame_pub = self.create_publisher(SkinFrame, 'frame', sensor_data_qos())

    def make_decoder(self) -> SkinStreamDecoder:
        return SkinStreamDecoder()

    def handle_frame(self, frame: DecodedFrame[SkinScan]) -> None:
        scan = frame.scan
        state = self.calibrator.update(scan.raw)
        x, y = state.contact_xy_mm.tolist() if state.contact else (math.nan, math.nan)   # Python floats
        z = 0.0 if state.contact else math.nan
        fx, fy, _ = state.force.sum(axis=0, dtype=np.float64).tolist()
        self.frame_pub.publish(SkinFrame(
            header=self.header(frame), sequence=scan.seq, raw=scan.raw, pressure=state.pressure.ravel(),
            contact=bool(state.contact), contact_x=x, contact_y=y, force=state.force.ravel(),
            total_force=float(state.total_force), contact_point=Point(x=x * 1e-3, y=y * 1e-3, z=z),
            net_force=Vector3(x=fx, y=fy, z=float(state.total_force))))


def main(args: list[str] | None = None) -> int:
    return run_node(SkinDriverNode, args)
