"""BearCalibrator on arrays: baseline and gain, threshold, faults, NaN, drift, bounded state."""

from __future__ import annotations

import textwrap
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_driver.bear.body_map import BodyMap
from touch_driver.bear.calibration import FAULT_DEAD, FAULT_INVALID, FAULT_SATURATED, FAULT_STUCK, BearCalibrator
from touch_graph.errors import ConfigError

BODY = BodyMap.default()
FITTED = BODY.fitted_mask()
rng = np.random.default_rng(7)


def quiet(base: float = 100.0, noise: float = 2.0) -> np.ndarray:
    return np.where(FITTED, base + rng.normal(0, noise, 64), 0.0).round()


def learned(frames: int = 10, **kwargs) -> BearCalibrator:
    cal = BearCalibrator(baseline_frames=frames, **kwargs)
    for i in range(frames):
        out = cal.update(quiet())
        assert not out.active.any() and (out.level < 0.02).all()
        if i < frames - 1:
            assert not out.level.any()  # no level before the baseline is known
    assert cal.ready and out.ready
    return cal


def test_learned_baseline_spans_zero_to_one() -> None:
    cal = learned()
    assert np.allclose(cal.baseline[FITTED], 100.0, atol=3)
    raw = quiet()
    raw[1] = 1023  # full direct touch saturates the sensor: level 1
    raw[2] = 100 + 0.5 * (1023 - 100)
    raw[3] = 100 + 0.2 * (1023 - 100)
    out = cal.update(raw)
    assert out.level.dtype == np.float32 and out.level[1] == pytest.approx(1.0, abs=0.01)
    assert out.level[2] == pytest.approx(0.5, abs=0.01) and out.level[3] == pytest.approx(0.2, abs=0.01)
    assert out.active[[1, 2]].all() and not out.active[3]  # 30 % threshold (knight2009 V.A)
    assert not out.level[~FITTED].any() and not out.active[~FITTED].any()
    assert out.raw.dtype == np.uint16 and out.raw[1] == 1023
    assert np.array_equal(out.fitted, FITTED)


def test_median_baseline_tolerates_a_touch_at_start_up() -> None:
    cal = BearCalibrator(baseline_frames=9)
    for i in range(9):
        raw = quiet()
        if i in (2, 3, 4):
            raw[5] = 900  # someone brushes the right ear while the bear starts
        cal.update(raw)
    assert cal.baseline[5] == pytest.approx(100, abs=5)


def test_configured_baseline_and_gain_and_threshold() -> None:
    cal = BearCalibrator(baseline=200.0, gain=1 / 400, threshold=0.5)
    assert cal.ready
    raw = np.where(FITTED, 200.0, 0.0)
    raw[0], raw[1] = 400, 420  # levels 0.5 and 0.55
    out = cal.update(raw)
    assert out.level[0] == pytest.approx(0.5) and out.active[0] and out.active[1]
    raw[0] = 399
    assert not cal.update(raw).active[0]


def test_dead_saturated_and_stuck_sensors_are_flagged_and_masked() -> None:
    cal = learned(rate_hz=10.0, fault_after_s=3.0, saturated_after_s=3.0)  # 30 frames without variation
    for i in range(40):
        raw = quiet()
        raw[4], raw[5], raw[6] = 0, 1023, 321  # dead ear, a sensor stuck at full scale, one stuck mid-range
        out = cal.update(raw)
        if i < 25:
            assert out.faults[4] == 0 and out.level[5] == pytest.approx(1.0, abs=0.01)
    assert out.faults[4] == FAULT_DEAD and out.faults[5] == FAULT_SATURATED and out.faults[6] == FAULT_STUCK
    assert out.level[[4, 5, 6]].tolist() == [0, 0, 0] and not out.active[[4, 5, 6]].any()
    assert not out.faults[np.r_[0:4, 7:64]].any()
    # The sensor comes back to life: the flag clears at once.
    raw = quiet()
    raw[5] = 800
    out = cal.update(raw)
    assert out.faults[5] == 0 and out.active[5]


def test_a_saturated_hold_is_not_a_fault_until_much_later() -> None:
    cal = learned(rate_hz=10.0, fault_after_s=3.0, saturated_after_s=20.0)
    for i in range(250):
        raw = quiet()
        raw[0], raw[1] = 1023, 0  # a long full-contact hold on head1; head2 dead
        out = cal.update(raw)
        if i == 100:  # 10 s: the dead sensor is flagged, the hold is still a hold
            assert out.faults[1] == FAULT_DEAD and out.faults[0] == 0 and out.active[0]
    assert out.faults[0] == FAULT_SATURATED and not out.active[0]


def test_unmasked_faults_are_only_reported() -> None:
    cal = learned(rate_hz=10.0, fault_after_s=1.0, saturated_after_s=1.0, mask_faults=False)
    for _ in range(15):
        raw = quiet()
        raw[5] = 1023
        out = cal.update(raw)
    assert out.faults[5] == FAULT_SATURATED and out.active[5]


def test_baseline_at_the_rail_gives_gain_zero_not_a_division_by_zero() -> None:
    cal = BearCalibrator(baseline_frames=3)
    for _ in range(3):
        raw = quiet()
        raw[7] = 1023  # saturated from power-up: no room above the baseline
        out = cal.update(raw)
    assert cal.gain[7] == 0.0 and out.faults[7] & FAULT_SATURATED
    assert np.isfinite(out.level).all() and out.level[7] == 0


def test_nan_and_out_of_range_samples_are_counted_and_skipped() -> None:
    cal = BearCalibrator(baseline_frames=4)
    for i in range(8):
        raw = quiet()
        raw[0] = np.nan if i % 2 else raw[0]
        raw[1] = np.inf
        raw[2] = -5
        raw[3] = 5000
        out = cal.update(raw)
    assert cal.invalid_samples == 4 + 3 * 8
    assert out.faults[1] & FAULT_INVALID and out.level[1] == 0 and out.raw[1] == 0
    assert cal._has_baseline[0] and not cal._has_baseline[1]  # channel 0 learned from its 4 valid samples
    assert not cal.ready and not out.ready
    assert cal.baseline[0] == pytest.approx(100, abs=5)


def test_drift_is_followed_but_a_touch_is_not_learned() -> None:
    cal = learned(rate_hz=10.0, drift_tau_s=5.0)
    for i in range(600):  # 60 s: baseline creeps up by 30 counts
        raw = quiet(base=100 + 0.05 * i)
        raw[9] = 700  # a hold on the mouth all along
        out = cal.update(raw)
    assert cal.baseline[8] == pytest.approx(130, abs=4)
    assert cal.baseline[9] == pytest.approx(100, abs=3)
    assert out.level[9] == pytest.approx((700 - cal.baseline[9]) * cal.gain[9], abs=1e-3) and out.active[9]
    assert out.level[8] < 0.05


def test_state_is_bounded_on_a_long_run() -> None:
    cal = learned()
    sizes = {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)}
    for _ in range(3000):
        cal.update(quiet())
    assert {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)} == sizes
    cal.reset()
    assert not cal.ready and cal.frames == 0


def test_argument_errors() -> None:
    with pytest.raises(ValueError, match='shape'):
        BearCalibrator().update(np.zeros(56))
    with pytest.raises(ValueError, match='threshold'):
        BearCalibrator(threshold=0)
    with pytest.raises(ValueError, match='baseline'):
        BearCalibrator(baseline=np.zeros(3))
    with pytest.raises(ValueError, match='fitted'):
        BearCalibrator(fitted=np.ones(8, dtype=bool))


@settings(max_examples=60, deadline=None)
@given(st.lists(arrays(np.float64, (64,), elements=st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(0, 1023).map(float))), min_size=1, max_size=15))
def test_any_input_gives_valid_levels(frames: list[np.ndarray]) -> None:
    cal = BearCalibrator(baseline_frames=2, rate_hz=10.0, fault_after_s=0.5, saturated_after_s=0.5)
    for raw in frames:
        out = cal.update(raw)
        assert out.level.dtype == np.float32 and np.isfinite(out.level).all()
        assert (out.level >= 0).all() and (out.level <= 1).all()
        assert np.array_equal(out.active, out.level >= 0.3)
        assert not out.level[~FITTED].any()


def test_from_yaml(tmp_path: Path) -> None:
    path = tmp_path / 'cal.yaml'
    names = {s.name: 150 for s in BODY}
    lines = '\n'.join(f'  {n}: {v}' for n, v in names.items())
    path.write_text(f'threshold: 0.4\nbaseline:\n{lines}\ngain:\n  head1: 0.01\n')
    cal = BearCalibrator.from_yaml(path)
    assert cal.threshold == 0.4 and cal.ready
    assert cal.gain[0] == 0.01 and cal.gain[1] == pytest.approx(1 / (1023 - 150))
    path.write_text(textwrap.dedent('''\
        threshold: 0.3
        gain:
          head1: 0.01
          hed2: 0.02
        '''))
    with pytest.raises(ConfigError, match="did you mean 'head2'") as err:
        BearCalibrator.from_yaml(path)
    assert err.value.line == 4
    path.write_text('treshold: 0.3\n')
    with pytest.raises(ConfigError, match="did you mean 'threshold'"):
        BearCalibrator.from_yaml(path)
    path.write_text('baseline:\n  head1: 100\n')
    with pytest.raises(ConfigError, match='missing: head2'):
        BearCalibrator.from_yaml(path)
