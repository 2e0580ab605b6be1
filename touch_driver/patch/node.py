"""``patch_driver``: the textile patch's serial driver node (pressure matrix + capacitive panels).

Reads frames from ``port`` (``patchsim://...`` for the virtual patch): raw 100 Hz scans (id
0x51), which it averages and sub-samples to 20 Hz as sympartner2018 6.1 describes, or the
firmware's own 20 Hz averages (id 0x50). It publishes

- ``frame`` (``/patch/frame``): a ``PatchFrame`` at 20 Hz, the activation of eq. (1)-(2);
- ``panels`` (``/patch/panels``): ``PanelContact`` as soon as any panel's contact changes
  (from every scan: within 10 ms on a 100 Hz stream), and with every 20 Hz frame otherwise,
  so a driving robot can stop on ``any_contact`` with the least latency the data allows.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from touch_graph.compat import get_message, sensor_data_qos
from touch_graph.node_main import run_node
from touch_graph.paths import share_file

from ..driver_node import SerialDriverNode, ranged
from ..serial_driver import DecodedFrame
from .calibration import PatchCalibrator
from .panels import PanelCalibrator
from .protocol import N_PANELS, PatchDecoder, PatchScan

__all__ = ['PatchDriverNode', 'main']

PatchFrame = get_message('social_touch_msgs/msg/PatchFrame')
PanelContact = get_message('social_touch_msgs/msg/PanelContact')

SCAN_RATE_HZ = 100.0  # the firmware's internal scan rate (sympartner2018 6.1)
FRAME_RATE_HZ = 20.0  # averaged frames to the PC (sympartner2018 6.1)


class PatchDriverNode(SerialDriverNode[PatchScan]):
    sensor = 'patch'
    default_port = 'patchsim://patch'
    # Wire frames per second: raw scans by default; set expected_rate_hz: 20.0 for firmware
    # that sends its own 20 Hz averages.
    frame_rate_hz = SCAN_RATE_HZ

    def __init__(self, **kwargs: Any) -> None:
        super().__init__('patch_driver', **kwargs)
        outline = self.declare_parameter('outline', '').value
        self.calibrator = PatchCalibrator(
            outline or None,
            gain=self.declare_parameter('gain', 1.0 / 400.0, ranged('eq. (2) gain g, 1/counts', 1e-9, 1e3)).value,
            tau=self.declare_parameter('tau', 0.001, ranged('eq. (1) minimum tracking rate, per frame',
                                                            0.0, 1.0)).value,
            k=self.declare_parameter('k', 0.08, ranged('eq. (2) activation floor', 0.0, 0.99)).value,
            average_window=self.declare_parameter('average_window', 5, ranged('scans in the moving average', 1,
                                                                              1000, integer=True)).value,
            decimation=self.declare_parameter('decimation', 5, ranged('scans per published frame', 1, 1000,
                                                                      integer=True)).value)
        panels_config = self.declare_parameter('panels', '').value or None
        self.get_logger().info(f"outline {outline or share_file('config', 'patch_outline.yaml')}, panels "
                               f"{panels_config or share_file('config', 'panels.yaml')}")
        # Both streams' calibrators are built now, so a wrong panels file stops the node at start
        # (file and line in the error) instead of failing on every frame.
        self._panel_calibrators = {int(raw): PanelCalibrator.from_yaml(panels_config, rate_hz=rate, n_panels=N_PANELS)
                                   for raw, rate in ((True, SCAN_RATE_HZ), (False, FRAME_RATE_HZ))}
        self._last_contact: np.ndarray | None = None
        self.frame_pub = self.create_publisher(PatchFrame, 'frame', sensor_data_qos())
        self.panels_pub = self.create_publisher(PanelContact, 'panels', sensor_data_qos())

    def make_decoder(self) -> PatchDecoder:
        return PatchDecoder()

    def _panel_calibrator(self, raw_scan: bool) -> PanelCalibrator:
        # Panels are sampled with every frame of the stream: 100 Hz scans or 20 Hz averages.
        return self._panel_calibrators[int(raw_scan)]

    def handle_frame(self, frame: DecodedFrame[PatchScan]) -> None:
        scan = frame.scan
        activation = self.calibrator.update_scan(scan.cells) if scan.raw_scan else self.calibrator.update(scan.cells)
        state = self._panel_calibrator(scan.raw_scan).update(scan.panels)
        # (bytes compared, cheaper than np.array_equal on every scan: same shape and dtype)
        changed = self._last_contact is None or state.contact.tobytes() != self._last_contact.tobytes()
        self._last_contact = state.contact
        if not (changed or activation is not None):
            return
        header = self.header(frame)
        self.panels_pub.publish(PanelContact(header=header, delta=state.delta.astype(np.float32),
                                             contact=state.contact.tolist(),  # bool[]: Python bools, as rclpy needs
                                             any_contact=bool(state.any_contact)))
        if activation is not None:
            self.frame_pub.publish(PatchFrame(
                header=header, sequence=scan.seq, raw=activation.raw.ravel(),
                activation=activation.activation.ravel(), in_outline=activation.in_outline.ravel().tolist()))


def main(args: list[str] | None = None) -> int:
    return run_node(PatchDriverNode, args)
