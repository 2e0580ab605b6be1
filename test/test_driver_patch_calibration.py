"""PatchCalibrator: eq. (1) running minimum, eq. (2) activation, averaging, outline, NaN, long runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.patch.calibration import PatchCalibrator, ScanAverager, load_outline
from touch_graph.errors import ConfigError

ALL = np.ones((16, 16), dtype=bool)


def frame(value: float) -> np.ndarray:
    return np.full((16, 16), value, dtype=np.float64)


# ---------------------------------------------------------------------- outline
def test_default_outline() -> None:
    mask = load_outline()
    assert mask.shape == (16, 16) and mask.dtype == bool and mask.sum() == 210
    assert not mask[0, 0] and mask[8, 8] and mask[0, 4] and not mask[15, 4]


def test_outline_errors(tmp_path: Path) -> None:
    path = tmp_path / 'outline.yaml'
    rows = ['#' * 16] * 16
    rows[3] = '#' * 15 + 'x'
    path.write_text('outline:\n' + ''.join(f'  - "{r}"\n' for r in rows))
    with pytest.raises(ConfigError, match="outline row 3 must be 16 characters of '#'") as err:
        load_outline(path)
    assert err.value.line == 5
    path.write_text('grid: [8, 8]\noutline: []\n')
    with pytest.raises(ConfigError, match=r'grid must be \[16, 16\]'):
        load_outline(path)
    path.write_text('outline:\n' + '  - "................"\n' * 16)
    with pytest.raises(ConfigError, match='no cell inside'):
        load_outline(path)
    path.write_text('outlines: []\n')
    with pytest.raises(ConfigError, match="did you mean 'outline'"):
        load_outline(path)


# ---------------------------------------------------------------------- equations
def test_eq1_and_eq2_by_hand() -> None:
    cal = PatchCalibrator(outline=ALL, gain=0.01, tau=0.5, k=0.08)
    expect_m = [100.0, 90.0, 92.5, 106.25]  # start; down at once; up by tau of the gap; again
    expect_r = [0.08, 0.08, 0.08, 0.1375]   # min(max(g (a - m), k), 1)
    for a, m, r in zip([100, 90, 95, 120], expect_m, expect_r, strict=True):
        out = cal.update(frame(a))
        assert out.minimum[3, 4] == pytest.approx(m) and out.activation[3, 4] == pytest.approx(r)
    out = cal.update(frame(1000))
    assert out.activation[0, 0] == 1.0  # clipped at 1
    assert out.activation.dtype == np.float32 and out.raw.dtype == np.uint16 and out.raw[0, 0] == 1000


def test_outline_masks_cells_and_gain_is_per_cell() -> None:
    mask = load_outline()
    gain = np.full((16, 16), 1 / 400)
    gain[8, 8] = 1 / 200
    cal = PatchCalibrator(outline=mask, gain=gain)
    cal.update(frame(50))
    out = cal.update(frame(250))  # 200 counts above the minimum... which eq. (1) raises by tau * 200
    m = 50 + 0.001 * 200
    assert out.activation[8, 8] == pytest.approx(min(1.0, (250 - m) / 200), abs=1e-5)
    assert out.activation[8, 9] == pytest.approx((250 - m) / 400, abs=1e-5)
    assert not out.activation[~mask].any() and (out.activation[mask] >= 0.08).all()
    assert np.array_equal(out.in_outline, mask)


def test_a_held_press_fades_at_the_documented_rate_and_release_is_instant() -> None:
    tau = 0.001
    cal = PatchCalibrator(outline=ALL, tau=tau, gain=1 / 400)
    for _ in range(20):
        cal.update(frame(50))
    first = cal.update(frame(350)).activation[0, 0]
    for _ in range(59):  # a 3 s push at 20 Hz
        last = cal.update(frame(350)).activation[0, 0]
    assert last / first == pytest.approx((1 - tau) ** 59, rel=1e-3)  # about 6 % lost (module docstring)
    out = cal.update(frame(50))  # release: the minimum drops to the signal at once
    assert out.minimum[0, 0] == pytest.approx(50) and out.activation[0, 0] == pytest.approx(0.08)


def test_nan_and_out_of_range_cells_are_counted_and_skipped() -> None:
    cal = PatchCalibrator(outline=ALL)
    cal.update(frame(50))
    bad = frame(300)
    bad[0, 0], bad[0, 1], bad[0, 2] = np.nan, -1, 2000
    out = cal.update(bad)
    assert out.invalid_cells == 3 and cal.invalid_cells == 3
    assert out.activation[0, :3].tolist() == pytest.approx([0.08] * 3)
    assert out.minimum[0, 0] == 50 and out.raw[0, 0] == 0
    assert out.activation[0, 3] > 0.5
    # A cell that never had a valid sample starts when its first one arrives.
    cal = PatchCalibrator(outline=ALL)
    first = frame(np.nan)
    out = cal.update(first)
    assert (out.activation == 0.08).all() and out.invalid_cells == 256
    out = cal.update(frame(70))
    assert (out.minimum == 70).all()


def messy_frame(seed: int, bad_fraction: float) -> np.ndarray:
    """Counts 0..1023 with a fraction of NaN, infinities, negative and too-large values."""
    rng = np.random.default_rng(seed)
    f = rng.integers(0, 1024, (16, 16)).astype(np.float64)
    bad = rng.random((16, 16)) < bad_fraction
    f[bad] = rng.choice([np.nan, np.inf, -np.inf, -3.0, 1e9, 1024.0], size=int(bad.sum()))
    return f


@settings(max_examples=40, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2**32 - 1), st.sampled_from([0.0, 0.1, 0.9, 1.0])), min_size=1, max_size=8),
       st.floats(1e-4, 1.0))
def test_any_input_gives_activations_in_range(specs: list[tuple[int, float]], tau: float) -> None:
    mask = load_outline()
    cal = PatchCalibrator(outline=mask, tau=tau)
    for f in (messy_frame(*spec) for spec in specs):
        out = cal.update(f)
        act = out.activation
        assert np.isfinite(act).all() and (act[~mask] == 0).all()
        assert (act[mask] >= np.float32(0.08)).all() and (act[mask] <= 1).all()
        valid = np.isfinite(f) & (f >= 0) & (f <= 1023)
        assert (out.minimum[valid] <= f[valid] + 1e-3).all()  # eq. (1): m_t <= a_t


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 1023), min_size=1, max_size=40), st.floats(1e-3, 1.0))
def test_eq1_matches_a_scalar_reference(values: list[int], tau: float) -> None:
    cal = PatchCalibrator(outline=ALL, tau=tau)
    m = None
    for a in values:
        m = a if m is None else min(a, m + tau * (a - m))
        out = cal.update(frame(a))
        assert out.minimum[5, 5] == pytest.approx(m, rel=1e-5, abs=1e-3)


# ---------------------------------------------------------------------- averaging
def test_scan_averager_decimates_and_averages() -> None:
    av = ScanAverager(window=5, decimation=5)
    outs = [av.update(frame(v)) for v in range(10)]
    assert [o is not None for o in outs] == [False] * 4 + [True] + [False] * 4 + [True]
    assert outs[4][0, 0] == pytest.approx(2.0) and outs[9][0, 0] == pytest.approx(7.0)
    assert outs[4].dtype == np.float32
    nan_scan = frame(10)
    nan_scan[1, 1] = np.nan
    av = ScanAverager(window=2, decimation=2)
    av.update(nan_scan)
    out = av.update(frame(20))
    assert out[1, 1] == 20 and out[0, 0] == 15
    av = ScanAverager(window=2, decimation=1)
    assert np.isnan(av.update(frame(np.nan))[0, 0])


def test_update_scan_runs_the_paper_chain() -> None:
    """100 Hz raw scans -> moving average -> 20 Hz -> eq. (1) and (2), as sympartner2018 6.1."""
    direct = PatchCalibrator(outline=ALL)
    chained = PatchCalibrator(outline=ALL)
    rng = np.random.default_rng(1)
    scans = [frame(50) + rng.normal(0, 3, (16, 16)) for _ in range(50)]
    got = [chained.update_scan(s) for s in scans]
    assert sum(g is not None for g in got) == 10
    for i, g in enumerate(got):
        if g is not None:
            ref = direct.update(np.mean(scans[i - 4:i + 1], axis=0))
            assert np.allclose(g.activation, ref.activation) and np.allclose(g.minimum, ref.minimum)


# ---------------------------------------------------------------------- long runs
def test_long_run_no_drift_of_the_tracked_minimum() -> None:
    """One hour at 20 Hz of a stationary noisy resting signal: m settles and stays put."""
    rng = np.random.default_rng(3)
    cal = PatchCalibrator(outline=ALL)
    sizes = None
    samples = {}
    for i in range(72000):
        out = cal.update(50 + rng.normal(0, 2, (16, 16)))
        if i == 10:
            sizes = {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)}
        if i in (12000, 36000, 71999):  # 10, 30 and 60 min
            samples[i] = out.minimum.astype(np.float64).mean()
            assert (out.activation == np.float32(0.08)).all()  # noise never shows above k
    assert all(44 < m < 50 for m in samples.values())  # below the mean by a few sigma, bounded
    assert abs(samples[71999] - samples[12000]) < 0.5 and abs(samples[71999] - samples[36000]) < 0.5
    assert {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)} == sizes


def test_tracked_minimum_follows_a_slow_upward_drift() -> None:
    tau, rate = 0.001, 20.0
    cal = PatchCalibrator(outline=ALL, tau=tau)
    slope = 0.2  # counts per second
    for i in range(20 * 600):  # 10 min
        out = cal.update(frame(50 + slope * i / rate))
    lag = slope / (tau * rate)  # steady-state lag of a first-order follower: 10 counts
    assert out.minimum[0, 0] == pytest.approx(50 + slope * 600 - lag, abs=0.5)
    assert (out.activation == np.float32(0.08)).all()  # g * lag = 0.025 < k


def test_argument_errors() -> None:
    with pytest.raises(ValueError, match='tau'):
        PatchCalibrator(outline=ALL, tau=0)
    with pytest.raises(ValueError, match='gain'):
        PatchCalibrator(outline=ALL, gain=-1)
    with pytest.raises(ValueError, match='outline'):
        PatchCalibrator(outline=np.ones((8, 8), dtype=bool))
    with pytest.raises(ValueError, match='shape'):
        PatchCalibrator(outline=ALL).update(np.zeros(256))
    cal = PatchCalibrator(outline=ALL)
    cal.update(frame(5))
    cal.reset()
    assert cal.frames == 0 and cal.update(frame(9)).minimum[0, 0] == 9


def _reference_average(scans: list[np.ndarray], window: int) -> np.ndarray:
    """The average of the last ``window`` scans, non-finite samples left out (NaN where none is left)."""
    stack = np.asarray(scans[-window:], dtype=np.float64)
    valid = np.isfinite(stack)
    count = valid.sum(axis=0)
    with np.errstate(invalid='ignore', divide='ignore'):
        return np.where(count > 0, np.where(valid, stack, 0.0).sum(axis=0) / count, np.nan).astype(np.float32)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(['int', 'float', 'nan']), min_size=1, max_size=25), st.integers(1, 6),
       st.integers(1, 6))
def test_scan_averager_mixes_integer_and_float_scans_like_the_reference(
        kinds: list[str], window: int, decimation: int) -> None:
    """Integer scans (the decoder's) take a shortcut; mixed with float scans holding NaN the averages
    are still those of the definition, bit for bit."""
    rng = np.random.default_rng(len(kinds) * 7 + window)
    averager, seen = ScanAverager(window, decimation), []
    for i, kind in enumerate(kinds):
        scan = rng.integers(0, 1024, (16, 16)).astype(np.uint16)
        if kind != 'int':
            scan = scan.astype(np.float32)
            if kind == 'nan':
                scan[rng.random((16, 16)) < 0.5] = np.nan
        seen.append(scan)
        out = averager.update(scan)
        if (i + 1) % decimation:
            assert out is None
        else:
            np.testing.assert_array_equal(out, _reference_average(seen, window))
