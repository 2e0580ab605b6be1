"""The second family of simulated people (touch_sim/bear/hand_people.py): hands over plates, synthetic."""

from __future__ import annotations

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap
from touch_sim.bear.hand_people import SENSE_HEIGHT_M, HandPerson, HandScene, _context, _touch, hand_trial_scene

BODY = BodyMap.default()
CH = {s.name: s.channel for s in BODY.sensors}


def quiet_scene(touches, duration_s=20.0):
    """A scene of ``touches`` with the sensing chain's drift, glitches and cross-talk switched off."""
    scene = HandScene(touches, [], duration_s, BODY, seed=0)
    scene.drift_level[:] = 0.0
    scene.glitches = []
    scene.crosstalk = 0.0
    scene.clock_error = 0.0
    return scene


def person(**changes):
    base = dict(index=0, palm_m=0.045, finger_m=0.01, pressure=1.0, tempo=1.0, persistence=1.0, rhythm=0.0,
                aim_m=0.0)
    return HandPerson(**{**base, **changes})


def test_a_palm_saturates_its_plate_and_reads_more_than_a_fingertip():
    rng = np.random.default_rng(0)
    hold = _touch(person(), 'hold', CH['belly_middle'], 1.0, rng, _context(BODY), duration_s=5.0)
    poke = _touch(person(), 'poke', CH['belly_middle'], 1.0, rng, _context(BODY), duration_s=1.0)
    palm = quiet_scene([hold]).proximity(3.0)[CH['belly_middle']]
    tip = quiet_scene([poke]).proximity(1.5)[CH['belly_middle']]
    assert palm > 0.95 and 0.3 <= tip < palm


def test_coupling_falls_off_with_distance_and_height():
    rng = np.random.default_rng(1)
    hold = _touch(person(palm_m=0.03), 'hold', CH['head2'], 1.0, rng, _context(BODY), duration_s=5.0)
    levels = quiet_scene([hold]).proximity(3.0)
    assert levels[CH['head2']] > levels[CH['head4']] and levels[CH['foot_left_sole']] == 0.0
    assert quiet_scene([hold]).proximity(0.0).max() == 0.0          # before the hand comes
    pat = _touch(person(), 'pat', CH['head2'], 1.0, rng, _context(BODY), duration_s=4.0)
    _, height, _ = pat.pose(1.0 + 0.5 * (pat.beats[1] + pat.beats[2]) + 0.05)    # mid-lift: above the fur
    assert height > 0.5 * SENSE_HEIGHT_M


def test_a_pat_lifts_between_contacts_and_a_hold_does_not():
    rng = np.random.default_rng(2)
    pat = _touch(person(), 'pat', CH['head1'], 0.0, rng, _context(BODY), duration_s=4.0)
    hold = _touch(person(), 'hold', CH['head1'], 0.0, rng, _context(BODY), duration_s=4.0)
    t = np.arange(0.5, 3.5, 0.005)
    pats = np.array([quiet_scene([pat]).proximity(x)[CH['head1']] for x in t])
    holds = np.array([quiet_scene([hold]).proximity(x)[CH['head1']] for x in t])
    assert (pats < 0.3).mean() > 0.2 and (pats > 0.6).mean() > 0.2 and (holds > 0.9).all()


def test_the_sensing_chain_adds_drift_crosstalk_and_glitches():
    rng = np.random.default_rng(3)
    hold = _touch(person(), 'hold', CH['head1'], 1.0, rng, _context(BODY), duration_s=5.0)
    scene = quiet_scene([hold])
    mate = next(s.channel for s in BODY.sensors if s.channel // 8 == CH['head1'] // 8 and s.channel != CH['head1'])
    clean = scene.proximity(3.0)[mate]
    scene.crosstalk = 0.02                                                # a board-mate of the touched plate
    assert scene.proximity(3.0)[mate] > clean
    scene.glitches = [(10.0, CH['chin'], 0.5)]
    assert scene.proximity(10.1)[CH['chin']] == pytest.approx(0.5) and scene.proximity(10.3)[CH['chin']] == 0.0
    scene.drift_level[CH['chin']] = 0.05
    assert 0.0 <= scene.proximity(15.0)[CH['chin']] <= 0.05


def test_sessions_are_labelled_reproducible_and_synthetic():
    trials = [('pat', 1.0), ('symbolic/head_pat', 1.0), ('tap', 0.5)]
    a = hand_trial_scene(1, trials, seed=4)
    b = hand_trial_scene(1, trials, seed=4)
    assert a.synthetic and [lab.label for lab in a.labels] == ['pat', 'head_pat', 'tap']
    assert [lab.kind for lab in a.labels] == ['subtype', 'symbolic', 'subtype']
    assert np.array_equal(a.proximity(a.labels[1].start_s + 1.0), b.proximity(b.labels[1].start_s + 1.0))
    assert a.subtype_truth(a.labels[0].start_s + 0.5)[CH[a.labels[0].sensors[0]]] == 'pat'
    with pytest.raises(ValueError, match='unknown gesture'):
        hand_trial_scene(0, [('symbolic/moonwalk', 1.0)])
