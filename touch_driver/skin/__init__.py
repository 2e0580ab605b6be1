"""Optoelectronic skin driver (cirillo2017): wire protocol and calibration.

- :mod:`.protocol`: geometry, scanning order, payload codec, :class:`SkinStreamDecoder`.
- :mod:`.calibration`: :class:`SkinCalibrator` (tare, drift tracking, contact, contact point, forces).
- :mod:`.calibration_config`: the calibration constants and their YAML file.
- :mod:`.node`: the ``skin_driver`` node.

The virtual skin (contact model, stimuli, device) is in :mod:`touch_sim.skin`.
"""

from .calibration import (
    CalibratedFrames,
    SkinCalibrationConfig,
    SkinCalibrator,
    SkinState,
    calibrate_frames,
    load_skin_calibration,
)
from .protocol import SkinScan, SkinStreamDecoder, decode_payload, encode_payload, encode_skin_frame

__all__ = [
    'CalibratedFrames', 'SkinCalibrationConfig', 'SkinCalibrator', 'SkinScan', 'SkinState', 'SkinStreamDecoder',
    'calibrate_frames', 'decode_payload', 'encode_payload', 'encode_skin_frame', 'load_skin_calibration',
]
