"""Optoelectronic skin (cirillo2017): wire protocol, calibration, contact model and virtual device.

- :mod:`.protocol`: geometry, scanning order, payload codec, :class:`SkinStreamDecoder`.
- :mod:`.calibration`: :class:`SkinCalibrator` (tare, drift tracking, contact, contact point, forces).
- :mod:`.contact`, :mod:`.stimuli`, :mod:`.traces`: the finger model and the stimuli that drive it.
- :mod:`.device`: :class:`SkinDevice` (behind ``skinsim://``) and :func:`render_frames`.
- :mod:`.bench`: :func:`bench_decode_calibrate`.
"""

from .calibration import (
    CalibratedFrames,
    SkinCalibrationConfig,
    SkinCalibrator,
    SkinState,
    calibrate_frames,
    load_skin_calibration,
)
from .contact import Contact, FingerContactModel, SkinStimulus
from .device import SkinDevice, forget_stimuli, register_stimulus, registered_stimulus, render_frames
from .protocol import SkinRawFrame, SkinStreamDecoder, decode_payload, encode_payload, encode_skin_frame
from .stimuli import LineStroke, NoTouch, StaticPress, Timeline, load_scene
from .traces import TraceStimulus

__all__ = [
    'CalibratedFrames', 'Contact', 'FingerContactModel', 'LineStroke', 'NoTouch', 'SkinCalibrationConfig',
    'SkinCalibrator', 'SkinDevice', 'SkinRawFrame', 'SkinState', 'SkinStimulus', 'SkinStreamDecoder', 'StaticPress',
    'Timeline', 'TraceStimulus', 'calibrate_frames', 'decode_payload', 'encode_payload', 'encode_skin_frame',
    'forget_stimuli', 'load_scene', 'load_skin_calibration', 'register_stimulus', 'registered_stimulus',
    'render_frames',
]
