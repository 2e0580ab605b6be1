"""Across families: ``band_share``, format-3 files of fewer features, the feature spread, C chosen across families.

All signals and people here are synthetic, made by hand or by the seeded simulation.
"""

from __future__ import annotations

import numpy as np
import pytest

from touch_gestures.bear.features import BAND_HZ, FEATURE_NAMES, spectral_features
from touch_gestures.bear.subtype_model import SubtypeModel
from touch_lab.bear.evaluate import EvalConfig
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.bear.transfer import feature_spread, format_spread

RATE = 3.4
BAND = FEATURE_NAMES.index('band_share')


def band(window, touch_cycles=None, rate_hz: float = RATE) -> np.ndarray:
    """(channels,) band_share of a (n, channels) window."""
    cycles = None if touch_cycles is None else np.asarray(touch_cycles)
    return spectral_features(np.asarray(window, dtype=np.float32), rate_hz, touch_cycles=cycles)[:, BAND]


def test_a_squeeze_in_the_band_reads_high_a_slow_one_low() -> None:
    t = np.arange(20) / RATE
    fast = 0.7 + 0.2 * np.sin(2 * np.pi * 1.36 * t)       # 1.36 Hz: inside 1 Hz .. Nyquist (1.7 Hz)
    slow = 0.7 + 0.2 * np.sin(2 * np.pi * 0.34 * t)       # a pet's stroke rate: below the band
    share = band(np.stack([fast, slow], axis=1), [20, 20])
    assert share[0] > 0.9 and share[1] < 0.1


def test_the_band_is_in_hz_not_in_bins() -> None:
    t = np.arange(64) / 10.0
    x = 0.6 + 0.2 * np.sin(2 * np.pi * 2.5 * t)           # at 10 Hz the whole 1-3 Hz band is seen
    assert BAND_HZ[0] < 2.5 < BAND_HZ[1] and band(x[:, None], [64], rate_hz=10.0)[0] > 0.9
    y = 0.6 + 0.2 * np.sin(2 * np.pi * 4.0 * t)           # a tickle's rate: above it
    assert band(y[:, None], [64], rate_hz=10.0)[0] < 0.1


def test_constant_one_onset_zero_nan_and_one_sample() -> None:
    assert band(np.full((20, 1), 0.7), [20])[0] == 0.0            # a steady hold: no component
    onset = np.zeros((20, 1))
    onset[15:, 0] = 0.9
    assert band(onset, [5])[0] == 0.0                             # the touch alone is steady
    assert band(onset)[0] > 0.0                                   # the whole buffer: the step has power
    assert (band(np.zeros((20, 3)), [0, 0, 0]) == 0).all()
    t = np.arange(20) / RATE
    x = (0.7 + 0.2 * np.sin(2 * np.pi * 1.36 * t))[:, None]
    x[4, 0] = np.nan                                              # read as 0: finite, still in [0, 1]
    assert 0.0 <= band(x, [20])[0] <= 1.0
    assert band(np.array([[0.6]]), [1])[0] == 0.0
    assert band(np.zeros((0, 2))).tolist() == [0.0, 0.0]


def test_format3_files_of_fewer_features_load_by_name(tmp_path) -> None:
    rng = np.random.default_rng(0)
    X = rng.random((120, len(FEATURE_NAMES))).astype(np.float32)
    y = np.where(X[:, 0] < 0.5, 'none', 'hold')
    cols = ('peak_amplitude', 'dip_fraction', 'mean_level/peak')
    model = SubtypeClassifier(columns=cols).fit(X, y)
    path = tmp_path / 'm.npz'
    model.save(path)
    with np.load(path) as data:        # as written before band_share was appended: its 15 features
        np.savez(path, **{**data, 'feature_names': np.array(FEATURE_NAMES[:15])})
    loaded = SubtypeModel.load(path)
    assert loaded.design_ == cols
    np.testing.assert_array_equal(loaded.predict(X), model.predict(X))
    with np.load(path) as data:        # a feature this code does not compute in that place: refused
        np.savez(path, **{**data, 'feature_names': np.array([*FEATURE_NAMES[:14], 'other'])})
    with pytest.raises(ValueError, match='retrain'):
        SubtypeModel.load(path)


def test_feature_spread_names_every_feature_per_family_and_class() -> None:
    result = feature_spread(EvalConfig(train_people=1, subtype_reps=1, seed=3), ('hold', 'shake'))
    assert result['features'] == list(FEATURE_NAMES) and result['classes'] == ['hold', 'shake']
    for family in result['families']:
        for c in ('hold', 'shake'):
            q = np.array(result['quartiles'][family][c])
            assert result['rows'][family][c] > 0 and q.shape == (3, len(FEATURE_NAMES))
            assert (q[0] <= q[1]).all() and (q[1] <= q[2]).all()
        hold = np.array(result['quartiles'][family]['hold'])
        assert hold[1, FEATURE_NAMES.index('base_frequency_hz')] == 0.0   # a still hand has no rhythm
    text = format_spread(result)
    assert 'SYNTHETIC' in text and all(f in text for f in FEATURE_NAMES)


def test_c_is_chosen_across_families_on_training_people_only(monkeypatch) -> None:
    import touch_lab.bear.transfer as transfer
    seeds = []
    render = transfer.render
    monkeypatch.setattr(transfer, 'render', lambda family, config, seed, *a, **k: seeds.append(seed) or
                        render(family, config, seed, *a, **k))
    config = EvalConfig(train_people=1, subtype_reps=1, seed=3)
    result = transfer.choose_c(config, ('peak_amplitude', 'duration_s', 'band_share'), grid=(1e-4, 1.0))
    assert seeds == [transfer.train_seed(f, 3) for f in transfer.FAMILIES]   # never a held-out person
    assert set(result['grid']) == {1e-4, 1.0} and result['chosen'] in (1e-4, 1.0)
    worse = {c: min(row.values()) for c, row in result['grid'].items()}
    assert set(result['grid'][1.0]) == {'script -> hands', 'hands -> script'}
    assert worse[result['chosen']] == max(worse.values())
    assert 'chosen' in transfer.format_choose_c(result)


def test_train_bear_writes_its_c_into_the_file_and_card(tmp_path, capsys) -> None:
    from touch_gestures.model_card import read_card
    from touch_lab.cli.main import main as cli_main
    out = tmp_path / 'm.npz'
    assert cli_main(['train', 'bear', '-o', str(out), '--population', 'hands', '--people', '1', '--C', '0.03',
                     '--columns', 'peak_amplitude', 'duration_s', 'band_share']) == 0
    with np.load(out) as data:
        assert float(data['params'][0]) == pytest.approx(0.03)
    assert SubtypeModel.load(out).design_ == ('peak_amplitude', 'duration_s', 'band_share')
    assert read_card(out)['data']['C'] == 0.03
    assert cli_main(['train', 'bear', '--bags', str(tmp_path / 'none'), '-o', str(tmp_path / 'b.npz'),
                     '--C', '0.1']) == 2
    assert '--C applies to simulated people' in capsys.readouterr().err
