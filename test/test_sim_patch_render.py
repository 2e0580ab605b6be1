"""Simulated patch scenes as the robot perceives them: virtual patch -> patch_driver -> /patch/frame (SYNTHETIC)."""

import argparse

import numpy as np
import pytest
from doctest_testing import check_doctests

from touch_driver.patch.calibration import PanelCalibrator, PatchCalibrator
from touch_driver.patch.protocol import PatchDecoder
from touch_lab.patch.cli import _add_source_arguments, load_sessions
from touch_lab.patch.datasets import render_session
from touch_lab.patch.evaluate import segment_events
from touch_sim import virtual_port
from touch_sim.patch import render as render_module
from touch_sim.patch.device import PatchDevice
from touch_sim.patch.people import make_people, simulate_session
from touch_sim.patch.render import PatchFrames, render_scene
from touch_sim.scenes import registered_stimuli


@pytest.fixture(scope='module')
def push_scene():
    """Two pushes, the other hand grabbing the shell (a panel contact) at least once (SYNTHETIC)."""
    person = make_people(2, seed=9)[1]
    scene = simulate_session(person, 'push', n_events=2, seed=4, lead_s=(1.5, 1.5), pause_s=(4.0, 4.0))
    assert scene.panel_contacts()
    return scene


@pytest.fixture(scope='module')
def rendered(push_scene):
    return render_scene(push_scene, seed=3)


def decoded_directly(scene, seed):
    """The reference: the device's bytes through a PatchDecoder, a PatchCalibrator and a PanelCalibrator with
    the driver's defaults (activations of the scans that complete a 20 Hz frame, panels on every scan)."""
    device = PatchDevice(scene, seed=seed)
    decoder, calibrator = PatchDecoder(), PatchCalibrator()
    panels = PanelCalibrator.from_yaml(rate_hz=1.0 / device.frame_period)
    acts, contact = [], []
    for index in range(int(scene.duration_s / device.frame_period)):
        for scan in decoder.update(device.frame_bytes(index, index * device.frame_period)):
            state = panels.update(scan.panels)
            out = calibrator.update_scan(scan.cells)
            if out is not None:
                acts.append(out.activation)
                contact.append(np.asarray(state.contact, dtype=bool))
    return np.stack(acts), np.stack(contact)


def test_the_driver_node_gives_the_devices_bytes_decoded_and_calibrated(push_scene, rendered):
    acts, contact = decoded_directly(push_scene, 3)
    assert rendered.activations.dtype == np.float32 and rendered.activations.shape == acts.shape
    np.testing.assert_array_equal(rendered.activations, acts)
    np.testing.assert_array_equal(rendered.panel_contact, contact)
    assert rendered.panel_contact.any() and (rendered.activations > 0.5).any()
    stats = rendered.stats
    assert stats['frames'] == len(acts) and stats['wire_frames'] == int(push_scene.duration_s / 0.01)
    assert stats['checksum_errors'] == stats['sequence_gaps'] == stats['reconnects'] == 0
    # A frame is stamped when the driver's 200 Hz poll reads the scan that completes it (scans 4, 9, ...).
    scan_s = (np.arange(len(acts)) * 5 + 4) / 100.0
    lag = stats['stamps_s'] - scan_s
    assert lag.min() >= -1e-9 and lag.max() <= 0.005 + 1e-9


def test_frames_are_in_range_and_at_20_hz(push_scene, rendered):
    n = rendered.activations.shape[0]
    assert n == pytest.approx(push_scene.duration_s * 20, abs=2)
    a = rendered.activations
    assert np.all((a == 0) | ((a >= np.float32(0.08)) & (a <= 1)))  # eq. (2) range, 0 outside the outline
    assert rendered.panel_contact.shape == (n, 11)


def test_the_events_are_where_they_happened(push_scene, rendered):
    found = segment_events(rendered.activations, 20.0, merge_gap_s=1.0)
    assert len(found) == len(push_scene.events)
    for (on, off), event in zip(found, push_scene.events, strict=True):
        assert abs(on - event.onset_s) < 0.5 and off <= event.offset_s + 3.0  # the fabric creeps back slowly


def test_panel_contact_follows_grabs(push_scene, rendered):
    times = np.arange(len(rendered.panel_contact)) / 20.0
    for panel, start, end in push_scene.panel_contacts():
        during = (times > start + 0.2) & (times < end - 0.2)
        if during.any():
            assert rendered.panel_contact[during, panel].mean() > 0.9
    idle = times < push_scene.events[0].onset_s - 1.5
    assert not rendered.panel_contact[idle].any()


def test_another_seed_gives_other_noise(push_scene, rendered):
    other = render_scene(push_scene, seed=4).activations
    assert other.shape == rendered.activations.shape and not np.array_equal(other, rendered.activations)


def test_the_harness_cleans_up_its_device_and_stimulus(push_scene):
    source = PatchFrames(push_scene, seed=1)
    frames = list(source.frames(2.0))
    assert len(frames) == 40 and frames[0].activation.shape == (16, 16) and frames[0].panel_contact.shape == (11,)
    assert not any(name.startswith('patch-harness') for name in registered_stimuli())
    assert not any(name.startswith('patch-harness') for name in virtual_port._registry)
    # 2 s of 100 Hz scans; the driver may read a scan or two more while the last poll comes round.
    assert source.counters['wire_frames'] == 200 and 200 <= source.counters['frames'] <= 202


def test_a_lossy_wire_loses_frames_but_not_the_graph(push_scene):
    source = PatchFrames(push_scene, seed=1, url_options={'drop': 0.05, 'garbage': 0.05})
    frames = list(source.frames(6.0))
    assert 0 < len(frames) < 120
    assert source.counters['sequence_gaps'] > 0 and source.counters['dropped_bytes'] > 0
    assert np.all(np.diff([f.t for f in frames]) > 0)


def test_bad_arguments_are_clear_errors(push_scene):
    with pytest.raises(ValueError, match='set by the harness'):
        list(PatchFrames(push_scene, url_options={'scene': 'x'}).frames(1.0))
    with pytest.raises(ValueError, match="must not set 'port'"):
        PatchFrames(push_scene, driver_parameters={'port': 'loop://'})
    with pytest.raises(TypeError, match=r'pressure\(t\) and panels\(t\)'):
        PatchFrames(object())
    with pytest.raises(ValueError, match=r"cannot open patchsim://.*unknown patchsim option 'nois'"):
        list(PatchFrames(push_scene, url_options={'nois': '3'}).frames(1.0))
    with pytest.raises(ValueError, match='duration_s'):
        list(PatchFrames(push_scene).frames(float('nan')))


def test_simulated_sessions_are_labelled_synthetic(monkeypatch, push_scene, rendered):
    s = render_session(push_scene, 'p1', 'push', seed=3)
    assert s.synthetic and 'patch_driver' in s.source and len(s.events) == 2 and s.panels.shape == (s.n_frames, 11)
    np.testing.assert_array_equal(s.activations, rendered.activations)
    parser = argparse.ArgumentParser()
    _add_source_arguments(parser)
    args = parser.parse_args(['--simulate', '2', '--events', '1', '--seed', '3'])
    from touch_sim.patch import people as scene_module
    short = scene_module.simulate_people

    def fewer(n_people, events_per_session, seed):  # two gestures keep the test short
        return short(n_people, events_per_session, seed, gestures=('slap', 'push'))

    monkeypatch.setattr(scene_module, 'simulate_people', fewer)
    sessions = load_sessions(args)
    assert len(sessions) == 4 and all(s.synthetic and 'patch_driver' in s.source for s in sessions)
    person, gesture, scene = fewer(2, 1, 3)[0]
    same = render_session(scene, person.name, gesture, seed=3 * 7919)
    np.testing.assert_array_equal(sessions[0].activations, same.activations)


def test_doctests():
    check_doctests(render_module)


def test_a_run_whose_end_rounds_down_to_whole_nanoseconds_ends(push_scene):
    """17 scans: the 20 Hz frames complete at scans 4, 9 and 14 and none comes in the two polls after the last
    scan, so the run stops at its end, 17 x 0.01 + 2 polls = 0.18000000000000002 s, 0.18 s in whole ns."""
    import signal

    from touch_sim.harness import DeviceRun

    def hung(signum, frame):
        raise AssertionError('DeviceRun.messages did not stop')
    old = signal.signal(signal.SIGALRM, hung)
    signal.alarm(20)
    try:
        run = DeviceRun('patch', push_scene, seed=1)
        assert len(list(run.messages(17, [('/patch/frame', 'PatchFrame')]))) == 3 and run.counters['wire_frames'] == 17
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
