"""The bear in the node graph: the harness's cycles against the device's bytes decoded and calibrated directly,
driver + recognisers in one simulated-time graph, the generated people scene and the bear launch file (all data
synthetic)."""

from __future__ import annotations

import argparse
import doctest
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import touch_sim.bear.render as render_module
from touch_driver.bear.body_map import BodyMap
from touch_driver.bear.calibration import BearCalibrator
from touch_driver.bear.node import BearDriverNode
from touch_driver.bear.protocol import BearDecoder
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.bear.symbolic import CANDIDATE, END, START, WITHDRAWN
from touch_graph.errors import ConfigError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
from touch_lab.bear import cli
from touch_sim import virtual_port
from touch_sim.bear.device import BearDevice
from touch_sim.bear.people import BearScene
from touch_sim.bear.render import BearCycles
from touch_sim.scenes import (
    BearScript,
    BearTouch,
    load_stimulus,
    register_stimulus,
    registered_stimuli,
    unregister_stimulus,
)
from touch_sim.virtual_port import forget_devices

ROOT = Path(__file__).resolve().parents[1]
BODY = BodyMap.default()
HUG = ('chest_left', 'back_upper', 'back_middle', 'side_left_upper', 'side_right_lower')


def touch(names, start, duration, **kw) -> BearTouch:
    return BearTouch(channels=tuple(BODY.by_name(n).channel for n in names), start=start, duration=duration, **kw)


SCRIPT = BearScript([touch(HUG, 5.0, 6.0),
                     touch(['head1', 'head2'], 14.0, 5.0, envelope='pulse', freq_hz=1.2, duty=0.6),
                     touch(['foot_left_sole'], 21.0, 1.0, level=0.8)])


@pytest.fixture(autouse=True)
def fresh_devices():
    forget_devices()
    yield
    forget_devices()


def decoded_directly(script, rate_hz, seed, device_options, duration_s):
    """The reference: every frame of the device's bytes through a BearDecoder and a BearCalibrator with the
    driver's defaults, stamped with its scan time."""
    device = BearDevice(script, rate_hz=rate_hz, seed=seed, **device_options)
    decoder, calibrator = BearDecoder(), BearCalibrator(rate_hz=rate_hz)
    out = []
    for index in range(int(np.ceil(duration_s * rate_hz - 1e-9))):
        for scan in decoder.update(device.frame_bytes(index, index * device.frame_period)):
            levels = calibrator.update(scan.raw)
            out.append((index / rate_hz, levels.level, levels.faults != 0))
    return out


def test_the_harness_gives_the_devices_bytes_as_the_driver_decodes_and_calibrates_them() -> None:
    options = {'scan': 'sequential', 'noise': 3.0, 'faults': {'head3': 'dead'}}
    graph = list(BearCycles(SCRIPT, rate_hz=3.4, seed=5, device_options=options).cycles(25.0))
    direct = decoded_directly(SCRIPT, 3.4, 5, options, 25.0)
    assert len(graph) == len(direct) == 85
    assert all(np.array_equal(g.levels, level) and np.array_equal(g.faulty, faulty)
               for g, (_, level, faulty) in zip(graph, direct, strict=True))
    assert any(g.levels[BODY.by_name('head2').channel] > 0.5 for g in graph)
    # A cycle is stamped when the driver's poll timer (2 x 3.4 Hz) read the frame: 0 to one poll after its scan.
    lag = np.array([g.t - t for g, (t, _, _) in zip(graph, direct, strict=True)])
    assert np.all(lag >= -1e-6) and np.all(lag <= 1 / 6.8 + 1e-6)
    assert lag[0] == pytest.approx(1 / 6.8, abs=1e-6) and np.median(np.abs(lag)) < 1e-6
    other = list(BearCycles(SCRIPT, rate_hz=3.4, seed=6, device_options=options).cycles(5.0))
    assert not all(np.array_equal(a.levels, b.levels) for a, b in zip(other, graph[:len(other)], strict=True))


def test_the_harness_cleans_up_and_reports_counters() -> None:
    source = BearCycles(SCRIPT, rate_hz=3.4, seed=1, calibrator_options={'baseline_frames': 5})
    cycles = list(source.cycles(4.0))
    assert len(cycles) == 14 and source.counters['frames'] >= 14 and source.counters['checksum_errors'] == 0
    leftovers = lambda: [n for n in (*registered_stimuli(), *virtual_port._registry) if n.startswith('bear-harness-')]  # noqa: E731
    assert not leftovers()
    early = BearCycles(SCRIPT, rate_hz=3.4, seed=1).cycles(30.0)
    next(early)
    assert leftovers()
    early.close()                                            # a caller that stops early leaves nothing behind
    assert not leftovers()


def test_bear_cycles_reject_options_a_url_cannot_carry() -> None:
    with pytest.raises(ValueError, match="'baseline_range' cannot be set through a bearsim URL"):
        BearCycles(SCRIPT, device_options={'baseline_range': (0, 10)})
    with pytest.raises(ValueError, match='not bear_driver parameters'):
        BearCycles(SCRIPT, calibrator_options={'gain': 2.0})
    with pytest.raises(ValueError, match='rate_hz'):
        BearCycles(SCRIPT, rate_hz=0.0)


def test_render_doctests() -> None:
    result = doctest.testmod(render_module)
    assert result.failed == 0 and result.attempted > 0


def test_driver_and_recognisers_in_one_graph_report_a_hug_and_a_head_pat() -> None:
    register_stimulus('bear-node-graph', SCRIPT)
    ctx = Context('sim')
    ctx.init()
    gestures = BearGesturesNode(context=ctx, namespace='bear', parameter_overrides=[
        Parameter('subtype_classifier', value='rule')])
    driver = BearDriverNode(context=ctx, namespace='bear', parameter_overrides=[
        Parameter('port', value='bearsim://bng?scene=bear-node-graph&seed=4')])
    listener = Node('listener', context=ctx)
    got = {'SymbolicGesture': [], 'TouchSubtype': [], 'SensorLevel': []}
    for kind, topic in (('SymbolicGesture', '/touch/symbolic'), ('TouchSubtype', '/touch/subtype'),
                        ('SensorLevel', '/touch/sensor_level')):
        best_effort = QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT)  # hears any publisher
        listener.create_subscription(get_message(kind), topic, got[kind].append, best_effort)
    executor = SingleThreadedExecutor(context=ctx)
    for node in (gestures, driver, listener):
        executor.add_node(node)
    start_s = ctx.now_ns() * 1e-9
    executor.spin_for(30.0)
    unregister_stimulus('bear-node-graph')

    def rel(stamp) -> float:
        return stamp.sec + stamp.nanosec * 1e-9 - start_s

    events = [(m.gesture, m.state, rel(m.onset), rel(m.header.stamp), tuple(m.sensors)) for m in got['SymbolicGesture']]
    # The 1 s touch on the sole is shorter than foot_rub's 2 s dwell: a poke, no gesture.
    decided = [e for e in events if e[1] in (START, END)]
    assert [(e[0], e[1]) for e in decided] == [('hug', START), ('hug', END), ('head_pat', START), ('head_pat', END)]
    hug_start, hug_end, pat_start, pat_end = decided
    # The first word: a CANDIDATE of each on the scan its filter first matched, and the sole's touch withdrawn.
    said = {(e[0], e[1]): e for e in reversed(events) if e[1] in (CANDIDATE, WITHDRAWN)}
    for name, begun in (('hug', hug_start), ('head_pat', pat_start)):
        assert said[name, CANDIDATE][2] == said[name, CANDIDATE][3] == begun[2]
    assert said['foot_rub', CANDIDATE][3] < said['foot_rub', WITHDRAWN][3] and ('foot_rub', WITHDRAWN) in said
    assert 5.0 <= hug_start[2] < 5.5 and hug_start[3] - hug_start[2] >= 2.0 and set(hug_start[4]) == set(HUG)
    assert 11.0 <= hug_end[3] < 11.0 + 1.5 + 0.7                 # released: after the 1.5 s gap, within 2 scans
    assert 14.0 <= pat_start[2] < 14.5 and set(pat_start[4]) <= {'head1', 'head2'}
    assert 19.0 <= pat_end[3] < 21.5
    subtypes = got['TouchSubtype']
    assert next(m.subtype for m in subtypes if m.sensor == 'foot_left_sole') == 'poke'
    assert {m.sensor for m in subtypes} >= {*HUG, 'head1', 'head2'}
    assert any(m.sensor == 'back_upper' and m.subtype == 'hold' and m.peak_amplitude > 0.9 for m in subtypes)
    assert [m.subtype for m in subtypes if m.sensor == 'head2'] == ['poke', 'pet', 'none']   # pats: the rule's pet
    assert len(got['SensorLevel']) == gestures.frames == driver.frames and 100 <= gestures.frames <= 104
    assert not gestures.skipped and ctx.callback_errors == 0
    for node in (listener, driver, gestures):
        node.destroy_node()
    ctx.shutdown()


def test_the_people_scene_file_makes_a_labelled_synthetic_scene() -> None:
    scene = load_stimulus(ROOT / 'config' / 'scenes' / 'bear_people.yaml', sensor='bear')
    assert isinstance(scene, BearScene) and scene.synthetic
    assert sorted(lab.label for lab in scene.labels) == ['head_pat', 'head_pat', 'hug', 'hug', 'tickle', 'tickle']
    assert scene.duration_s < 60.0 and min(lab.start_s for lab in scene.labels) >= 4.0


@pytest.mark.parametrize('body, message', [
    ('generator: os:system\n', "no scene generator 'os:system'"),
    ('generator: touch_sim.bear.people:make_scene\n', "no scene generator 'touch_sim.bear.people:make_scene'"),
    ('generator: bear_peple\n', "did you mean 'bear_people'"),
    ('generator: bear_people\noptions: {n_peple: 2}\n', "did you mean 'n_people'"),
    ('generator: bear_people\noptions: {n_people: 0}\n', 'n_people must be >= 1'),
    ('generator: bear_people\ntouches: []\n', 'not both'),
    ('options: {n_people: 2}\ntouches: []\n', "'options' are the keyword arguments of a 'generator'"),
])
def test_a_bad_generated_scene_gives_one_clear_error_with_file_and_line(tmp_path: Path, body: str, message: str):
    path = tmp_path / 'scene.yaml'
    path.write_text('sensor: bear\n' + body)
    with pytest.raises(ConfigError) as err:
        load_stimulus(path, sensor='bear')
    assert message in str(err.value) and str(path) in str(err.value) and err.value.line is not None


def test_eval_bear_runs_through_the_driver_node(capsys) -> None:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(['--json', '--quiet', '--people', '1', '--train-people', '1', '--reps', '1'])
    assert cli.run(args) == 0
    result = json.loads(capsys.readouterr().out)
    assert 'synthetic' in result['data']
    assert result['driver']['frames'] >= result['cycles'] > 100 and result['driver']['checksum_errors'] == 0
    assert 0.0 <= result['subtype_accuracy'] <= 1.0 and 0.0 <= result['symbolic_accuracy'] <= 1.0


def test_the_bear_launch_file_prints_gestures_as_they_happen() -> None:
    env = {**os.environ, 'SOCIAL_TOUCH_SHIM': '1'}
    launch = str(ROOT / 'launch' / 'bear.launch.yaml')
    proc = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', launch, '--sim-time', '--duration',
                           '60', '--no-bridge'],
                          capture_output=True, text=True, timeout=120, cwd=ROOT, env=env)
    assert proc.returncode == 0, proc.stderr
    lines = [line for line in proc.stdout.splitlines() if ' bear ' in line]
    started = [line.split(' bear ')[1].split()[0] for line in lines if 'started' in line]
    assert {'hug', 'head_pat'} <= set(started), proc.stdout
    assert sum('ended after' in line for line in lines) >= len(started) - 1
    assert 'error' not in proc.stderr.lower(), proc.stderr
