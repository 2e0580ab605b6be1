"""skin_driver + haptic_commands in one simulated-time graph on the virtual skin; the people scene; the launch file.

Everything the skin sees here is SYNTHETIC: scripted touches and simulated people on the
virtual skin (touch_driver.skin), decoded and calibrated by the real driver node.
"""

import argparse
import itertools
from pathlib import Path

import numpy as np
import pytest

import touch_graph.launch.cli as launch_cli
from touch_driver.skin.node import SkinDriverNode
from touch_gestures.skin.node import HapticCommandsNode
from touch_graph.errors import ConfigError
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_sim.skin.device import forget_stimuli, register_stimulus
from touch_sim.skin.people import SceneEvent, SkinScene, _trace_part, people_scene
from touch_sim.skin.stimuli import LineStroke, StaticPress, Timeline, load_scene
from touch_sim.skin.synthetic import random_touches
from touch_sim.virtual_port import forget_devices

ROOT = Path(__file__).resolve().parent.parent
PEOPLE_YAML = ROOT / 'config' / 'scenes' / 'skin_people.yaml'
NS = 1_000_000_000


@pytest.fixture(autouse=True)
def fresh_devices():
    forget_devices()
    forget_stimuli()
    yield
    forget_devices()
    forget_stimuli()


def run_graph(scene, seed=3, **params):
    """skin_driver on the virtual skin playing ``scene`` + haptic_commands; (node, commands, start_ns)."""
    register_stimulus('skin-commands-graph', scene)
    ctx = Context('sim')
    ctx.init()
    quiet = ['--ros-args', '--log-level', 'error']
    try:
        node = HapticCommandsNode(context=ctx, namespace='skin', cli_args=quiet,
                                  parameter_overrides=[Parameter(k, value=v) for k, v in params.items()])
        listener = Node('listener', context=ctx)
        commands = []
        listener.create_subscription(get_message('HapticCommand'), '/touch/haptic_command', commands.append, 100)
        driver = SkinDriverNode(context=ctx, namespace='skin', cli_args=quiet, parameter_overrides=[
            Parameter('port', value=f'skinsim://graph?scene=skin-commands-graph&seed={seed}')])
        start_ns = ctx.now_ns()
        executor = SingleThreadedExecutor(context=ctx)
        for n in (node, listener, driver):
            executor.add_node(n)
        executor.spin_for(scene.duration_s)
        for n in (driver, listener, node):
            n.destroy_node()
        return node, commands, start_ns
    finally:
        ctx.try_shutdown()


def at(cmd, start_ns):
    return (cmd.header.stamp.sec * NS + cmd.header.stamp.nanosec - start_ns) / NS


def event(kind, label, start, end):
    return SceneEvent(kind, label, 'script', start, end)


@pytest.fixture(scope='module')
def scripted_run():
    """Lines, then a scribble, a press, two fingers, a resting hand (cut at max_duration_s = 2 s), a line."""
    forget_devices()
    forget_stimuli()
    scribble = random_touches(1, seed=4)[0]
    parts = [
        (LineStroke((6, 23), (41, 23), 1.5, at_s=1.0, for_s=0.8), event('gesture', 'line_right', 1.0, 1.8)),
        (LineStroke((40, 30), (7, 28), 1.5, at_s=3.0, for_s=0.6), event('gesture', 'line_left', 3.0, 3.6)),
        _trace_part(scribble, 5.0, 'random', 'script'),
        (StaticPress(20, 25, 2.0, at_s=9.0, for_s=1.5), event('press', 'press', 9.0, 10.5)),
        (Timeline([LineStroke((10, y), (35, y), 1.5, at_s=12.0, for_s=0.8) for y in (13, 33)]),
         event('two_fingers', 'two fingers', 12.0, 12.8)),
        (StaticPress(30, 30, 1.5, at_s=14.0, for_s=4.0), event('resting_hand', 'resting hand', 14.0, 18.0)),
        (LineStroke((24, 6), (22, 41), 1.5, at_s=19.0, for_s=0.7), event('gesture', 'line_down', 19.0, 19.7)),
    ]
    scene = SkinScene(parts)
    return scene, *run_graph(scene, max_duration_s=2.0)


def test_traced_lines_give_their_commands_and_nothing_else_fires(scripted_run):
    scene, node, commands, start_ns = scripted_run
    got = [(c.command, round(at(c, start_ns), 2)) for c in commands]
    assert [c for c, _ in got] == ['move_right', 'move_left', 'stop'], got
    for (_command, t), ev in zip(got, scene.gestures(), strict=True):
        assert ev.end_s <= t <= ev.end_s + 0.1    # stamped at the lift (the ramp takes 50 ms)
    assert node.callback_errors == 0 and not node.stream.skipped


def test_the_other_touches_are_counted_for_what_they_are(scripted_run):
    _scene, node, _commands, _start = scripted_run
    outcomes = dict(node.outcomes)
    assert outcomes.pop('published') == 3
    assert outcomes.pop('multi_contact') == 1            # two fingers
    assert outcomes.pop('truncated') == 1                # the resting hand, cut at 2 s
    assert outcomes.pop('too_small') == 1                # the press
    assert outcomes == {'rejected_distance': 1}          # the scribble: a shape, but none of the codebook


def test_the_people_scene_loads_from_yaml_through_the_generator_hook():
    scene = load_scene(PEOPLE_YAML)
    same = people_scene(n_people=2, seed=1, gestures=('diagonal_down', 'diagonal_up', 'line_right', 'line_left',
                                                      'one', 'two', 'line_down', 'line_up'),
                        per_person=4, random_touches_n=2, presses=1, two_fingers=1, resting_hand_s=0.0,
                        pause_s=(1.2, 2.0), lead_s=2.0)
    assert isinstance(scene, SkinScene) and scene.synthetic and scene.events == same.events
    assert [e.kind for e in scene.events].count('gesture') == 8 and scene.duration_s < 38   # seen by --duration 40
    assert {e.person for e in scene.gestures()} == {'p1', 'p2'}
    gaps = [b.start_s - a.end_s for a, b in itertools.pairwise(scene.events)]
    assert scene.events[0].start_s == 2.0 and min(gaps) >= 1.2


def test_the_people_scene_fires_the_commands_of_its_gestures_only():
    scene = load_scene(PEOPLE_YAML)
    node, commands, start_ns = run_graph(scene, seed=1)
    fired = []
    for c in commands:
        t = at(c, start_ns)
        (ev,) = [e for e in scene.events if e.start_s - 0.1 <= t <= e.end_s + 0.1]
        fired.append((ev.kind, ev.label, c.gesture))
    assert fired == [('gesture', e.label, e.label) for e in scene.gestures()]
    assert node.outcomes['published'] == 8 and node.callback_errors == 0


@pytest.mark.parametrize('text, fragment', [
    ('generator: skin_people\noptions:\n  n_peeple: 2\n',
     "takes no option 'n_peeple' (did you mean 'n_people'?)"),
    ('generator: skin_people\noptions:\n  gestures: [lien_right]\n',
     'rejected the options: gestures must be some of'),
    ('generator: os:system\n', "no scene generator 'os:system'"),
    ('generator: skin_people\nevents: []\n', 'a generator or events, not both'),
    ('options: {seed: 1}\nevents: []\n', "'options' are the keyword arguments of a 'generator'"),
    ('duration_s: 3\n', "needs 'events: [...]' or 'generator: NAME'"),
])
def test_a_bad_generated_scene_is_an_error_at_its_line(tmp_path, text, fragment):
    path = tmp_path / 'scene.yaml'
    path.write_text('skin_scene: 1\n' + text)
    with pytest.raises(ConfigError) as info:
        load_scene(path)
    assert fragment in str(info.value) and str(path) in str(info.value)


def test_scene_touches_must_not_overlap():
    press = StaticPress(20, 20, 1.0, at_s=1.0, for_s=1.0)
    with pytest.raises(ValueError, match='touches overlap'):
        SkinScene([(press, event('press', 'a', 1.0, 2.0)), (press, event('press', 'b', 2.05, 3.0))])
    empty = SkinScene([])
    assert empty.contacts(1.0) == [] and empty.duration_s == 1.0
    scene = SkinScene([(press, event('press', 'a', 1.0, 2.0))])
    assert scene.contacts(0.9) == [] and scene.contacts(1.5) and scene.contacts(2.2) == []
    assert np.isclose(scene.duration_s, 3.05)


def test_the_launch_file_prints_the_commands_as_they_happen(capsys):
    parser = argparse.ArgumentParser()
    launch_cli.add_arguments(parser)
    args = parser.parse_args([str(ROOT / 'launch' / 'skin.launch.yaml'), '--sim-time', '--duration', '40',
                              '--no-bridge'])
    assert launch_cli.run(args) == 0
    captured = capsys.readouterr()
    assert ('3 node(s) running in this process: '
            '/skin/haptic_commands, /touch_monitor, /skin/skin_driver') in captured.err
    assert 'SYNTHETIC' in captured.err   # the node says where its codebook comes from
    lines = [line for line in captured.out.splitlines() if ' skin ' in line]
    expected = [e.label for e in load_scene(PEOPLE_YAML).gestures()]
    assert [line.split("from gesture '")[1].split("'")[0] for line in lines] == expected, captured.out
    assert all("command '" in line and '(trace, distance ' in line for line in lines)


def test_session_evaluation_scores_commands_against_the_ground_truth():
    from touch_lab.skin.session_eval import evaluate_sessions
    r = evaluate_sessions([1])
    assert (r['sessions'], r['gestures'], r['right'], r['wrong'], r['missed']) == (1, 8, 8, 0, 0)
    assert (r['other_touches'], r['false_commands']) == (4, 0)
    assert r['node_outcomes'] == {'published': 8, 'rejected_distance': 2, 'too_small': 1, 'multi_contact': 1}
