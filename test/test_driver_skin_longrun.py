"""Long runs of the virtual skin: a 60 s press keeps its pressure, drift over minutes is followed,
memory stays bounded through a faulty port (synthetic data)."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import serial

import touch_sim  # noqa: F401  (registers the skinsim:// URL handler)
from touch_driver.skin.calibration import SkinCalibrator, calibrate_frames
from touch_driver.skin.calibration_config import SkinCalibrationConfig
from touch_driver.skin.protocol import SkinStreamDecoder
from touch_sim.skin.contact import FingerContactModel
from touch_sim.skin.device import SkinDevice, forget_stimuli, register_stimulus, render_frames
from touch_sim.skin.stimuli import StaticPress, Timeline
from touch_sim.virtual_port import forget_devices

pytestmark = pytest.mark.slow
RATE = 150


def window(values: np.ndarray, start_s: float, end_s: float) -> np.ndarray:
    return values[round(start_s * RATE):round(end_s * RATE)]


def test_sixty_second_press_keeps_its_pressure():
    press = StaticPress(18.0, 27.0, 1.5, at_s=1.0, for_s=61.0)
    frames = render_frames(press, duration_s=63.0, seed=11)              # default drift and noise
    out = calibrate_frames(frames)
    peak = out.pressure.max(axis=(1, 2))
    early, late = window(peak, 1.5, 2.5).mean(), window(peak, 60.5, 61.5).mean()
    assert early > 0.1
    assert late == pytest.approx(early, rel=0.05)
    assert window(out.total_force, 60.5, 61.5).mean() == pytest.approx(window(out.total_force, 1.5, 2.5).mean(),
                                                                       rel=0.05)
    assert window(out.contact, 1.0, 62.0).all()
    assert not window(out.contact, 62.2, 63.0).any()                    # and it ends when the finger lifts
    # Control: a calibrator that adapts every taxel (as skins that fade a hug do) loses the press,
    # so the check above can fail.
    fading = calibrate_frames(frames, SkinCalibrationConfig(drift_gate=100.0, guard_taxels=0))
    assert window(fading.pressure.max(axis=(1, 2)), 60.5, 61.5).mean() < 0.2 * early


def test_slow_drift_over_minutes_is_followed():
    minutes = 5
    scene = Timeline([StaticPress(23.5, 23.5, 1.0, at_s=5.0, for_s=2.0),
                      StaticPress(23.5, 23.5, 1.0, at_s=minutes * 60 - 5.0, for_s=2.0)])
    # No repeatability error here: the two presses should differ only by what drift does to them.
    device = SkinDevice(scene, seed=5, drift_counts=1500.0, drift_period_s=480.0,
                        contact_model=FingerContactModel(repeatability=0.0))
    cal = SkinCalibrator()
    n = minutes * 60 * RATE
    peaks = np.empty(n, dtype=np.float32)
    contact = np.empty(n, dtype=bool)
    for i in range(n):
        s = cal.update(device.raw_frame(i / RATE))
        peaks[i], contact[i] = s.pressure.max(), s.contact
    t_end = (n - 1) / RATE
    drift = device.baseline(t_end) - device.baseline(0.0)
    # Untracked, this drift alone would read as a press far above the contact threshold.
    assert np.abs(drift).max() / cal.config.full_scale_counts > 5 * cal.config.contact_on
    assert np.abs(cal.baseline - device.baseline(t_end)).max() < 50       # counts; noise is 25
    untouched = np.ones(n, dtype=bool)
    untouched[round(4.5 * RATE):round(7.6 * RATE)] = False
    untouched[round((minutes * 60 - 5.5) * RATE):round((minutes * 60 - 2.4) * RATE)] = False
    untouched[:round(0.2 * RATE)] = False                                 # tare
    assert not contact[untouched].any()
    assert peaks[untouched].max() < cal.config.contact_on
    # The same press reads the same after minutes of drift.
    first = window(peaks, 5.5, 6.5).mean()
    last = window(peaks, minutes * 60 - 4.5, minutes * 60 - 3.5).mean()
    assert last == pytest.approx(first, rel=0.06)


def _state_bytes(obj) -> int:
    return sum(v.nbytes for v in vars(obj).values() if isinstance(v, np.ndarray))


def test_long_run_through_a_faulty_port_has_bounded_memory():
    forget_devices()
    forget_stimuli()
    register_stimulus('taps', Timeline([StaticPress(10.0 + k % 3 * 12, 30.0, 1.2, at_s=2.0 + 4.0 * k, for_s=1.0)
                                        for k in range(40)]))
    clock = [0.0]
    port = serial.serial_for_url('skinsim://long?scene=taps&garbage=0.05&corrupt=0.02&seed=2', do_not_open=True)
    port.attach_clock(lambda: clock[0])
    port.open()
    dec, cal = SkinStreamDecoder(), SkinCalibrator()
    contacts = frames = 0
    sizes = []
    tracemalloc.start()
    try:
        for step in range(16000 // 10):                   # 160 s of device time, read every 10 frames
            clock[0] += 10 / RATE
            for f in dec.update(port.read(port.in_waiting)):
                s = cal.update(f.raw)
                frames += 1
                contacts += s.contact
            if step == 200:
                tracemalloc.reset_peak()
                before = tracemalloc.get_traced_memory()[0]
                sizes.append(_state_bytes(cal))
        after, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
        port.close()
        forget_devices()
        forget_stimuli()
    assert frames > 15000 and dec.stats.dropped_bytes > 0 and dec.stats.checksum_errors > 0
    assert dec.buffered < 2 * 302
    assert _state_bytes(cal) == sizes[0]
    assert after - before < 64 * 1024 and peak - before < 512 * 1024
    assert contacts > 0
