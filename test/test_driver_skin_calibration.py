"""Skin calibration on hand-made frames: tare, pressure, contact hysteresis, centroid, forces, faults, config."""

from __future__ import annotations

import dataclasses
import textwrap

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from touch_driver.skin.calibration import SkinCalibrator, calibrate_frames
from touch_driver.skin.calibration_config import SkinCalibrationConfig, load_skin_calibration
from touch_driver.skin.protocol import MODULE_TAXELS, TAXEL_XY_MM
from touch_graph.errors import ConfigError
from touch_sim.skin.contact import FingerContactModel

REST = 40000
FS = 16000  # default full_scale_counts


def idx(row: int, col: int) -> int:
    return row * 12 + col


def rest(noise: float = 0.0, seed: int = 0) -> np.ndarray:
    frame = np.full(144, float(REST))
    if noise:
        frame += np.random.default_rng(seed).normal(0, noise, 144)
    return np.rint(frame).astype(np.uint16)


def tared(config: SkinCalibrationConfig | None = None, frame: np.ndarray | None = None) -> SkinCalibrator:
    """A calibrator tared on ``frame`` (default: flat rest), with stuck detection off (noiseless frames)."""
    cal = SkinCalibrator(config or SkinCalibrationConfig(tare_s=2 / 150, stuck_s=0))
    while not cal.tared:
        cal.update(rest() if frame is None else frame)
    return cal


def pressed(*taxels: tuple[int, float], base: np.ndarray | None = None) -> np.ndarray:
    """Rest frame plus ``pressure`` (fraction of full scale) on taxels given as (index, pressure)."""
    frame = (rest() if base is None else base).astype(np.int64)
    for i, p in taxels:
        frame[i] += round(p * FS)
    return np.clip(frame, 0, 65535).astype(np.uint16)


def test_outputs_are_zero_until_tared():
    cal = SkinCalibrator(SkinCalibrationConfig(tare_s=3 / 150, stuck_s=0))
    for _ in range(2):
        s = cal.update(rest())
        assert not s.tared and not s.contact and np.isnan(s.contact_xy_mm).all()
        assert s.pressure.shape == (12, 12) and s.pressure.dtype == np.float32 and not s.pressure.any()
    s = cal.update(rest())
    assert not s.tared and cal.tared
    s = cal.update(rest())
    assert s.tared and not s.contact and not s.pressure.any() and s.total_force == 0
    assert s.force.shape == (36, 3) and s.force.dtype == np.float32
    assert cal.baseline == pytest.approx(np.full(144, REST))


def test_pressure_is_normalised_and_clipped():
    cal = tared()
    s = cal.update(pressed((idx(3, 4), 0.1), (idx(8, 8), -0.05)))
    assert s.pressure[3, 4] == pytest.approx(0.1, abs=1e-4)
    assert s.pressure[8, 8] == 0.0 and (s.pressure >= 0).all()
    s = cal.update(pressed((idx(3, 4), 1.5)))
    assert s.pressure[3, 4] == pytest.approx(1.5, abs=1e-4)        # above full scale is allowed


def test_contact_has_hysteresis():
    cal = tared()
    c = cal.config
    seq = [0.9 * c.contact_on, 1.1 * c.contact_on, 0.5 * (c.contact_on + c.contact_off), 0.9 * c.contact_off,
           0.5 * (c.contact_on + c.contact_off)]
    got = [cal.update(pressed((idx(6, 6), p))).contact for p in seq]
    assert got == [False, True, True, False, False]


def test_contact_point_is_the_pressure_weighted_centroid():
    cal = tared()
    s = cal.update(pressed((idx(5, 7), 0.5)))
    assert s.contact_xy_mm == pytest.approx(TAXEL_XY_MM[idx(5, 7)], abs=1e-4)
    s = cal.update(pressed((idx(5, 7), 0.3), (idx(5, 8), 0.3)))
    assert s.contact_xy_mm == pytest.approx((TAXEL_XY_MM[idx(5, 7)] + TAXEL_XY_MM[idx(5, 8)]) / 2, abs=1e-4)


def test_two_fingers_give_a_point_between_them():
    # Documented behaviour: the recogniser, not the driver, deals with two fingers.
    cal = tared()
    a, b = idx(2, 2), idx(9, 9)
    s = cal.update(pressed((a, 0.2), (b, 0.6)))
    floor = cal.config.centroid_floor
    wa, wb = 0.2 - floor, 0.6 - floor
    expect = (wa * TAXEL_XY_MM[a] + wb * TAXEL_XY_MM[b]) / (wa + wb)
    assert s.contact_xy_mm == pytest.approx(expect, abs=1e-3)


def test_module_force_uses_its_calibration_matrix():
    cal = tared()
    m = 14                                           # rows 4-5, cols 4-5
    tl, tr, bl, br = MODULE_TAXELS[m]
    s = cal.update(pressed((tl, 0.1), (tr, 0.3), (bl, 0.1), (br, 0.3)))
    fx, fy, fz = s.force[m]
    k = cal.config.force_matrices[m]
    assert fz == pytest.approx(k[2] @ [0.1, 0.3, 0.1, 0.3], rel=1e-3) and fz > 0
    assert fx == pytest.approx(k[0] @ [0.1, 0.3, 0.1, 0.3], rel=1e-3) and fx > 0     # right side pressed more
    assert fy == pytest.approx(0, abs=1e-4)
    assert s.total_force == pytest.approx(float(s.force[:, 2].sum()), rel=1e-5)
    others = np.delete(s.force, m, axis=0)
    assert not others.any()                          # neighbours are unloaded, so exactly zero


def test_no_contact_gives_nan_point_and_zero_force():
    cal = tared()
    s = cal.update(pressed((idx(1, 1), 0.5 * cal.config.contact_on)))
    assert not s.contact and np.isnan(s.contact_xy_mm).all() and not s.force.any() and s.total_force == 0


def test_all_zero_frame_is_all_dead_not_a_crash():
    cal = tared()
    s = cal.update(np.zeros(144, dtype=np.uint16))
    assert s.dead.all() and not s.contact and not s.pressure.any() and np.isnan(s.contact_xy_mm).all()
    assert np.isfinite(s.force).all()
    s = cal.update(rest())                           # the taxels come back
    assert not s.dead.any()


def test_dead_taxel_is_excluded_and_flagged():
    cal = tared()
    frame = pressed((idx(4, 4), 0.2))
    frame[idx(7, 7)] = 3                             # no light: dead, even though far below baseline
    s = cal.update(frame)
    assert s.dead[idx(7, 7)] and s.dead.sum() == 1 and s.pressure[7, 7] == 0
    assert s.contact_xy_mm == pytest.approx(TAXEL_XY_MM[idx(4, 4)], abs=1e-4)


def test_taxel_dead_during_tare_stays_dead():
    frame = rest()
    frame[idx(0, 11)] = 0
    cal = tared(frame=frame)
    s = cal.update(pressed((idx(0, 11), 0.5)))       # even if it comes back later, it has no baseline
    assert s.dead[idx(0, 11)] and not s.contact
    cal.retare()
    assert not cal.tared


def test_stuck_taxel_is_detected():
    config = SkinCalibrationConfig(tare_s=2 / 150, stuck_s=10 / 150)
    cal = SkinCalibrator(config)
    flags = []
    for k in range(40):
        frame = rest(noise=25, seed=k)
        frame[idx(6, 2)] = 41234                     # frozen ADC reading, 0.08 above the baseline
        flags.append(cal.update(frame).dead[idx(6, 2)])
    assert not any(flags[:9]) and all(flags[20:])    # found within two windows of stuck_s
    s = cal.update(rest(noise=25, seed=99))
    assert not s.contact and s.pressure[6, 2] == 0


def test_saturated_taxel_under_a_press_is_kept_and_flagged():
    cal = tared(SkinCalibrationConfig(tare_s=2 / 150, stuck_s=5 / 150))
    r, c = 6, 6
    for k in range(20):
        frame = pressed((idx(r, c), 2.0), (idx(r, c + 1), 0.5), (idx(r + 1, c), 0.4), base=rest(25, seed=k))
        frame[idx(r, c)] = 65535
        s = cal.update(frame)
    assert s.saturated[idx(r, c)] and not s.dead[idx(r, c)] and s.pressure[r, c] > 1.0


def test_isolated_saturated_taxel_is_dead():
    cal = tared(SkinCalibrationConfig(tare_s=2 / 150, stuck_s=5 / 150))
    for k in range(20):
        frame = rest(25, seed=k)
        frame[idx(2, 9)] = 65535                     # a shorted phototransistor, alone at full scale
        s = cal.update(frame)
    assert s.saturated[idx(2, 9)] and s.dead[idx(2, 9)] and not s.contact and s.pressure[2, 9] == 0


def test_touch_during_tare_is_undone_after_release():
    finger = pressed((idx(5, 5), 0.3), (idx(5, 6), 0.2))
    cal = tared(SkinCalibrationConfig(tare_s=5 / 150, stuck_s=0), frame=finger)
    s = cal.update(rest())
    assert not s.contact                             # reads below its baseline: never a press
    for _ in range(10 * 150):           # recover_tau_s = 0.5 s down to -drift_gate, then drift_tau_s = 5 s
        cal.update(rest())
    assert cal.baseline[idx(5, 5)] == pytest.approx(REST, abs=40)
    s = cal.update(pressed((idx(5, 5), 0.1)))
    assert s.contact and s.pressure[5, 5] == pytest.approx(0.1, abs=3e-3)


def test_non_finite_float_input_is_counted_not_propagated():
    cal = tared()
    frame = pressed((idx(3, 3), 0.2)).astype(np.float64)
    frame[[0, 50]] = np.nan
    frame[60] = np.inf
    frame[61] = -5
    s = cal.update(frame)
    assert cal.invalid_values == 4
    assert s.dead[[0, 50, 60, 61]].all() and np.isfinite(s.pressure).all() and np.isfinite(s.force).all()
    assert s.contact and s.contact_xy_mm == pytest.approx(TAXEL_XY_MM[idx(3, 3)], abs=1e-3)


def test_bad_frames_raise_clear_errors():
    cal = tared()
    with pytest.raises(ValueError, match=r'shape \(144,\) or \(12, 12\); got \(143,\)'):
        cal.update(np.zeros(143, dtype=np.uint16))
    with pytest.raises(ValueError, match='uint16 ADC counts'):
        cal.update(np.array(['x'] * 144))
    assert cal.update(rest().reshape(12, 12)).tared


def test_inverted_hardware():
    config = SkinCalibrationConfig(tare_s=2 / 150, stuck_s=0, invert=True)
    cal = tared(config, frame=(65535 - rest()).astype(np.uint16))
    frame = (65535 - pressed((idx(9, 1), 0.25)).astype(np.int64)).astype(np.uint16)
    s = cal.update(frame)
    assert s.pressure[9, 1] == pytest.approx(0.25, abs=1e-4)


@settings(max_examples=50, deadline=None)
@given(hnp.arrays(np.uint16, 144, elements=st.integers(0, 65535)))
def test_any_frame_gives_finite_bounded_outputs(frame):
    cal = tared(SkinCalibrationConfig(tare_s=2 / 150, stuck_s=2 / 150), frame=rest(25))
    for _ in range(3):
        s = cal.update(frame)
        assert np.isfinite(s.pressure).all() and (s.pressure >= 0).all()
        assert np.isfinite(s.force).all() and np.isfinite(s.total_force)
        xy = s.contact_xy_mm
        assert np.isnan(xy).all() or (np.isfinite(xy).all() and (xy >= 0).all() and (xy <= 47).all())
        if not s.contact:
            assert np.isnan(xy).all() and not s.force.any()


def test_calibrate_frames_stacks_states():
    frames = np.stack([rest()] * 3 + [pressed((idx(1, 2), 0.2))])
    out = calibrate_frames(frames, SkinCalibrationConfig(tare_s=2 / 150, stuck_s=0))
    assert out.pressure.shape == (4, 12, 12) and out.force.shape == (4, 36, 3) and out.contact_xy_mm.shape == (4, 2)
    assert out.tared.tolist() == [False, False, True, True] and out.contact.tolist() == [False] * 3 + [True]
    with pytest.raises(ValueError, match=r'\(n, 144\)'):
        calibrate_frames(np.zeros(144))


# ---------------------------------------------------------------------- configuration
def test_shipped_yaml_equals_the_dataclass_defaults():
    loaded, default = load_skin_calibration(), SkinCalibrationConfig()
    for f in dataclasses.fields(SkinCalibrationConfig):
        a, b = getattr(loaded, f.name), getattr(default, f.name)
        if isinstance(a, np.ndarray):
            assert np.allclose(a, b), f.name
        else:
            assert a == b, f.name


def test_shipped_force_matrix_is_derived_from_the_contact_model():
    config = load_skin_calibration()
    derived = FingerContactModel().force_matrix(config.full_scale_counts)
    assert np.allclose(config.force_matrices, derived, atol=1e-6)


def write(tmp_path, text: str):
    path = tmp_path / 'cal.yaml'
    path.write_text(textwrap.dedent(text))
    return path


MATRIX = '[[-1, 1, -1, 1], [-1, -1, 1, 1], [2, 2, 2, 2]]'


def test_module_override(tmp_path):
    path = write(tmp_path, f"""\
        format_version: 1
        force:
          default: {MATRIX}
          modules:
            7: [[0, 0, 0, 0], [0, 0, 0, 0], [3, 3, 3, 3]]
        """)
    config = load_skin_calibration(path)
    assert config.force_matrices[7, 2].tolist() == [3] * 4 and config.force_matrices[6, 2].tolist() == [2] * 4
    assert config.contact_on == SkinCalibrationConfig().contact_on      # absent keys keep their defaults


@pytest.mark.parametrize(('text', 'line', 'message'), [
    (f'format_version: 1\nforce: {{default: {MATRIX}}}\ncontact:\n  threshold_onn: 0.1\n', 4,
     "unknown key 'threshold_onn'.*did you mean 'threshold_on'"),
    (f'format_version: 1\nforce: {{default: {MATRIX}}}\ndrift:\n  tau_s: fast\n', 4, "'tau_s'.*must be float"),
    ('format_version: 1\nforce:\n  default: [[1, 2], [3, 4]]\n', 3, '3 rows'),
    (f'format_version: 1\nforce:\n  default: {MATRIX}\n  modules:\n    36: {MATRIX}\n', 5, 'module index 0..35'),
    (f'format_version: 2\nforce: {{default: {MATRIX}}}\n', 1, 'format_version 2'),
    (f'format_version: 1\nforce: {{default: {MATRIX}}}\ncontact: {{threshold_on: 0.01, threshold_off: 0.02}}\n',
     None, 'contact_off <= contact_on'),
])
def test_config_errors_name_file_and_line(tmp_path, text, line, message):
    path = write(tmp_path, text)
    with pytest.raises(ConfigError, match=message) as info:
        load_skin_calibration(path)
    assert info.value.path == str(path)
    assert info.value.line == line


def test_bad_config_values_raise_value_error():
    with pytest.raises(ValueError, match='full_scale_counts'):
        SkinCalibrationConfig(full_scale_counts=0)
    with pytest.raises(ValueError, match=r'\(36, 3, 4\)'):
        SkinCalibrationConfig(force_matrices=np.zeros((36, 3, 3)))
