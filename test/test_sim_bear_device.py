"""The virtual bear: sensor model, scan timing, faults, the bearsim:// URL, and calibration on it."""

from __future__ import annotations

import numpy as np
import pytest
import serial
from serial.serialutil import SerialException
from sim_testing import open_port

import touch_sim  # noqa: F401  (registers the URL handlers)
from touch_driver.bear.body_map import BodyMap
from touch_driver.bear.calibration import FAULT_DEAD, FAULT_SATURATED, BearCalibrator
from touch_driver.bear.protocol import BearDecoder
from touch_sim.bear.device import BearDevice
from touch_sim.scenes import BearScript, BearTouch, IdleBear, register_stimulus, unregister_stimulus
from touch_sim.virtual_port import forget_devices

BODY = BodyMap.default()
FITTED = BODY.fitted_mask()


@pytest.fixture(autouse=True)
def _clean_registry():
    yield
    forget_devices()
    for name in ('bear-test', 'bear-step'):
        unregister_stimulus(name)


class Constant:
    def __init__(self, values: np.ndarray) -> None:
        self.values = np.asarray(values, dtype=np.float32)

    def proximity(self, t: float) -> np.ndarray:
        return self.values


class Step:
    """Everything jumps to full contact at t_step."""

    def __init__(self, t_step: float) -> None:
        self.t_step = t_step

    def proximity(self, t: float) -> np.ndarray:
        return np.full(64, 1.0 if t >= self.t_step else 0.0, dtype=np.float32)


def decode(device: BearDevice, n: int) -> list[np.ndarray]:
    dec = BearDecoder()
    out = [s.raw for i in range(n) for s in dec.update(device.frame_bytes(i, i * device.frame_period))]
    assert len(out) == n and dec.stats.dropped_bytes == 0
    return out


def test_untouched_counts_and_full_contact_saturates() -> None:
    quiet = np.array(decode(BearDevice(IdleBear(), seed=1), 20), dtype=float)
    assert (quiet[:, ~FITTED] == 0).all()  # unfitted inputs read 0
    assert (quiet[:, FITTED] > 60).all() and (quiet[:, FITTED] < 180).all()
    assert 1.0 < quiet[:, FITTED].std(axis=0).mean() < 3.5  # the noise, 2 counts
    full = np.array(decode(BearDevice(Constant(np.ones(64)), seed=1), 5))
    assert (full[:, FITTED] == 1023).all()  # direct touch saturates (knight2009 IV.D)


def test_sequential_scan_reads_channels_5_ms_apart() -> None:
    device = BearDevice(Step(0.1), rate_hz=3.4)
    offsets = device.slot_offsets[FITTED]
    assert np.allclose(np.diff(offsets), 0.005) and offsets[-1] == pytest.approx(55 * 0.005)
    seen = device.proximity_at(0.0)
    # Channels read at or after 100 ms into the scan see the touch, earlier ones do not.
    assert np.array_equal(seen[FITTED] == 1.0, offsets >= 0.1 - 1e-12)


def test_parallel_scan_and_squeezed_slots() -> None:
    parallel = BearDevice(IdleBear(), rate_hz=25, scan='parallel')
    assert np.allclose(parallel.slot_offsets[FITTED], (np.flatnonzero(FITTED) % 8) * 0.005)
    squeezed = BearDevice(IdleBear(), rate_hz=25, scan='sequential')
    assert squeezed.channel_dt_s == pytest.approx(0.04 / 56)
    assert squeezed.slot_offsets.max() < squeezed.frame_period


def test_crosstalk_reaches_neighbouring_inputs_only() -> None:
    touch = np.zeros(64)
    touch[1] = 0.5
    with_xt = np.array(decode(BearDevice(Constant(touch), crosstalk=0.05, noise=0, drift_counts=0), 3), dtype=float)
    without = np.array(decode(BearDevice(Constant(touch), crosstalk=0.0, noise=0, drift_counts=0), 3), dtype=float)
    extra = (with_xt - without)[0]
    device = BearDevice(Constant(touch), noise=0)
    assert extra[0] == pytest.approx(0.05 * 0.5 * device.span[1], abs=1)
    assert extra[2] == pytest.approx(0.05 * 0.5 * device.span[1], abs=1)
    assert not extra[np.r_[3:64]].any()


def test_faults_and_determinism() -> None:
    device = BearDevice(Constant(np.full(64, 0.5)), faults={'ear_left': 'dead', 5: 'saturated', 'cheek_left': 'stuck'})
    a, b = device.frame_bytes(7, 0.7), device.frame_bytes(7, 0.7)
    assert a == b  # noise depends on (seed, index) only
    raw = decode(device, 4)
    for r in raw:
        assert r[4] == 0 and r[5] == 1023 and r[6] == round(device.baseline[6])
    assert BearDevice(IdleBear(), seed=2).frame_bytes(0, 0) != BearDevice(IdleBear(), seed=3).frame_bytes(0, 0)
    with pytest.raises(ValueError, match="did you mean 'dead'"):
        BearDevice(IdleBear(), faults={1: 'daed'})
    with pytest.raises(ValueError, match="did you mean 'ear_left'"):
        BearDevice(IdleBear(), faults={'ear_lft': 'dead'})


def test_bad_stimulus_output() -> None:
    nan = np.full(64, np.nan)
    raw = decode(BearDevice(Constant(nan), noise=0, drift_counts=0), 1)[0]
    assert np.array_equal(raw[FITTED], np.rint(BearDevice(IdleBear()).baseline[FITTED]))  # NaN read as no touch
    with pytest.raises(ValueError, match=r'must return \(64,\)'):
        BearDevice(Constant(np.zeros(10))).frame_bytes(0, 0)
    with pytest.raises(TypeError, match='proximity'):
        BearDevice(object())
    with pytest.raises(ValueError, match='rate_hz'):
        BearDevice(IdleBear(), rate_hz=0)


# ---------------------------------------------------------------------- through the URL
def test_url_streams_frames_on_the_attached_clock() -> None:
    register_stimulus('bear-step', Step(0.5))
    port, clock = open_port('bearsim://u1?scene=bear-step&rate=25&scan=parallel&seed=4')
    dec = BearDecoder()
    clock.t = 2.0
    scans = dec.update(port.read(1 << 20))
    assert len(scans) == 51 and [s.seq for s in scans] == list(range(51))  # frames at 0, 0.04, ..., 2.0
    assert scans[5].raw[0] < 200 and scans[20].raw[0] == 1023
    port.close()
    port.close()  # safe twice


def test_url_options_and_errors() -> None:
    with pytest.raises(SerialException, match="did you mean 'noise'"):
        serial.serial_for_url('bearsim://e1?nosie=3')
    with pytest.raises(SerialException, match='no registered stimulus'):
        serial.serial_for_url('bearsim://e2?scene=nobody')
    with pytest.raises(SerialException, match='must be a float'):
        serial.serial_for_url('bearsim://e3?rate=fast')
    with pytest.raises(SerialException, match="did you mean 'head2'"):
        serial.serial_for_url('bearsim://e4?dead=hed2')
    port = serial.serial_for_url('bearsim://e5?dead=head2,7&noise=0&rate=10')
    assert port.device.model.faults == {1: 'dead', 7: 'dead'} and port.device.model.rate_hz == 10
    port.close()


def test_calibration_on_the_virtual_bear_with_garbage_and_faulty_sensors() -> None:
    """Synthetic: 60 s at 25 Hz, touches on the head and the left foot, a dead and a saturated sensor,
    garbage, corrupted bytes and lost frames in the stream."""
    touches = [BearTouch(channels=tuple(BODY.channels(['head1', 'head2'])), start=10, duration=8, level=1.0),
               BearTouch(channels=tuple(BODY.channels(['foot_left_sole'])), start=30, duration=10, level=0.7,
                         envelope='pulse', freq_hz=1.0, duty=0.6)]
    register_stimulus('bear-test', BearScript(touches))
    port, clock = open_port('bearsim://cal?scene=bear-test&rate=25&scan=parallel&seed=5'
                            '&dead=ear_left&saturated=belly_middle&garbage=0.2&corrupt=0.05&drop=0.03')
    dec, cal = BearDecoder(), BearCalibrator(rate_hz=25, fault_after_s=5, saturated_after_s=20)
    head, sole, dead, sat = (BODY.by_name(n).channel for n in ('head2', 'foot_left_sole', 'ear_left', 'belly_middle'))
    false_active, head_active, sole_levels = 0, [], []
    for step in range(1, 61 * 4):
        clock.t = step * 0.25
        for scan in dec.update(port.read(1 << 16)):
            out = cal.update(scan.raw)
            t = scan.seq / 25
            others = out.active.copy()
            others[[0, 1, head, sole]] = False
            false_active += int(others.any())
            if 11 <= t <= 17:
                head_active.append(bool(out.active[head]))
            if 30.2 <= t <= 39.8:
                sole_levels.append(float(out.level[sole]))
    assert dec.stats.checksum_errors + dec.stats.length_errors > 0 and dec.stats.dropped_bytes > 0
    assert dec.stats.frames > 0.85 * 60 * 25 and dec.stats.sequence_gaps > 0
    assert false_active == 0
    assert all(head_active) and len(head_active) > 100
    levels = np.array(sole_levels)
    assert 0.55 < levels.max() < 0.85 and levels.min() < 0.1  # pulses of 0.7 (level maps to proximity)
    assert out.faults[dead] == FAULT_DEAD and out.faults[sat] & FAULT_SATURATED
    port.close()


def test_unplug_and_replug() -> None:
    port, clock = open_port('bearsim://plug?rate=10&unplug_at=1.0&replug_at=2.0')
    dec = BearDecoder()
    clock.t = 0.95
    assert len(dec.update(port.read(1 << 16))) == 10
    clock.t = 1.5
    with pytest.raises(SerialException):
        port.read(1)
    with pytest.raises(SerialException):
        port.open()
    clock.t = 2.5
    port.open()
    dec.reset()  # as a driver does after a reconnect
    scans = dec.update(port.read(1 << 16))
    assert scans and scans[-1].seq == 25
    port.close()


def test_long_run_bounded_and_drift_free() -> None:
    """Synthetic: one hour at 3.4 Hz with baseline drift (10 min periods); nothing touched."""
    device = BearDevice(IdleBear(), rate_hz=3.4, scan='parallel', seed=9, drift_counts=10, drift_period_s=600)
    dec, cal = BearDecoder(), BearCalibrator(rate_hz=3.4, drift_tau_s=60)
    sizes = None
    worst = 0.0
    n = int(3600 * 3.4)
    for i in range(n):
        for scan in dec.update(device.frame_bytes(i, i * device.frame_period)):
            out = cal.update(scan.raw)
        if i == 100:
            sizes = {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)}
        if i > 100:
            worst = max(worst, float(out.level.max()))
        assert dec.buffered < 142  # at most a trailing partial sync byte between frames
    assert not out.active.any() and worst < 0.3 * 0.5
    assert {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)} == sizes
    t_end = (n - 1) * device.frame_period
    truth = device.baseline + 10 * np.sin(device._drift_omega * (t_end + device.slot_offsets) + device._drift_phase)
    assert np.abs(cal.baseline - truth)[FITTED].max() < 8  # tracked within the noise and the filter lag
