"""Virtual skin: contact model, scripted stimuli, device model and the skinsim:// URL handler (synthetic data)."""

from __future__ import annotations

import textwrap

import numpy as np
import pytest
import serial

import touch_sim  # noqa: F401  (registers the skinsim:// URL handler)
from touch_driver.framing import HEADER_SIZE
from touch_driver.skin.calibration import SkinCalibrator, calibrate_frames
from touch_driver.skin.protocol import MODULE_TAXELS, SkinStreamDecoder, decode_payload
from touch_graph.errors import ConfigError
from touch_sim.skin.contact import Contact, FingerContactModel, HysteresisPlay, SkinStimulus
from touch_sim.skin.device import SkinDevice, forget_stimuli, register_stimulus, render_frames
from touch_sim.skin.stimuli import LineStroke, NoTouch, StaticPress, Timeline, envelope, load_scene
from touch_sim.virtual_port import forget_devices


@pytest.fixture(autouse=True)
def _clean_registries():
    forget_devices()
    forget_stimuli()
    yield
    forget_devices()
    forget_stimuli()


# ---------------------------------------------------------------------- contact model
def test_kernel_carries_the_load_and_loses_some_off_the_edge():
    model = FingerContactModel()
    assert model.kernel(23.5, 23.5, 4.0).sum() == pytest.approx(1.0, abs=0.01)
    assert 0.2 < model.kernel(0.0, 0.0, 4.0).sum() < 0.35       # a corner press: three quarters fall off


def test_sensitivity_of_the_model_matches_the_paper():
    # cirillo2017 2.3: 0.2 N is detectable. The strongest taxel of a 0.2 N touch at the worst
    # spot (between four taxels) must clear the calibration's contact threshold.
    model = FingerContactModel()
    pitch = 47 / 12
    load = model.taxel_load([Contact(5 * pitch, 5 * pitch, 0.2)])
    worst_case = (1 - model.hysteresis * 2) * (1 - model.repeatability / 2)      # loading branch, low gain
    peak_pressure = load.max() * model.gain_counts_per_n * worst_case / 16000
    assert peak_pressure > SkinCalibrator().config.contact_on


def test_sliding_finger_shears_the_skin_along_its_motion():
    model = FingerContactModel()
    still = model.taxel_load([Contact(23.5, 23.5, 1.0)])
    moving = model.taxel_load([Contact(23.5, 23.5, 1.0, vx_mm_s=50.0)])
    tl, tr, bl, br = MODULE_TAXELS[14]            # the module under the finger
    delta = moving - still
    assert delta[tr] > 0 and delta[br] > 0 and delta[tl] < 0 and delta[bl] < 0
    assert delta.sum() == pytest.approx(0.0, abs=1e-12)       # shear moves load, adds none
    creeping = model.taxel_load([Contact(23.5, 23.5, 1.0, vx_mm_s=0.5)])
    assert np.array_equal(creeping, still)                   # below min_slide_mm_s: sticking


def test_bad_contacts_are_skipped():
    model = FingerContactModel()
    load = model.taxel_load([Contact(np.nan, 1.0, 1.0), Contact(1.0, 1.0, -2.0), Contact(1.0, 1.0, np.inf)])
    assert not load.any()


def test_hysteresis_gap_is_the_papers_and_leaves_no_residue():
    h = HysteresisPlay(0.1027, size=1)
    grid = np.linspace(0, 1, 101)
    up = np.array([h.update(np.array([u]))[0] for u in grid])
    down = np.array([h.update(np.array([u]))[0] for u in grid[::-1]])[::-1]
    gaps = down - up
    assert gaps.max() == pytest.approx(0.1027, abs=1e-3) and gaps.min() >= 0
    assert up[0] == down[0] == 0.0 and up[-1] == down[-1] == 1.0


def test_repeatability_spread_is_the_papers():
    n = 60
    press = Timeline([StaticPress(23.5, 23.5, 1.0, at_s=0.1 + 0.3 * k, for_s=0.1) for k in range(n)])
    device = SkinDevice(press, seed=4, noise_counts=0, drift_counts=0, taxel_drift_counts=0)
    sample = {round((0.15 + 0.3 * k) * 150) for k in range(n)}      # mid-press frames
    peaks = []
    for i in range(round(press.duration_s * 150)):
        t = i / 150
        raw = device.raw_frame(t).astype(float) - device.baseline(t)
        if i in sample:
            peaks.append(raw.max())
    assert len(peaks) == n
    spread = (max(peaks) - min(peaks)) / np.mean(peaks)
    assert 0.04 < spread <= 0.0677 + 2e-3                           # uniform gains: spread tends to R


def test_force_matrix_inverts_the_model_for_a_centred_slide():
    model = FingerContactModel(hysteresis=0.0)
    m = 14
    centre = (5 * 47 / 12, 5 * 47 / 12)            # module 14's centre: rows 4-5, cols 4-5
    load = model.taxel_load([Contact(*centre, 1.0, vx_mm_s=30.0, vy_mm_s=-40.0)])
    counts = model.mix_crosstalk(load / model.full_scale_n) * model.counts_per_unit
    q = counts[MODULE_TAXELS[m]] / 16000
    fx, fy, fz = model.force_matrix(16000) @ q
    share = model.kernel(*centre, 4.0)[MODULE_TAXELS[m]].sum()
    assert fz == pytest.approx(share * 1.0, rel=1e-6)
    assert (fx, fy) == pytest.approx((share * 0.5 * 0.6, share * 0.5 * -0.8), rel=1e-6)


# ---------------------------------------------------------------------- stimuli
def test_envelope_and_scripted_stimuli():
    assert envelope(1.0, 1.0, 2.0, 0.1) == 1.0 and envelope(0.85, 1.0, 2.0, 0.1) == 0.0
    press = StaticPress(10.0, 20.0, 2.0, at_s=0.5, for_s=1.0)
    assert press.contacts(0.2) == [] and press.contacts(1.0) == [Contact(10.0, 20.0, 2.0, 4.0)]
    assert press.contacts(0.475)[0].force_n == pytest.approx(1.0)
    line = LineStroke((0.0, 0.0), (10.0, 20.0), 1.0, at_s=1.0, for_s=2.0)
    (c,) = line.contacts(2.0)
    assert (c.x_mm, c.y_mm, c.vx_mm_s, c.vy_mm_s) == (5.0, 10.0, 5.0, 10.0)
    both = Timeline([press, line])
    assert len(both.contacts(1.2)) == 2 and both.duration_s == pytest.approx(line.duration_s + 0.5)
    assert isinstance(press, SkinStimulus) and isinstance(NoTouch(), SkinStimulus)
    with pytest.raises(ValueError, match='finite'):
        StaticPress(np.nan, 1.0, 1.0)


def test_yaml_scene(tmp_path):
    path = tmp_path / 'scene.yaml'
    path.write_text(textwrap.dedent("""\
        skin_scene: 1
        duration_s: 8
        events:
          - press: {x_mm: 23.5, y_mm: 23.5, force_n: 2.0, at_s: 1.0, for_s: 2.0}
          - line: {from_mm: [6, 6], to_mm: [41, 41], at_s: 3.5, for_s: 1.0, force_n: 1.5}
          - trace: {points: [[0, 0, 0], [10, 0, 200], [10, 10, 400]], at_s: 5.0}
        """))
    scene = load_scene(path)
    assert scene.duration_s == 8
    assert scene.contacts(2.0)[0].force_n == 2.0
    assert scene.contacts(4.0)[0].x_mm == pytest.approx(23.5)
    (c,) = scene.contacts(5.0)                                  # the trace's first point, at full force
    assert c.force_n == pytest.approx(1.5) and scene.contacts(4.96)[0].force_n < 1.5


@pytest.mark.parametrize(('text', 'line', 'message'), [
    ('skin_scene: 1\nevents:\n  - pres: {x_mm: 1, y_mm: 1, force_n: 1}\n', 3, "did you mean 'press'"),
    ('skin_scene: 1\nevents:\n  - press: {x_mm: 1, y_mm: 1}\n', 3, "missing key 'force_n'"),
    ('skin_scene: 1\nevents:\n  - line: {from_mm: [1], to_mm: [2, 2], force_n: 1}\n', 3, r'\[x_mm, y_mm\]'),
    ('skin_scene: 1\nevents:\n  - press: {x_mm: 1, y_mm: 1, force_n: -1}\n', 3, 'force_n'),
    ('skin_scene: 2\nevents: []\n', 1, 'format 2'),
    ('skin_scene: 1\nevents:\n  - press: 5\n', 3, 'needs a mapping'),
    ('skin_scene: 1\nevents:\n  - trace: {points: [[0, 0], [1, 1]]}\n', 3, r'\[x, y, t_ms\]'),
])
def test_yaml_scene_errors(tmp_path, text, line, message):
    path = tmp_path / 'bad.yaml'
    path.write_text(text)
    with pytest.raises(ConfigError, match=message) as info:
        load_scene(path)
    assert info.value.line == line


# ---------------------------------------------------------------------- device
def test_device_is_deterministic_and_frames_decode_to_raw():
    stim = StaticPress(20.0, 20.0, 1.0, at_s=0.1, for_s=0.2)
    a = render_frames(stim, duration_s=0.5, seed=5)
    b = render_frames(stim, duration_s=0.5, seed=5)
    c = render_frames(stim, duration_s=0.5, seed=6)
    assert a.shape == (76, 144) and a.dtype == np.uint16
    assert np.array_equal(a, b) and not np.array_equal(a, c)
    dev = SkinDevice(stim, seed=5)
    wire = dev.frame_bytes(70000, 0.0)
    assert wire[6:8] == (70000 & 0xFFFF).to_bytes(2, 'little')
    assert np.array_equal(decode_payload(wire[HEADER_SIZE:-4]), a[0])


def test_device_faults_and_saturation():
    dev = SkinDevice(StaticPress(23.5, 23.5, 30.0, at_s=0.1, for_s=1.0), seed=1, dead=[3], stuck=[4],
                     saturated=[140])
    rest = dev.raw_frame(0.0)
    hard = dev.raw_frame(0.5)
    assert rest[3] < 64 and hard[3] < 64
    assert rest[4] == hard[4] == dev.raw_frame(0.7)[4]
    assert rest[140] == hard[140] == 65535
    assert hard.max() == 65535 and np.count_nonzero(hard == 65535) > 1     # a hard press saturates 16 bits
    with pytest.raises(ValueError, match=r'0\.\.143'):
        SkinDevice(dead=[144])


def test_calibrated_virtual_device_with_dead_and_saturated_taxels():
    pitch = 47 / 12
    stim = Timeline([StaticPress(6 * pitch, 6 * pitch, 25.0, at_s=0.5, for_s=1.5),      # saturates the centre
                     StaticPress(2 * pitch, 9.5 * pitch, 1.0, at_s=2.5, for_s=1.0)])
    dead = 9 * 12 + 1                                # under the second press
    frames = render_frames(stim, seed=2, dead=[dead], saturated=[5])
    out = calibrate_frames(frames)
    t = np.arange(len(frames)) / 150
    hard = (t > 0.6) & (t < 1.9)
    assert out.contact[hard].all()
    assert out.contact_xy_mm[hard] == pytest.approx(np.full((hard.sum(), 2), 6 * pitch), abs=0.3)
    cal = SkinCalibrator()
    states = [cal.update(f) for f in frames]
    s = states[int(1.5 * 150)]
    assert s.saturated[[65, 66, 77, 78]].all() and not s.dead[[65, 66, 77, 78]].any()
    assert s.dead[dead] and s.dead[5] and s.dead.sum() == 2
    light = (t > 2.6) & (t < 3.4)
    assert out.contact[light].all()
    # The dead taxel pulls the point off by under a pitch (its pressure is missing).
    err = np.linalg.norm(out.contact_xy_mm[light] - [2 * pitch, 9.5 * pitch], axis=1)
    assert err.max() < pitch
    assert not out.contact[(t > 3.7)].any() and not out.contact[(t < 0.4)].any()


# ---------------------------------------------------------------------- URL handler
def read_all(port, clock, seconds: float, dec: SkinStreamDecoder):
    frames = []
    for _ in range(int(seconds * 150)):
        clock[0] += 1 / 150
        frames += dec.update(port.read(port.in_waiting))
    return frames


def open_port(url: str, clock: list[float]):
    port = serial.serial_for_url(url, do_not_open=True)
    port.attach_clock(lambda: clock[0])
    port.open()
    return port


def test_url_handler_matches_render_frames_and_survives_garbage():
    stim = LineStroke((6.0, 6.0), (41.0, 30.0), 1.5, at_s=0.5, for_s=1.0)
    register_stimulus('line', stim)
    clock = [0.0]
    port = open_port('skinsim://a?scene=line&garbage=0.2&seed=7', clock)
    dec = SkinStreamDecoder()
    frames = read_all(port, clock, 2.0, dec)
    port.close()
    port.close()                                                       # safe twice
    expected = render_frames(stim, duration_s=2.0, seed=7)
    assert [f.seq for f in frames] == list(range(len(frames))) and len(frames) >= 300
    assert np.array_equal(np.stack([f.raw for f in frames]), expected[:len(frames)])
    assert dec.stats.dropped_bytes > 0 and dec.stats.sequence_gaps == 0


def test_url_handler_corruption_is_counted():
    clock = [0.0]
    port = open_port('skinsim://b?corrupt=0.1&drop=0.05&seed=1', clock)
    dec = SkinStreamDecoder()
    frames = read_all(port, clock, 3.0, dec)
    s = dec.stats
    assert s.checksum_errors > 0 and s.sequence_gaps > 0
    # Every lost frame is accounted once: corrupt ones as checksum errors, the others as missed.
    assert len(frames) + s.frames_missed + s.checksum_errors == frames[-1].seq + 1


def test_url_handler_scene_file_and_faults(tmp_path):
    path = tmp_path / 'press.yaml'
    path.write_text('skin_scene: 1\nevents:\n  - press: {x_mm: 30, y_mm: 15, force_n: 1.5, at_s: 0.5, for_s: 1}\n')
    clock = [0.0]
    port = open_port(f'skinsim://c?scene={path}&dead=17,18&noise=10&drift=0', clock)
    dec = SkinStreamDecoder()
    cal = SkinCalibrator()
    states = [cal.update(f.raw) for f in read_all(port, clock, 1.2, dec)]
    assert states[-1].contact and states[-1].dead[[17, 18]].all()
    assert states[-1].contact_xy_mm == pytest.approx([30, 15], abs=0.5)


@pytest.mark.parametrize(('url', 'message'), [
    ('skinsim://d?scen=x', "did you mean 'scene'"),
    ('skinsim://e?scene=nothing_here', 'neither a registered stimulus nor a YAML file'),
    ('skinsim://f?noise=loud', 'number of ADC counts'),
    ('skinsim://g?dead=1,x', 'taxel indices'),
    ('skinsim://h?dead=200', '0..143'),
    ('skinsim://i?seed=abc', 'seed'),
])
def test_url_handler_bad_options(url, message):
    with pytest.raises(serial.SerialException, match=message):
        serial.serial_for_url(url)


def test_register_stimulus_rejects_non_stimuli():
    with pytest.raises(ValueError, match='contacts'):
        register_stimulus('x', object())
    with pytest.raises(ValueError, match='name'):
        register_stimulus('a&b', NoTouch())
