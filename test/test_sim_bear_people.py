"""Simulated people (synthetic): Table II styles, reproducible scenes, ground truth that matches the stimulus."""

from __future__ import annotations

from itertools import pairwise

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES
from touch_gestures.bear.symbolic import GestureLibrary
from touch_sim.bear.people import PERFORMANCES, SUBTYPE_STATS, Person, make_scene
from touch_sim.scenes import BearStimulus

BODY = BodyMap.default()


def test_scene_is_a_bear_stimulus_and_synthetic() -> None:
    scene = make_scene(n_people=1, seed=0, subtype_reps=1, gesture_reps=1)
    assert isinstance(scene, BearStimulus) and scene.synthetic and 'synthetic' in scene.description
    for t in np.linspace(0, scene.duration_s, 200):
        p = scene.proximity(float(t))
        assert p.shape == (64,) and p.dtype == np.float32 and np.all((p >= 0) & (p <= 1))
        assert not p[~BODY.fitted_mask()].any()


def test_same_seed_same_scene_other_seed_other_scene() -> None:
    a, b, c = (make_scene(n_people=2, seed=s, subtype_reps=1, gesture_reps=1) for s in (4, 4, 5))
    assert a.labels == b.labels and a.contacts == b.contacts
    assert a.labels != c.labels


def test_every_label_is_performed_and_nothing_else() -> None:
    scene = make_scene(n_people=2, seed=1, subtype_reps=2, gesture_reps=2)
    subtypes = [lab.label for lab in scene.labels if lab.kind == 'subtype']
    assert sorted(subtypes) == sorted(list(TOUCH_SUBTYPES) * 4)
    gestures = [lab for lab in scene.labels if lab.kind == 'symbolic']
    assert len(gestures) == len(PERFORMANCES) * 2 * 2
    assert {(lab.label, lab.person, lab.attempt) for lab in gestures} == {
        (g, p, a) for g in PERFORMANCES for p in range(2) for a in (1, 2)}
    for lab in scene.labels:                  # the touched sensors carry signal inside the label's interval
        channels = [BODY.by_name(n).channel for n in lab.sensors]
        peak = max(scene.proximity(float(t))[channels].max() for t in np.linspace(lab.start_s, lab.end_s, 60))
        assert peak > 0.3, lab
        assert scene.proximity(lab.start_s - 1e-3)[channels].max() == 0
    ends = sorted((lab.start_s, lab.end_s) for lab in scene.labels)
    assert all(e1 <= s2 for (_, e1), (s2, _) in pairwise(ends))   # one interaction at a time


def test_subtype_truth_matches_contacts() -> None:
    scene = make_scene(n_people=1, seed=2, subtype_reps=1, gesture_reps=0)
    for lab in scene.labels:
        ch = BODY.by_name(lab.sensors[0]).channel
        assert scene.subtype_truth((lab.start_s + lab.end_s) / 2).get(ch) == lab.label
    assert scene.subtype_truth(0.0) == {}         # the untouched lead-in the calibrator learns its baseline from


def test_people_styles_stay_within_table_ii_limits() -> None:
    for seed in range(20):
        person = Person(seed, np.random.default_rng(seed))
        for name, (amp, freq, dur) in person.means.items():
            st = SUBTYPE_STATS[name]
            assert st.amplitude_range[0] <= amp <= st.amplitude_range[1]
            assert st.frequency_range[0] <= freq <= st.frequency_range[1]
            assert st.duration_range[0] <= dur <= st.duration_range[1]
        contact = person.contact('tickle', 3, 10.0)
        assert 3.0 <= contact.end_s - contact.start_s <= 20.0 and 3.0 <= contact.frequency_hz <= 12.0
    assert {k for k, v in SUBTYPE_STATS.items() if v.paper} == {'tickle', 'poke', 'pet', 'hold'}


def test_performances_use_real_sensors_and_the_papers_filters() -> None:
    lib = GestureLibrary.default(BODY)
    for name, perf in PERFORMANCES.items():
        for sensor in (*perf.sensors, *perf.stray):
            BODY.by_name(sensor)                                  # raises on a typo
        assert lib[name].detectable
        assert set(perf.sensors) <= set(lib[name].sensor_names), name
        assert not set(perf.stray) & set(lib[name].sensor_names), name
    undetectable = {g.name for g in lib.gestures if not g.detectable}
    assert undetectable.isdisjoint(PERFORMANCES)


def test_bad_arguments() -> None:
    with pytest.raises(ValueError, match='n_people'):
        make_scene(n_people=0)
    with pytest.raises(ValueError, match='no performance'):
        make_scene(n_people=1, gestures=('rocking',))
    with pytest.raises(ValueError, match='unknown subtype'):
        make_scene(n_people=1, subtypes=('stroke',))


def test_trial_scene_performs_symbolic_gestures_between_subtypes_in_the_protocols_order():
    from touch_sim.bear.people import PERFORMANCES, split_label, symbolic_label, trial_scene
    trials = [('poke', 1.0), (symbolic_label('hug'), 1.0), ('tickle', 0.6), (symbolic_label('tickle'), 1.4)]
    scene = trial_scene(0, trials, seed=3)
    assert [(lab.kind, lab.label) for lab in scene.labels] == [
        ('subtype', 'poke'), ('symbolic', 'hug'), ('subtype', 'tickle'), ('symbolic', 'tickle')]
    hug = scene.labels[1]
    aimed = set(PERFORMANCES['hug'].sensors) | set(PERFORMANCES['hug'].stray)
    assert 5 <= len(hug.sensors) <= 8 and set(hug.sensors) <= aimed
    assert split_label('symbolic/hug') == ('symbolic', 'hug') and split_label('hug') == ('subtype', 'hug')
    # Subtype-only sessions are what they were before gestures could be asked (the stray draw is apart).
    plain = trial_scene(0, [('poke', 1.0), ('tickle', 0.6)], seed=3)
    assert plain.labels[0] == scene.labels[0]
    with pytest.raises(ValueError, match=r"unknown subtypes or gestures \['symbolic/rocking'\]"):
        trial_scene(0, [('symbolic/rocking', 1.0)])
