"""Simulated scenes through the real sensor chain: stimulus -> PatchDevice bytes -> decoder -> calibration."""

import numpy as np
import pytest

from touch_gestures.patch.sensor_chain import driver_available, render_scene, render_session
from touch_lab.patch.evaluate import segment_events
from touch_sim.patch.people import make_people, simulate_session

pytestmark = pytest.mark.skipif(not driver_available(), reason='touch_driver.patch device/calibration missing')


@pytest.fixture(scope='module')
def push_scene():
    person = make_people(1, seed=1)[0]
    return simulate_session(person, 'push', n_events=2, seed=3, lead_s=(2.0, 2.0), pause_s=(4.0, 4.0))


def test_driver_chain_frames(push_scene):
    out = render_scene(push_scene, seed=1, chain='driver')
    assert out.chain == 'driver'
    assert out.stats['checksum_errors'] == 0 and out.stats['dropped_bytes'] == 0
    n = out.activations.shape[0]
    assert n == pytest.approx(push_scene.duration_s * 20, abs=2)
    assert out.activations.dtype == np.float32 and out.activations.shape[1:] == (16, 16)
    a = out.activations
    assert np.all((a == 0) | ((a >= np.float32(0.08)) & (a <= 1)))  # eq. (2) range, 0 outside the outline
    assert out.panel_contact.shape == (n, 11)


def test_driver_chain_sees_the_events_where_they_are(push_scene):
    out = render_scene(push_scene, seed=1, chain='driver')
    found = segment_events(out.activations, 20.0, merge_gap_s=1.0)
    assert len(found) == len(push_scene.events)
    for (on, off), event in zip(found, push_scene.events, strict=True):
        assert abs(on - event.onset_s) < 0.5 and off <= event.offset_s + 3.0  # the fabric creeps back slowly


def test_panel_contact_follows_grabs(push_scene):
    out = render_scene(push_scene, seed=1, chain='driver')
    times = np.arange(len(out.panel_contact)) / 20.0
    for panel, start, end in push_scene.panel_contacts():
        during = (times > start + 0.2) & (times < end - 0.2)
        if during.any():
            assert out.panel_contact[during, panel].mean() > 0.9
    idle = times < push_scene.events[0].onset_s - 1.5
    assert not out.panel_contact[idle].any()


def test_simple_and_driver_chains_agree_roughly(push_scene):
    simple = render_scene(push_scene, seed=1, chain='simple').activations
    driver = render_scene(push_scene, seed=1, chain='driver').activations
    n = min(len(simple), len(driver))
    area_s = (simple[:n] > 0.08 + 1e-6).sum(axis=(1, 2))
    area_d = (driver[:n] > 0.08 + 1e-6).sum(axis=(1, 2))
    assert np.corrcoef(area_s, area_d)[0, 1] > 0.8


def test_render_session_is_labelled_synthetic(push_scene):
    s = render_session(push_scene, 'p1', 'push', chain='driver')
    assert s.synthetic and 'driver' in s.source and len(s.events) == 2 and s.panels.shape == (s.n_frames, 11)
    with pytest.raises(ValueError, match='chain'):
        render_scene(push_scene, chain='magic')
