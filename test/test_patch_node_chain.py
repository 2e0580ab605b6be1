"""The graph chain: a virtual patch read by the real patch_driver node gives the driver chain's frames (SYNTHETIC)."""

import argparse
import doctest

import numpy as np
import pytest

from touch_gestures.patch import graph_chain as graph_chain_module
from touch_gestures.patch.graph_chain import PatchGraphChain, render_graph
from touch_gestures.patch.sensor_chain import render_scene, render_session
from touch_lab.patch.cli import _add_source_arguments, load_sessions
from touch_sim import virtual_port
from touch_sim.patch.people import make_people, simulate_session
from touch_sim.scenes import registered_stimuli


@pytest.fixture(scope='module')
def push_scene():
    """Two pushes, the other hand grabbing the shell (a panel contact) at least once (SYNTHETIC)."""
    person = make_people(2, seed=9)[1]
    scene = simulate_session(person, 'push', n_events=2, seed=4, lead_s=(1.5, 1.5), pause_s=(4.0, 4.0))
    assert scene.panel_contacts()
    return scene


def test_graph_and_driver_chains_give_the_same_frames(push_scene):
    graph = render_scene(push_scene, seed=3, chain='graph')
    driver = render_scene(push_scene, seed=3, chain='driver')
    assert graph.chain == 'graph' and graph.activations.shape == driver.activations.shape
    assert graph.activations.dtype == np.float32
    np.testing.assert_array_equal(graph.activations, driver.activations)
    np.testing.assert_array_equal(graph.panel_contact, driver.panel_contact)
    assert graph.panel_contact.any() and (graph.activations > 0.5).any()
    stats = graph.stats
    assert stats['frames'] == len(driver.activations) and stats['wire_frames'] == driver.stats['wire_frames']
    assert stats['checksum_errors'] == stats['sequence_gaps'] == stats['reconnects'] == 0
    # A frame is stamped when the driver's 200 Hz poll reads the scan that completes it (scans 4, 9, ...).
    scan_s = (np.arange(len(driver.activations)) * 5 + 4) / 100.0
    lag = stats['stamps_s'] - scan_s
    assert lag.min() >= -1e-9 and lag.max() <= 0.005 + 1e-9


def test_another_seed_gives_other_noise(push_scene):
    a = render_graph(push_scene, seed=3).activations
    b = render_graph(push_scene, seed=4).activations
    assert a.shape == b.shape and not np.array_equal(a, b)


def test_the_chain_cleans_up_its_device_and_stimulus(push_scene):
    chain = PatchGraphChain(push_scene, seed=1)
    frames = list(chain.frames(2.0))
    assert len(frames) == 40 and [f.scan for f in frames[:3]] == [4, 9, 14]
    assert frames[0].activation.shape == (16, 16) and frames[0].panel_contact.shape == (11,)
    assert not any(name.startswith('patch-graphchain') for name in registered_stimuli())
    assert not any(name.startswith('patch-graphchain') for name in virtual_port._registry)
    # 2 s of 100 Hz scans; the driver may read a scan or two more while the last poll comes round.
    assert chain.counters['wire_frames'] == 200 and 200 <= chain.counters['frames'] <= 202


def test_a_lossy_wire_loses_frames_but_not_the_graph(push_scene):
    chain = PatchGraphChain(push_scene, seed=1, url_options={'drop': 0.05, 'garbage': 0.05})
    frames = list(chain.frames(6.0))
    assert 0 < len(frames) < 120
    assert chain.counters['sequence_gaps'] > 0 and chain.counters['dropped_bytes'] > 0
    assert np.all(np.diff([f.scan for f in frames]) > 0)


def test_bad_chain_arguments_are_clear_errors(push_scene):
    with pytest.raises(ValueError, match='set by the chain itself'):
        PatchGraphChain(push_scene, url_options={'scene': 'x'})
    with pytest.raises(ValueError, match="must not set 'port'"):
        PatchGraphChain(push_scene, driver_parameters={'port': 'loop://'})
    with pytest.raises(TypeError, match=r'pressure\(t\) and panels\(t\)'):
        PatchGraphChain(object())
    with pytest.raises(ValueError, match=r"cannot open patchsim://.*unknown patchsim option 'nois'"):
        list(PatchGraphChain(push_scene, url_options={'nois': '3'}).frames(1.0))
    with pytest.raises(ValueError, match='duration_s'):
        list(PatchGraphChain(push_scene).frames(float('nan')))


def test_eval_sessions_through_the_graph_are_labelled(monkeypatch):
    parser = argparse.ArgumentParser()
    _add_source_arguments(parser)
    args = parser.parse_args(['--simulate', '2', '--events', '1', '--chain', 'graph', '--seed', '3'])
    from touch_sim.patch import people as scene_module
    short = scene_module.simulate_people

    def fewer(n_people, events_per_session, seed):  # two gestures keep the test short
        return short(n_people, events_per_session, seed, gestures=('slap', 'push'))

    monkeypatch.setattr(scene_module, 'simulate_people', fewer)
    sessions = load_sessions(args)
    assert len(sessions) == 4 and all(s.synthetic and s.source == 'simulated (graph chain)' for s in sessions)
    person, gesture, scene = fewer(2, 1, 3)[0]
    same = render_session(scene, person.name, gesture, seed=3 * 7919, chain='driver')
    np.testing.assert_array_equal(sessions[0].activations, same.activations)


def test_doctests():
    assert doctest.testmod(graph_chain_module).failed == 0
