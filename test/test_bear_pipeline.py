"""The three paths together on what the bear_driver node makes of a virtual bear (the robot's decode and
calibration, through the harness): hard cases."""

from __future__ import annotations

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.features import FEATURE_NAMES
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.subtype_labels import subtype_index
from touch_sim.bear.render import BearCycles
from touch_sim.scenes import BearScript, BearTouch

BODY = BodyMap.default()
HUG = ['side_left_upper', 'side_right_upper', 'back_upper', 'back_middle', 'chest_left', 'chest_right']


def ch(name: str) -> int:
    return BODY.by_name(name).channel


def touch(names, start, duration, level=1.0, envelope='constant', freq_hz=1.0):
    return BearTouch(channels=tuple(ch(n) for n in names), start=start, duration=duration, level=level,
                     envelope=envelope, freq_hz=freq_hz)


def run(chain, duration_s, recogniser=None):
    rec = recogniser or BearRecogniser(chain.rate_hz)
    return rec, [rec.update(c.t, c.levels, c.faulty) for c in chain.cycles(duration_s)]


def events(results):
    return [(e.gesture, e.state_name) for r in results for e in r.symbolic_events]


def test_sensor_level_subtype_and_symbolic_through_the_driver_node() -> None:
    script = BearScript([touch(['head2'], 5.0, 8.0)])
    _, results = run(BearCycles(script, rate_hz=3.4, seed=1), 22.0)
    during = [r for r in results if 7.0 < r.t < 12.0]
    assert all([s.name for s in r.active_sensors] == ['head2'] for r in during)
    assert during[0].active_sensors[0].region == 'head' and during[0].active_sensors[0].level > 0.8
    changes = [(c.sensor, c.change.previous, c.subtype) for r in results for c in r.subtype_changes]
    # The rule: under 3 s a poke, then a hold; after release the buffer still holds the touch (knight2009
    # V.D's amplitude is the buffer's peak), and the release step reads as a low frequency, a pet, until the
    # 20 cycles (5.9 s) have passed. That tail is the paper's; the trained model learns to say none there.
    assert changes == [('head2', 'none', 'poke'), ('head2', 'poke', 'hold'), ('head2', 'hold', 'pet'),
                       ('head2', 'pet', 'none')]
    assert events(results) == [('head_pat', 'CANDIDATE'), ('head_pat', 'START'), ('head_pat', 'END')]
    assert not any(r.active_sensors for r in results if r.t < 4.5)                    # baseline learnt, no touch


def test_sensor_stuck_at_full_scale_is_masked_once_flagged() -> None:
    """A saturated back sensor plus three other hug sensors: only a real fourth one makes a hug."""
    script = BearScript([touch(['side_left_upper', 'side_right_upper', 'chest_left'], 30.0, 6.0)])
    chain = BearCycles(script, rate_hz=3.4, seed=2, device_options={'faults': {'back_upper': 'saturated'}},
                        calibrator_options={'fault_after_s': 10.0})
    _, results = run(chain, 40.0)
    late = [r for r in results if r.t > 15.0]
    assert all(not r.active[ch('back_upper')] for r in late)
    assert all(r.codes[ch('back_upper')] == 0 for r in late)
    assert ('hug', 'START') not in events(results)            # 3 real sensors + 1 stuck one is not a hug


def test_stuck_sensor_not_flagged_reads_as_a_hold() -> None:
    """Documented behaviour: without the calibrator's fault flag a constant full-scale level is a hold."""
    rec = BearRecogniser(3.4)
    levels = np.zeros(64, dtype=np.float32)
    levels[ch('back_upper')] = 1.0
    for i in range(30):
        out = rec.update(i / 3.4, levels)
    assert out.subtype_of(ch('back_upper')) == 'hold'
    assert out.features.base_frequency_hz[ch('back_upper')] == 0.0
    faulty = np.zeros(64, dtype=bool)
    faulty[ch('back_upper')] = True
    rec.reset()
    for i in range(30):
        out = rec.update(i / 3.4, levels, faulty)
    assert out.subtype_of(ch('back_upper')) == 'none' and not out.active_sensors


def test_dead_sensor_never_active_and_a_hug_still_detected() -> None:
    script = BearScript([touch(HUG, 6.0, 6.0)])
    chain = BearCycles(script, rate_hz=3.4, seed=3, device_options={'faults': {'side_left_upper': 'dead'}})
    _, results = run(chain, 16.0)
    assert all(not r.active[ch('side_left_upper')] for r in results)
    assert all(np.isfinite(r.features.table).all() for r in results)
    assert ('hug', 'START') in events(results)                # 5 of 6 hug sensors, still on both sides


def test_nan_levels_are_counted_not_raised() -> None:
    rec = BearRecogniser(3.4)
    levels = np.full(64, np.nan, dtype=np.float32)
    out = rec.update(0.0, levels)
    assert not out.active.any() and rec.buffer.invalid_counts.sum() == 64
    assert np.isfinite(out.features.table).all()


def test_first_cycles_with_a_short_buffer() -> None:
    rec = BearRecogniser(25.0, buffer_len=40)
    levels = np.zeros(64, dtype=np.float32)
    levels[ch('paw_left_palm')] = 0.7
    outs = [rec.update(i / 25.0, levels) for i in range(3)]
    assert [o.features.table.shape for o in outs] == [(64, len(FEATURE_NAMES))] * 3
    assert outs[-1].subtype_of(ch('paw_left_palm')) == 'poke'


def test_two_gestures_at_once_end_to_end() -> None:
    script = BearScript([touch(['head1'], 4.0, 5.0), touch(['foot_right_sole'], 4.0, 5.0)])
    _, results = run(BearCycles(script, rate_hz=10.0, device_options={'scan': 'parallel'}), 12.0)
    starts = {e.gesture for r in results for e in r.symbolic_events if e.state_name == 'START'}
    assert starts == {'head_pat', 'foot_rub'}


@pytest.mark.parametrize('rate', [3.4, 25.0])
def test_trained_classifier_plugs_in(rate: float) -> None:
    from touch_lab.bear.subtype_training import SubtypeClassifier

    rng = np.random.default_rng(0)
    X = rng.random((200, len(FEATURE_NAMES))).astype(np.float32)
    y = np.where(X[:, 0] > 0.5, 'hold', 'none')
    rec = BearRecogniser(rate, classifier=SubtypeClassifier().fit(X, y))
    levels = np.zeros(64, dtype=np.float32)
    levels[ch('head2')] = 0.9
    out = rec.update(0.0, levels)
    assert out.codes.dtype == np.int8 and set(np.unique(out.codes)) <= {0, subtype_index('hold')}
    assert np.all((out.confidence >= 0) & (out.confidence <= 1))
    assert not out.codes[~BODY.fitted_mask()].any()
