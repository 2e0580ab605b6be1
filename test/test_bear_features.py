"""Buffer features (knight2009 V.D, Table II) for all channels at once, and their hard cases."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

import touch_gestures.bear.features as features_module
from touch_gestures.bear.features import FEATURE_NAMES, FeatureExtractor, spectral_features

COL = {name: i for i, name in enumerate(FEATURE_NAMES)}


def sine(freq_hz: float, rate_hz: float, n: int, amp: float = 0.3, mean: float = 0.5) -> np.ndarray:
    t = np.arange(n) / rate_hz
    return (mean + amp * np.sin(2 * np.pi * freq_hz * t)).astype(np.float32)


def test_pure_tone_gives_its_frequency_and_no_spread() -> None:
    window = np.stack([sine(2.5, 25.0, 40), sine(5.0, 25.0, 40)], axis=1)
    table = spectral_features(window, 25.0)
    np.testing.assert_allclose(table[:, COL['base_frequency_hz']], [2.5, 5.0])
    assert np.all(table[:, COL['spectral_spread_hz']] < 1e-2)
    assert np.all(table[:, COL['spectral_peakiness']] > 0.99)


def test_two_tones_spread_more_than_one() -> None:
    one = sine(2.5, 25.0, 40)
    two = one + sine(7.5, 25.0, 40, amp=0.15, mean=0.0)
    table = spectral_features(np.stack([one, two], axis=1), 25.0)
    assert table[1, COL['spectral_spread_hz']] > 1.0 > table[0, COL['spectral_spread_hz']]
    assert table[1, COL['base_frequency_hz']] == pytest.approx(2.5)


@pytest.mark.parametrize('value', [0.0, 0.5, 1.0])
def test_constant_signal_has_zero_frequency_and_spread(value: float) -> None:
    """The FFT of a constant (all zeros, a hold, a sensor stuck at full scale): 0 Hz, no NaN."""
    table = spectral_features(np.full((20, 64), value, dtype=np.float32), 3.4)
    assert np.isfinite(table).all()
    assert np.all(table[:, COL['base_frequency_hz']] == 0) and np.all(table[:, COL['spectral_spread_hz']] == 0)
    assert np.all(table[:, COL['spectral_peakiness']] == 0) and np.all(table[:, COL['std_level']] == 0)
    assert np.all(table[:, COL['peak_amplitude']] == np.float32(value))


def test_sensor_noise_below_min_component_is_not_a_frequency() -> None:
    rng = np.random.default_rng(0)
    hold = (0.95 + rng.normal(0, 0.003, (20, 64))).astype(np.float32)
    table = spectral_features(hold, 3.4)
    assert np.all(table[:, COL['base_frequency_hz']] == 0)


def test_empty_buffer_gives_zeros() -> None:
    table = spectral_features(np.zeros((0, 64), dtype=np.float32), 3.4)
    assert table.shape == (64, len(FEATURE_NAMES)) and not table.any()


def test_single_sample_has_no_frequency() -> None:
    table = spectral_features(np.full((1, 3), 0.9, dtype=np.float32), 3.4)
    assert table[0, COL['peak_amplitude']] == pytest.approx(0.9)
    assert table[0, COL['base_frequency_hz']] == 0 and table[0, COL['spectral_spread_hz']] == 0
    assert table[0, COL['since_active_s']] == 0


def test_buffer_shorter_than_one_period_stays_finite_and_below_nyquist() -> None:
    """A 0.5 Hz pet seen through 3 cycles at 25 Hz (0.12 s): only what fits is described."""
    window = sine(0.5, 25.0, 3)[:, None]
    table = spectral_features(window, 25.0)
    assert np.isfinite(table).all()
    assert 0 <= table[0, COL['base_frequency_hz']] <= 12.5


def test_nan_in_the_window_reads_as_zero() -> None:
    window = np.full((10, 4), 0.5, dtype=np.float32)
    window[3, 1] = np.nan
    window[4, 2] = np.inf
    table = spectral_features(window, 10.0)
    assert np.isfinite(table).all()
    assert table[1, COL['std_level']] > 0 and table[0, COL['std_level']] == 0


def test_dft_and_rfft_paths_agree(monkeypatch) -> None:
    rng = np.random.default_rng(3)
    window = rng.random((40, 64)).astype(np.float32)
    fast = spectral_features(window, 10.0)
    monkeypatch.setattr(features_module, '_DFT_MAX_N', 0)
    slow = spectral_features(window, 10.0)
    np.testing.assert_allclose(fast, slow, rtol=1e-4, atol=1e-5)


def test_linear_detrend_removes_a_slow_approach() -> None:
    ramp = np.linspace(0.1, 0.9, 20, dtype=np.float32)[:, None]
    assert spectral_features(ramp, 3.4)[0, COL['base_frequency_hz']] > 0          # the ramp reads as a frequency
    assert spectral_features(ramp, 3.4, detrend='linear')[0, COL['base_frequency_hz']] == 0


def test_activity_features() -> None:
    pats = np.array([0, 0.8, 0, 0.8, 0, 0.8, 0, 0, 0, 0], dtype=np.float32)[:, None]
    table = spectral_features(pats, 10.0)
    assert table[0, COL['onset_rate_hz']] == pytest.approx(3 / 1.0)          # three rising crossings in 1 s
    assert table[0, COL['active_fraction']] == pytest.approx(0.3)
    assert table[0, COL['since_active_s']] == pytest.approx(0.4)
    assert table[0, COL['latest_level']] == 0
    never = spectral_features(np.zeros((10, 1), dtype=np.float32), 10.0)
    assert never[0, COL['since_active_s']] == pytest.approx(1.0)              # the whole buffer span


@settings(max_examples=80, deadline=None)
@given(window=arrays(np.float32, st.tuples(st.integers(0, 70), st.integers(1, 5)),
                     elements=st.one_of(st.floats(0, 1, width=32), st.just(np.nan))),
       rate=st.sampled_from([3.4, 10.0, 25.0]))
def test_features_are_finite_and_in_range(window: np.ndarray, rate: float) -> None:
    table = spectral_features(window, rate)
    assert np.isfinite(table).all()
    assert np.all((table[:, COL['peak_amplitude']] >= 0) & (table[:, COL['peak_amplitude']] <= 1))
    assert np.all((table[:, COL['base_frequency_hz']] >= 0) & (table[:, COL['base_frequency_hz']] <= rate / 2 + 1e-4))
    assert np.all((table[:, COL['spectral_spread_hz']] >= 0) & (table[:, COL['spectral_spread_hz']] <= rate / 2))
    assert np.all((table[:, COL['active_fraction']] >= 0) & (table[:, COL['active_fraction']] <= 1))
    assert np.all(table[:, COL['duration_s']] == 0)


def test_duration_counts_cycles_with_buffer_peak_over_threshold() -> None:
    """V.D pseudocode: duration increments while amplitude (the buffer's peak) is >= 30 %; it resets after."""
    ext = FeatureExtractor(rate_hz=2.0, n_channels=1)
    window = np.zeros((4, 1), dtype=np.float32)
    durations = []
    for level in [0.5, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0]:
        window = np.roll(window, -1, axis=0)
        window[-1] = level
        durations.append(float(ext.update(window).duration_s[0]))
    assert durations == [0.5, 1.0, 1.5, 2.0, 2.5, 0.0, 0.0]     # the buffer holds the touch 4 cycles


def test_extractor_rejects_bad_arguments() -> None:
    with pytest.raises(ValueError, match='rate_hz'):
        FeatureExtractor(rate_hz=0.0)
    with pytest.raises(ValueError, match='shape'):
        FeatureExtractor(rate_hz=3.4).update(np.zeros((20, 63), dtype=np.float32))
    with pytest.raises(ValueError, match='detrend'):
        spectral_features(np.zeros((4, 2)), 3.4, detrend='quadratic')


def test_touch_window_does_not_read_the_onset_step_as_a_frequency() -> None:
    """A steady hold 8 cycles old in a 20-cycle buffer: 'touch' sees a constant, 'buffer' sees a step."""
    window = np.zeros((20, 1), dtype=np.float32)
    window[-8:] = 0.95
    touch = spectral_features(window, 3.4, touch_cycles=np.array([8]))
    whole = spectral_features(window, 3.4)
    assert touch[0, COL['base_frequency_hz']] == 0 and touch[0, COL['spectral_spread_hz']] == 0
    assert whole[0, COL['base_frequency_hz']] > 0
    stroke = sine(1.0, 10.0, 20)[:, None]
    gated = spectral_features(stroke, 10.0, touch_cycles=np.array([20]))
    np.testing.assert_allclose(gated, spectral_features(stroke, 10.0))
    none = spectral_features(stroke, 10.0, touch_cycles=np.array([0]))
    assert none[0, COL['base_frequency_hz']] == 0
