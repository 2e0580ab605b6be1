"""Simulated people on the textile patch (SYNTHETIC): reproducible, recording protocol, realistic variety."""

import numpy as np
import pytest

from touch_sim.patch.people import (
    GESTURES,
    GRAB_PANELS,
    PatchScene,
    TouchEvent,
    demo_scene,
    make_people,
    simulate_people,
    simulate_session,
)
from touch_sim.scenes import PatchStimulus


@pytest.fixture(scope='module')
def people():
    return make_people(4, seed=3)


def sample(scene: PatchScene, rate=20.0):
    times = np.arange(0, scene.duration_s, 1 / rate)
    return times, np.stack([scene.pressure(t) for t in times]), np.stack([scene.panels(t) for t in times])


def test_implements_the_driver_stimulus_protocol(people):
    scene = simulate_session(people[0], 'stroke', n_events=2, seed=1)
    assert isinstance(scene, PatchStimulus)
    p, q = scene.pressure(1.0), scene.panels(1.0)
    assert p.shape == (16, 16) and p.dtype == np.float32
    assert q.shape == (11,) and q.dtype == np.float32
    assert scene.synthetic


def test_seeded_and_reproducible(people):
    a = simulate_session(people[1], 'tickle', n_events=3, seed=7)
    b = simulate_session(people[1], 'tickle', n_events=3, seed=7)
    c = simulate_session(people[1], 'tickle', n_events=3, seed=8)
    assert a.events == b.events and a.events != c.events
    for t in np.linspace(0, a.duration_s, 50):
        np.testing.assert_array_equal(a.pressure(t), b.pressure(t))
    assert make_people(3, seed=1) == make_people(3, seed=1)


@pytest.mark.parametrize('gesture', GESTURES)
def test_one_class_per_session_with_pauses_of_at_least_4_s(people, gesture):
    scene = simulate_session(people[2], gesture, n_events=5, seed=11)
    assert [e.gesture for e in scene.events] == [gesture] * 5
    assert all(isinstance(e, TouchEvent) and e.person == people[2].name for e in scene.events)
    for before, after in zip(scene.events, scene.events[1:], strict=False):
        assert after.onset_s - before.offset_s >= 4.0
    times, pressure, panels = sample(scene)
    assert np.all(pressure >= 0) and np.all((panels >= 0) & (panels <= 1))
    touching = pressure.reshape(len(times), -1).max(axis=1) > 0
    inside = np.zeros(len(times), dtype=bool)
    for e in scene.events:
        inside |= (times >= e.onset_s) & (times <= e.offset_s)
    assert not np.any(touching & ~inside)  # no pressure outside the labelled events
    for e in scene.events:  # every event presses
        span = (times >= e.onset_s) & (times <= e.offset_s)
        assert pressure[span].max() > 0.2


def test_gestures_differ_the_way_the_paper_describes(people):
    def stats(gesture):
        durations, areas, peaks = [], [], []
        for person in people:
            scene = simulate_session(person, gesture, n_events=3, seed=5)
            times, pressure, _ = sample(scene, rate=100.0)
            for e in scene.events:
                span = pressure[(times >= e.onset_s) & (times <= e.offset_s)]
                durations.append(e.offset_s - e.onset_s)
                areas.append((span > 0.3).sum(axis=(1, 2)).max())
                peaks.append(span.max())
        return np.median(durations), np.median(areas), np.median(peaks)

    slap, push, tickle = stats('slap'), stats('push'), stats('tickle')
    assert slap[0] < 1.0 < push[0]             # slaps are short, pushes long
    assert tickle[1] < push[1] and tickle[1] < slap[1]  # fingertips against a hand


def test_people_have_their_own_styles():
    a, b = make_people(2, seed=0)
    assert a.name != b.name and a.centre != b.centre and a.force != b.force


def test_pushes_often_grab_the_shell(people):
    grabbed = 0
    for person in people:
        scene = simulate_session(person, 'push', n_events=4, seed=2)
        grabbed += sum(1 for panel, _, _ in scene.panel_contacts() if panel in GRAB_PANELS)
        for panel, start, end in scene.panel_contacts():
            assert scene.panels((start + end) / 2)[panel] >= 0.5
    assert grabbed > 0
    stroke = simulate_session(people[0], 'stroke', n_events=4, seed=2)
    assert stroke.panel_contacts() == []  # a hand near the back panels is not contact


def test_simulated_data_set_and_demo_scene():
    data = simulate_people(n_people=2, events_per_session=2, seed=4)
    assert len(data) == 8 and {g for _, g, _ in data} == set(GESTURES)
    demo = demo_scene(seed=2, n_events=10)
    assert len(demo.events) == 10 and len({e.gesture for e in demo.events}) > 1
    assert demo.duration_s > demo.events[-1].offset_s


def test_bad_arguments(people):
    with pytest.raises(ValueError, match='unknown gesture'):
        simulate_session(people[0], 'hug')
    with pytest.raises(ValueError, match='4 s'):
        simulate_session(people[0], 'slap', pause_s=(1.0, 2.0))
