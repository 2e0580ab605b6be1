"""The virtual patch: matrix and panel model, both firmware modes, patchsim:// URL, calibration on it."""

from __future__ import annotations

import numpy as np
import pytest
import serial
from serial.serialutil import SerialException
from sim_testing import open_port

import touch_sim  # noqa: F401  (registers the URL handlers)
from touch_driver.patch.calibration import PanelCalibrator, PatchCalibrator, load_outline
from touch_driver.patch.protocol import PATCH_FRAME_ID, PATCH_SCAN_ID, PatchDecoder
from touch_sim.patch.device import PatchDevice
from touch_sim.scenes import IdlePatch, PanelTouch, PatchScript, PatchTouch, register_stimulus, unregister_stimulus
from touch_sim.virtual_port import forget_devices

OUTLINE = load_outline()
CLEAN = dict(noise=0.0, drift_counts=0.0, crosstalk=0.0, creep=0.0, panel_noise=0.0, panel_drift=0.0)


@pytest.fixture(autouse=True)
def _clean_registry():
    yield
    forget_devices()
    unregister_stimulus('patch-test')


class Press:
    """A constant pressure map and panel levels."""

    def __init__(self, pressure: np.ndarray | None = None, panels: np.ndarray | None = None) -> None:
        self.p = np.zeros((16, 16), np.float32) if pressure is None else np.asarray(pressure, np.float32)
        self.q = np.zeros(11, np.float32) if panels is None else np.asarray(panels, np.float32)

    def pressure(self, t: float) -> np.ndarray:
        return self.p

    def panels(self, t: float) -> np.ndarray:
        return self.q


def one_cell(row: int, col: int, p: float) -> np.ndarray:
    out = np.zeros((16, 16), np.float32)
    out[row, col] = p
    return out


def run(device: PatchDevice, n: int) -> list:
    dec = PatchDecoder()
    out = [s for i in range(n) for s in dec.update(device.frame_bytes(i, i * device.frame_period))]
    assert len(out) == n
    return out


def test_idle_counts_and_outline() -> None:
    scans = run(PatchDevice(IdlePatch(), seed=2), 50)
    cells = np.array([s.cells for s in scans], dtype=float)
    assert (cells[:, OUTLINE] >= 15).all() and (cells[:, OUTLINE] <= 80).all()
    assert cells[:, ~OUTLINE].max() <= 10  # no fabric outside the outline: only noise near 0
    assert 1.5 < cells[:, OUTLINE].std(axis=0).mean() < 2.5
    panels = np.array([s.panels for s in scans], dtype=float)
    assert ((panels > 380) & (panels < 620)).all()
    assert all(s.raw_scan for s in scans)


def test_transfer_curve_is_nearly_linear_below_300_g_per_cm2() -> None:
    device = PatchDevice(Press(), **CLEAN)
    delta = []
    for p in (0.5, 1.0, 2.0, 3.0, 6.0, 12.0):
        device.stimulus = Press(one_cell(8, 8, p))
        delta.append(device.scan_counts(0, 0.0)[8, 8] - device.rest[8, 8])
    slope = delta[0] / 0.5
    assert delta[3] / (3.0 * slope) > 0.95  # within 5 % of linear at 3 N/cm^2 (~300 g/cm^2)
    assert delta[4] / (6.0 * slope) < 0.85  # compressed above ~400 g/cm^2
    assert delta[5] < 1023 - device.rest[8, 8] + 1  # never above full scale


def test_crosstalk_in_row_and_column_is_cancelled_by_k() -> None:
    press = one_cell(8, 8, 3.0)
    quiet = PatchDevice(IdlePatch(), seed=1, creep=0.0)
    device = PatchDevice(Press(press), seed=1, creep=0.0)
    base, hot = quiet.scan_counts(0, 0.0), device.scan_counts(0, 0.0)
    signal = (hot[8, 8] - base[8, 8]) / 1.06  # the pressed cell also gets 3 % from its row and its column
    assert (hot - base)[8, 2] == pytest.approx(0.03 * signal, rel=0.05)  # same row
    assert (hot - base)[3, 8] == pytest.approx(0.03 * signal, rel=0.05)  # same column
    assert (hot - base)[3, 3] == pytest.approx(0.0, abs=1e-9)
    cal = PatchCalibrator()
    for s in run(PatchDevice(IdlePatch(), seed=1, mode='averaged'), 20):
        cal.update(s.cells)
    pressed = PatchDevice(Press(press), seed=1, mode='averaged')
    out = cal.update(run(pressed, 1)[0].cells)
    assert out.activation[8, 8] > 0.8
    act = out.activation.copy()
    act[8, 8] = 0.08
    assert (act[OUTLINE] == np.float32(0.08)).all()  # "k = 0.08 cancels noise and crosstalk activations"


def test_creep_after_release_stays_below_k() -> None:
    script = PatchScript([PatchTouch(at=(6, 6), radius=1.0, pressure=5.0, start=1.0, duration=2.0)])
    device = PatchDevice(script, mode='averaged', seed=4)
    cal = PatchCalibrator()
    raw_after, act_after = [], []
    for s in run(device, 140):
        out = cal.update(s.cells)
        t = s.seq * device.frame_period
        if t > 3.2:
            raw_after.append(float(s.cells[6, 6]))
            act_after.append(float(out.activation[6, 6]))
    assert raw_after[0] - raw_after[-1] > 10  # the fabric relaxes slowly after the press (sympartner2018 5.3)
    assert max(act_after) == pytest.approx(0.08)  # ... which eq. (1) and k hide


def test_averaged_mode_frames() -> None:
    device = PatchDevice(IdlePatch(), mode='averaged', seed=3)
    assert device.frame_period == pytest.approx(0.05)
    wire = device.frame_bytes(0, 0.0)
    assert wire[3] == PATCH_FRAME_ID
    assert PatchDevice(IdlePatch()).frame_bytes(0, 0.0)[3] == PATCH_SCAN_ID
    scans = run(device, 40)
    cells = np.array([s.cells for s in scans], dtype=float)
    assert 0.6 < cells[:, OUTLINE].std(axis=0).mean() < 1.3  # 2 counts / sqrt(5), plus rounding
    assert not any(s.raw_scan for s in scans)


def test_faults_and_panels() -> None:
    device = PatchDevice(Press(panels=np.r_[1.0, np.zeros(10)]), seed=5,
                         faults={(2, 5): 'dead', (8, 8): 'saturated', (9, 9): 'stuck'}, dead_panels=[10])
    for s in run(device, 3):
        assert s.cells[2, 5] == 0 and s.cells[8, 8] == 1023 and s.cells[9, 9] == round(device.rest[9, 9])
        assert s.panels[10] == 0
        assert s.panels[0] == pytest.approx(device.panel_quiescent[0] + device.panel_span[0], abs=15)
    cal = PatchCalibrator()
    for s in run(device, 10):
        out = cal.update(s.cells)
    assert out.activation[2, 5] == out.activation[8, 8] == np.float32(0.08)  # dead and stuck-high read as untouched
    with pytest.raises(ValueError, match="did you mean 'dead'"):
        PatchDevice(IdlePatch(), faults={(1, 1): 'deed'})
    with pytest.raises(ValueError, match='outside'):
        PatchDevice(IdlePatch(), faults={(16, 1): 'dead'})


def test_bad_stimulus_output() -> None:
    nan = np.full((16, 16), np.nan)
    scan = run(PatchDevice(Press(nan), **CLEAN), 1)[0]
    assert np.array_equal(scan.cells[OUTLINE], np.rint(PatchDevice(IdlePatch()).rest[OUTLINE]))
    with pytest.raises(ValueError, match=r'must return \(16, 16\)'):
        PatchDevice(Press(np.zeros((8, 8)))).frame_bytes(0, 0.0)
    with pytest.raises(TypeError, match='pressure'):
        PatchDevice(object())
    with pytest.raises(ValueError, match="did you mean 'raw'"):
        PatchDevice(IdlePatch(), mode='rawr')


# ---------------------------------------------------------------------- through the URL
def test_url_modes_and_errors() -> None:
    port, clock = open_port('patchsim://m1')
    clock.t = 1.0
    scans = PatchDecoder().update(port.read(1 << 20))
    assert len(scans) == 101 and all(s.raw_scan for s in scans)
    port.close()
    port, clock = open_port('patchsim://m2?mode=averaged&dead=1:2,3:4&dead_panels=0')
    clock.t = 1.0
    scans = PatchDecoder().update(port.read(1 << 20))
    assert len(scans) == 21 and not any(s.raw_scan for s in scans)
    assert port.device.model.faults == {(1, 2): 'dead', (3, 4): 'dead'}
    port.close()
    with pytest.raises(SerialException, match='row:col'):
        serial.serial_for_url('patchsim://m3?dead=5')
    with pytest.raises(SerialException, match="did you mean 'mode'"):
        serial.serial_for_url('patchsim://m4?mdoe=raw')
    with pytest.raises(SerialException, match='not a bear'):
        register_stimulus('patch-test', IdlePatch())
        serial.serial_for_url('bearsim://m5?scene=patch-test')


def test_calibration_on_the_virtual_patch_with_garbage_and_panels() -> None:
    """Synthetic: 12 s of raw 100 Hz scans with a stroke, a push, a panel touch, garbage and corrupt bytes."""
    script = PatchScript([PatchTouch(at=(8, 2), to=(8, 13), radius=1.2, pressure=2.5, start=2.0, duration=1.5),
                          PatchTouch(at=(4, 6), radius=1.8, pressure=4.0, start=6.0, duration=3.0)],
                         [PanelTouch(panels=(4,), start=5.0, duration=2.0, level=1.0, ramp_s=0.05)])
    register_stimulus('patch-test', script)
    port, clock = open_port('patchsim://cal?scene=patch-test&seed=6&garbage=0.05&corrupt=0.02')
    dec, cal, panels = PatchDecoder(), PatchCalibrator(), PanelCalibrator(rate_hz=100.0, window_s=2.0)
    idle_max, stroke_cols, push_rows, contact_times = 0.0, [], [], []
    for step in range(1, 121):
        clock.t = step * 0.1
        for scan in dec.update(port.read(1 << 20)):
            t = scan.seq / 100
            if panels.update(scan.panels).contact[4]:
                contact_times.append(t)
            out = cal.update_scan(scan.cells)
            if out is None:
                continue
            act = out.activation
            touched = act > 0.08
            if t < 1.9 or 4.0 < t < 5.9:
                idle_max = max(idle_max, float(act.max()))
            if 2.2 < t < 3.3 and touched.any():
                stroke_cols.append(float(np.average(np.nonzero(touched)[1], weights=act[touched])))
            if 6.5 < t < 8.8:
                rows, cols = np.nonzero(touched)
                push_rows.append((rows.mean(), cols.mean(), float(act.max())))
    assert dec.stats.checksum_errors + dec.stats.length_errors > 0 and dec.stats.frames > 1100
    assert idle_max == pytest.approx(0.08)  # no activation without a touch
    assert stroke_cols[0] < 5 and stroke_cols[-1] > 10 and np.all(np.diff(stroke_cols) > -1)  # moves along the row
    assert all(abs(r - 4) < 1 and abs(c - 6) < 1 and m > 0.9 for r, c, m in push_rows)
    assert 5.0 <= contact_times[0] < 5.1 and 6.95 < contact_times[-1] <= 7.05  # panel contact, 10 ms scans
    port.close()


@pytest.mark.slow
def test_long_run_through_the_device_is_bounded_and_drift_free() -> None:
    """Synthetic: 10 minutes of averaged 20 Hz frames, untouched, resting state drifting (5 min periods)."""
    device = PatchDevice(IdlePatch(), mode='averaged', seed=8, drift_counts=8.0, drift_period_s=300.0)
    dec, cal = PatchDecoder(), PatchCalibrator()
    worst = 0.0
    gap = []
    for i in range(20 * 600):
        for scan in dec.update(device.frame_bytes(i, i * device.frame_period)):
            out = cal.update(scan.cells)
        worst = max(worst, float(out.activation.max()))
        assert dec.buffered < 356
        if i % 1200 == 0 and i:
            truth = device.rest + 8.0 * np.sin(device._omega * i * device.frame_period + device._phase)
            gap.append(float(np.abs(out.minimum - truth)[OUTLINE].max()))
    assert worst == pytest.approx(0.08)
    assert max(gap) < 12  # the minimum stays with the drifting rest: within the noise floor and the eq. (1) lag
