"""Textile patch driver, pure layers (sympartner2018): wire protocol, calibration, panels.

- :mod:`.protocol`: 20 Hz (0x50) and raw 100 Hz (0x51) frames, 10-bit packed cells + 11 panels; :class:`PatchDecoder`
- :mod:`.calibration`: :class:`ScanAverager`, :class:`PatchCalibrator` (eq. 1 and 2), the outline mask
- :mod:`.panels`: :class:`PanelCalibrator`, capacitive panel contact
"""

from touch_driver.patch.calibration import PatchActivation, PatchCalibrator, ScanAverager, load_outline
from touch_driver.patch.panels import PanelCalibrator, PanelState
from touch_driver.patch.protocol import PatchDecoder, PatchScan

__all__ = ['PanelCalibrator', 'PanelState', 'PatchActivation', 'PatchCalibrator', 'PatchDecoder', 'PatchScan',
           'ScanAverager', 'load_outline']
