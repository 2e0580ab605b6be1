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
from touch_graph.paths import share_file

from ..driver_node import SerialDriverNode
from ..serial_driver import DecodedFrame
from .calibration import PatchCalibrator
from .panels import PanelCalibrator
from .protocol import PatchDecoder, PatchScan

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
            gain=self.declare_parameter('gain', 1.0 / 400.0).value,
            tau=self.declare_parameter('tau', 0.001).value,
            k=self.declare_parameter('k', 0.08).value,
            average_window=self.declare_parameter('average_window', 5).value,
            decimation=self.declare_parameter('decimation', 5).value)
        self._panels_config = self.declare_parameter('panels', '').value or None
        self.get_logger().info(f"outline {outline or share_file('config', 'patch_outline.yaml')}, panels "
                               f"{self._panels_config or share_file('config', 'panels.yaml')}")
        self._panel_calibrators: dict[int, PanelCalibrator] = {}
        self._last_contact: np.ndarray | None = None
        self.frame_pub = self.create_publisher(PatchFrame, 'frame', sensor_data_qos())
        self.panels_pub = self.create_publisher(PanelContact, 'panels', sensor_data_qos())

    def make_decoder(self) -> PatchDecoder:
        return PatchDecoder()

    def _panel_calibrator(self, raw_scan: bool) -> PanelCalibrator:
        # Panels are sampled with every frame of the stream: 100 Hz scans or 20 Hz averages.
        rate = SCAN_RATE_HZ if raw_scan else FRAME_RATE_HZ
        key = int(raw_scan)
        if key not in self._panel_calibrators:
            self._panel_calibrators[key] = PanelCalibrator.from_yaml(self._panels_config, rate_hz=rate)
        return self._panel_calibrators[key]

    def handle_frame(self, frame: DecodedFrame[PatchScan]) -> None:
        scan = frame.scan
        activation = self.calibrator.update_scan(scan.cells) if scan.raw_scan else self.calibrator.update(scan.cells)
        state = self._panel_calibrator(scan.raw_scan).update(scan.panels)
        changed = self._last_contact is None or not np.array_equal(state.contact, self._last_contact)
        self._last_contact = state.contact
        if not (changed or activation is not None):
            return
        header = self.header()
        self.panels_pub.publish(PanelContact(header=header, delta=state.delta.astype(np.float32),
                                             contact=state.contact, any_contact=bool(state.any_contact)))
        if activation is not None:
            self.frame_pub.publish(PatchFrame(
                header=header, sequence=scan.seq, raw=activation.raw.ravel(),
                activation=activation.activation.ravel(), in_outline=activation.in_outline.ravel()))


def main(args: list[str] | None = None) -> int:
    from touch_graph.node_main import run_node
    return run_node(PatchDriverNode, args)
