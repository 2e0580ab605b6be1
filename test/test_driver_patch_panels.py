"""PanelCalibrator: moving-average quiescent value frozen during contact, threshold, NaN, long holds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_driver.patch.calibration import PanelCalibrator
from touch_graph.errors import ConfigError

rng = np.random.default_rng(11)
Q = np.linspace(400, 600, 11)


def quiet(offset: float = 0.0) -> np.ndarray:
    return Q + offset + rng.normal(0, 1.5, 11)


def settled(**kwargs) -> PanelCalibrator:
    cal = PanelCalibrator(rate_hz=20.0, window_s=5.0, **kwargs)
    for _ in range(200):
        state = cal.update(quiet())
        assert not state.any_contact
    return cal


def test_quiescent_is_the_moving_average_and_contact_a_threshold_on_the_difference() -> None:
    cal = settled()
    assert np.allclose(cal.quiescent, Q, atol=1.0)
    x = quiet()
    x[2] += 150  # a hand on panel 2
    x[5] += 20   # furniture near panel 5: below the 40-count threshold
    state = cal.update(x)
    assert state.contact.tolist() == [i == 2 for i in range(11)] and state.any_contact
    assert state.delta[2] == pytest.approx(150, abs=6) and state.delta.dtype == np.float32
    assert state.quiescent[2] == pytest.approx(Q[2], abs=1.0)


def test_hysteresis() -> None:
    cal = settled()
    for delta, expect in ((50, True), (35, True), (29, True), (27, False), (35, False)):
        x = Q.copy() + (cal.quiescent - Q)  # exactly the quiescent value, no noise
        x[0] += delta
        assert cal.update(x).contact[0] == expect, delta  # on above 40, off at or below 0.7 * 40 = 28


def test_a_long_hold_is_not_learned_and_release_is_seen_at_once() -> None:
    cal = settled(max_freeze_s=None)
    for _ in range(20 * 300):  # five minutes of a hand resting on panel 0
        x = quiet()
        x[0] += 120
        state = cal.update(x)
        assert state.contact[0]
    assert cal.quiescent[0] == pytest.approx(Q[0], abs=1.0)
    state = cal.update(quiet())
    assert not state.contact[0] and not state.any_contact


def test_the_freeze_gives_way_after_max_freeze_s() -> None:
    cal = settled(max_freeze_s=30.0)
    contact = []
    for _ in range(20 * 60):  # a lasting step of +100 counts (parked against a couch)
        x = quiet()
        x[1] += 100
        contact.append(cal.update(x).contact[1])
    assert all(contact[:20 * 30]) and not any(contact[-20 * 10:])
    assert cal.quiescent[1] == pytest.approx(Q[1] + 100, abs=2)


def test_slow_drift_is_followed_without_false_contact() -> None:
    cal = settled()
    for i in range(20 * 600):  # +60 counts over ten minutes
        state = cal.update(quiet(offset=0.1 * i / 20))
        assert not state.any_contact
    assert np.allclose(cal.quiescent, Q + 60, atol=2)


def test_nan_keeps_the_contact_state_and_is_not_learned() -> None:
    cal = settled()
    x = quiet()
    x[3] += 100
    assert cal.update(x).contact[3]
    x = quiet()
    x[3] = np.nan
    x[4] = np.inf
    state = cal.update(x)
    assert state.contact[3] and state.delta[3] == 0 and cal.invalid_samples == 2
    assert np.isfinite(cal.quiescent).all() and cal.quiescent[4] == pytest.approx(Q[4], abs=1)
    # A panel that has never had a valid sample reports NaN as its quiescent value, and no contact.
    cal = PanelCalibrator(n_panels=2)
    state = cal.update([np.nan, 500])
    assert np.isnan(state.quiescent[0]) and not state.any_contact
    state = cal.update([300, 500])
    assert state.quiescent[0] == 300 and not state.contact[0]


def test_polarity() -> None:
    cal = PanelCalibrator(n_panels=1, polarity=-1, window_s=1.0)
    for _ in range(20):
        cal.update([500])
    assert cal.update([430]).contact[0] and not cal.update([570]).contact[0]


@settings(max_examples=50, deadline=None)
@given(st.lists(st.lists(st.one_of(st.floats(allow_nan=True, allow_infinity=True, width=32),
                                   st.floats(0, 70000)), min_size=11, max_size=11), min_size=1, max_size=40))
def test_any_input(samples: list[list[float]]) -> None:
    cal = PanelCalibrator(window_s=0.5)
    for x in samples:
        state = cal.update(np.array(x))
        assert state.contact.dtype == bool and state.any_contact == bool(state.contact.any())
        assert state.delta.shape == (11,)


def test_state_is_bounded() -> None:
    cal = settled()
    sizes = {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)}
    for _ in range(5000):
        cal.update(quiet())
    assert {k: v.nbytes for k, v in vars(cal).items() if isinstance(v, np.ndarray)} == sizes
    assert np.allclose(cal._sum, cal._ring.sum(axis=0))  # no rounding creep of the running sum


def test_config_file(tmp_path: Path) -> None:
    cal = PanelCalibrator.from_yaml(rate_hz=100.0)
    assert cal.n_panels == 11 and len(cal.names) == 11 and cal.window == 1000
    assert np.all(cal.threshold == 40.0)
    path = tmp_path / 'panels.yaml'
    path.write_text('threshold: 30\npanels:\n  - {name: a}\n  - {name: b, threshold: 50}\n')
    cal = PanelCalibrator.from_yaml(path)
    assert cal.names == ('a', 'b') and cal.threshold.tolist() == [30.0, 50.0]
    path.write_text('threshold: 30\npanels:\n  - {name: a}\n  - {name: b, treshold: 50}\n')
    with pytest.raises(ConfigError, match="did you mean 'threshold'") as err:
        PanelCalibrator.from_yaml(path)
    assert err.value.line == 4
    path.write_text('threshold: -3\npanels:\n  - {name: a}\n')
    with pytest.raises(ConfigError, match='positive'):
        PanelCalibrator.from_yaml(path)


def test_argument_errors() -> None:
    with pytest.raises(ValueError, match='shape'):
        PanelCalibrator().update(np.zeros(10))
    with pytest.raises(ValueError, match='polarity'):
        PanelCalibrator(polarity=0)
