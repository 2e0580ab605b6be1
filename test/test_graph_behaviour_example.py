"""The example behaviour node (examples/touch_behaviour) in its own process beside the demo's recognisers.

The test process runs the demo scene's bear recogniser and touch_state on DDS, fed with scripted
bear frames (synthetic: a hug, then a poke on the belly), and publishes a haptic command, a patch
stroke and two state queries; the example node runs in a process of its own, as a user starts it
from another terminal, and the test checks what it says, where it looks and how its mood goes.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from dds_testing import SpinningGraph, wait_until
from test_bear_node import FITTED, ch

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.touch_state.node import TouchStateNode
from touch_graph.compat import sensor_data_qos
from touch_graph.messages import get_message
from touch_graph.runtime import Node, Parameter

EXAMPLE = Path(__file__).resolve().parents[1] / 'examples' / 'touch_behaviour'
BearFrame = get_message('BearFrame')
HapticCommand = get_message('HapticCommand')
GestureEvent = get_message('GestureEvent')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')
String = get_message('std_msgs/msg/String')
Float32 = get_message('std_msgs/msg/Float32')
PointStamped = get_message('geometry_msgs/msg/PointStamped')
RATE = 3.4


def bear_frame(i: int, touched: dict[int, float]) -> object:
    level = np.zeros(64, np.float32)
    for channel, value in touched.items():
        level[channel] = value
    ns = round(i / RATE * 1e9)
    return BearFrame(header=Header(stamp=Time(sec=1000 + ns // 10**9, nanosec=ns % 10**9), frame_id='bear_link'),
                     sequence=i, level=level, active=(level >= 0.3).tolist(), fitted=FITTED,
                     faults=np.zeros(64, np.uint8))


@pytest.fixture
def example_process(dds_domain):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(EXAMPLE), os.environ.get('PYTHONPATH', '')]))
    proc = subprocess.Popen([sys.executable, '-c', 'from touch_behaviour.node import main; main()'], env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    yield proc
    if proc.poll() is None:
        proc.terminate()
    proc.communicate(timeout=20)


def test_the_example_greets_a_hug_looks_at_a_poke_calms_on_stroking_obeys_and_answers_queries(example_process):
    graph = SpinningGraph()
    heard = {'say': [], 'look_at': [], 'mood': [], 'action': []}
    try:
        def build():
            bear = BearGesturesNode(context=graph.context, namespace='bear',
                                    parameter_overrides=[Parameter('subtype_classifier', value='rule')])
            state = TouchStateNode(context=graph.context)
            script = Node('script', context=graph.context)
            for name, kind in (('say', String), ('look_at', PointStamped), ('mood', Float32), ('action', String)):
                script.create_subscription(kind, f'/behaviour/{name}', heard[name].append, 50)
            pubs = {'frame': script.create_publisher(BearFrame, '/bear/frame', sensor_data_qos(50)),
                    'command': script.create_publisher(HapticCommand, '/touch/haptic_command', 10),
                    'gesture': script.create_publisher(GestureEvent, '/touch/gesture', 10),
                    'query': script.create_publisher(String, '/behaviour/query', 10)}
            for node in (bear, state, script):
                graph.executor.add_node(node)
            return script, pubs
        script, pubs = graph.call(build)
        wait_until(lambda: all(pub.get_subscription_count() >= 1 for pub in pubs.values()), 30,
                   'the example node to subscribe')
        wait_until(lambda: script.count_publishers('/behaviour/say') >= 1, 30, "the example's publishers")

        hug = dict.fromkeys(ch('chest_left', 'chest_right', 'back_upper', 'back_middle', 'side_left_upper',
                               'side_right_upper'), 0.8)
        belly = ch('belly_middle')[0]
        script_frames = [bear_frame(i, hug if 2 <= i < 14 else {}) for i in range(40)]
        script_frames += [bear_frame(i, {belly: 0.9} if i in (40, 41) else {}) for i in range(40, 44)]
        for msg in script_frames:       # paced: the recogniser's queue keeps the last 10 frames
            graph.call(pubs['frame'].publish, msg)
            time.sleep(0.02)
        wait_until(lambda: any('hug' in m.data for m in heard['say']), 20, 'the greeting')
        wait_until(lambda: heard['look_at'], 20, 'a look at the poke')

        graph.call(pubs['command'].publish, HapticCommand(gesture='line_left_to_right', command='stop'))
        wait_until(lambda: heard['action'], 20, 'the command to be obeyed')
        assert [m.data for m in heard['action']] == ['stop']

        wait_until(lambda: len(heard['mood']) >= 2, 20, 'the mood after the touches')
        moods_before = len(heard['mood'])
        graph.call(pubs['gesture'].publish, GestureEvent(gesture='stroke', probability=0.99))
        wait_until(lambda: len(heard['mood']) > moods_before, 20, 'a mood change after the stroke')

        graph.call(pubs['query'].publish, String(data='torso_front'))
        wait_until(lambda: any(m.data.startswith('I feel') for m in heard['say']), 20, 'the answer to the query')
        graph.call(pubs['query'].publish, String(data='tail'))
        wait_until(lambda: any('unknown region' in m.data for m in heard['say']), 20, 'the unknown region answer')

        # The paper's rule reads every new touch as a poke first, so the hug's sensors drew looks too; the
        # last look is the belly's poke.
        look = heard['look_at'][-1]
        position = BodyMap.default().by_name('belly_middle').position
        assert look.header.frame_id == 'bear_link'
        assert (look.point.x, look.point.y, look.point.z) == pytest.approx(position, abs=1e-9)
        moods = [m.data for m in heard['mood']]       # float32 on the wire: tolerances of 1e-6
        # From 0.5: +0.2 for the hug and +0.3 per poke, clamped at 1 (the rule reads the releases as pets,
        # -0.3 each, so the level before the stroke varies), then -0.3 for the stroke, clamped at 0.
        assert max(moods[:moods_before]) == pytest.approx(1.0, abs=1e-6)
        assert moods[moods_before] == pytest.approx(max(0.0, moods[moods_before - 1] - 0.3), abs=1e-6)
        answer = next(m.data for m in heard['say'] if m.data.startswith('I feel'))
        assert answer.endswith('on my torso_front')
    finally:
        graph.close()
    assert example_process.poll() is None, example_process.stderr.read()


@pytest.fixture
def installed_example(tmp_path, monkeypatch):
    """The example as an installed distribution: its entry points in a dist-info on sys.path, as pip leaves them."""
    dist = tmp_path / 'touch_behaviour-0.1.0.dist-info'
    dist.mkdir()
    (dist / 'METADATA').write_text('Metadata-Version: 2.1\nName: touch_behaviour\nVersion: 0.1.0\n')
    (dist / 'entry_points.txt').write_text('[social_touch.nodes]\n'
                                           'touch_behaviour = touch_behaviour.node:TouchBehaviour\n')
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.syspath_prepend(str(EXAMPLE))
    yield
    for name in [n for n in sys.modules if n.startswith('touch_behaviour')]:
        del sys.modules[name]


BUGGY = """
from touch_behaviour.node import TouchBehaviour


class Buggy(TouchBehaviour):
    def on_command(self, msg):
        if msg.command == 'explode':
            raise RuntimeError('a bug in the behaviour')
        super().on_command(msg)
"""


def test_the_example_launches_by_its_package_name_and_a_node_whose_callback_raises_dies_the_others_go_on(
        installed_example, tmp_path, capfd):
    from touch_graph.launch import LaunchRunner, evaluate_launch
    (tmp_path / 'buggy_behaviour.py').write_text(BUGGY)
    launch = tmp_path / 'scene.launch.yaml'
    launch.write_text('launch:\n- node: {pkg: touch_behaviour, exec: touch_behaviour, name: behaviour}\n'
                      '- node: {pkg: buggy_behaviour, exec: Buggy, name: buggy}\n')
    runner = LaunchRunner(evaluate_launch(launch).nodes, sim_time=True, network=False)
    runner.start()
    try:
        behaviour, buggy = runner.nodes
        assert type(behaviour).__name__ == 'TouchBehaviour' and behaviour.get_name() == 'behaviour'
        script = Node('script', context=runner.context)
        runner.executor.add_node(script)
        said = []
        script.create_subscription(String, '/behaviour/say', said.append, 10)
        commands = script.create_publisher(HapticCommand, '/touch/haptic_command', 10)
        symbolic = script.create_publisher(get_message('SymbolicGesture'), '/touch/symbolic', 10)
        for command in ('explode', 'stop', 'explode'):
            commands.publish(HapticCommand(command=command))
        symbolic.publish(get_message('SymbolicGesture')(gesture='hug', state=1))
        runner.spin(0.5)
        # The buggy node died on its first 'explode', as an rclpy node would; the launch says which and why.
        assert runner.nodes == [behaviour] and buggy.callback_errors == 1 and behaviour.callback_errors == 0
        assert runner.died == ['/buggy: RuntimeError: a bug in the behaviour']
        texts = [m.data for m in said]
        assert texts.count('OK: explode.') == 2 and texts.count('OK: stop.') == 1      # the other node went on
        assert texts.count('Hello! Thank you for the hug.') == 1
        err = capfd.readouterr().err
        assert '[ERROR] [launch]: node /buggy has died: a callback raised RuntimeError: a bug in the behaviour' in err
        assert 'Traceback' in err and "raise RuntimeError('a bug in the behaviour')" in err
    finally:
        runner.shutdown()
