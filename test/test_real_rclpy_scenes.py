"""Every node of the shipped scenes on both backends: our runtime, and real rclpy (ROS 2 Jazzy).

test/ros2_scene.py runs the demo scene with the example behaviour node, the web view and the
Foxglove server (twelve nodes) on one backend, as a robot deploys it: each node in a process of
its own, and the counter in another, meeting on the DDS domain. The virtual devices of every run
play the same stretch of their scripted people; the counter counts the messages of every topic
the nodes publish from the devices' common time zero until the graph has drained after their
common end, and the drivers count what they published in that window. On our runtime it runs in
every suite; on real rclpy where ROS 2 is here (.ci/ros2-jazzy), and then its counts are compared
with our runtime's, topic by topic, events included (see :func:`close` for how closely; the frames
a starved recogniser reports missed widen the bound of what it publishes per frame). So do the
mixed graphs: the drivers on our runtime and the rest on real rclpy, and the reverse; there
``social-touch node list``, ``topic list`` and ``topic info -v`` must show every rclpy node in
every try. Also here: ``touch_graph.compat`` beside PyPI's rclpy, with and without the
colcon-built social_touch_msgs.
"""
import json
import os
import subprocess
import sys

import pytest
from dds_testing import allocate_domain
from ros2_testing import ROOT, require_ros2, ros2_env

SCRIPT = ROOT / 'test' / 'ros2_scene.py'
DURATION_S = 12.0
#: The backends of the runs: (the counter's and every node's but the drivers', the drivers').
RUNS = {'ours': ('ours', 'ours'), 'rclpy': ('rclpy', 'rclpy'), 'rclpy-drivers-ours': ('rclpy', 'ours'),
        'ours-drivers-rclpy': ('ours', 'rclpy')}
#: Tries of each graph tool in a mixed graph.
GRAPH_CHECKS = 5
#: The node classes of the shipped scenes (launch/*.yaml) and the example; each must start.
NODES = ['/bear/bear_driver', '/bear/bear_gestures', '/bear/bear_sensor_frames', '/foxglove_server',
         '/patch/patch_driver', '/patch/patch_gestures', '/skin/haptic_commands', '/skin/skin_driver',
         '/touch_behaviour', '/touch_monitor', '/touch_state', '/touch_view']
#: Topics a scene of this length always carries (rates, latched frames; events depend on the moment).
STEADY = ['/bear/bear_driver/status', '/bear/frame', '/diagnostics', '/patch/frame', '/patch/panels',
          '/patch/patch_driver/status', '/patch/posteriors', '/skin/frame', '/skin/skin_driver/status', '/tf_static',
          '/touch/sensor_level', '/touch/state']
#: The nodes that screen their driver's frames (touch_graph.frame_screen) and report the frames they missed.
RECOGNISERS = ['/bear/bear_gestures', '/patch/patch_gestures', '/skin/haptic_commands']

#: Topics whose messages are events of the touches (gestures, commands, what the behaviour does; touch_state
#: publishes on a change); every other topic goes at the rate of a device or a timer.
EVENTS = ('/behaviour/action', '/behaviour/look_at', '/behaviour/mood', '/behaviour/say', '/skin/candidate',
          '/skin/collision', '/touch/gesture', '/touch/haptic_command', '/touch/state', '/touch/subtype',
          '/touch/symbolic')

_runs: dict[str, dict] = {}


def scene_counts(run: str, tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The scene's JSON report of ``run`` (one of :data:`RUNS`; one run per test session)."""
    backend, drivers = RUNS[run]
    if run not in _runs:
        out = tmp_path_factory.mktemp('scene') / f'{run}.json'
        mixed = ['--drivers', drivers, '--graph-checks', str(GRAPH_CHECKS)] if drivers != backend else []
        with allocate_domain() as domain:
            # rclpy's field checks on: a wrong field type is an AssertionError naming the field, not an abort.
            env = ros2_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
                           ROS_PYTHON_CHECK_FIELDS='1')
            done = subprocess.run([sys.executable, str(SCRIPT), '--backend', backend, '--duration', str(DURATION_S),
                                   '--out', str(out), *mixed], capture_output=True, text=True, timeout=900, env=env,
                                  cwd=ROOT)
        assert done.returncode == 0, f'the scene {run} failed:\n{done.stderr[-4000:]}'
        _runs[run] = json.loads(out.read_text(encoding='utf-8'))
    return _runs[run]


def close(a: int, b: int, missed: int = 0) -> bool:
    """Counts of one topic in two runs of the scene: within a third, or 3 messages, plus ``missed``: the
    input frames its publishers reported missed in the two runs (rate topics only).

    Both runs play the same stretch of the scenes (one time zero and one end for every device) and count
    until the graph has drained (ros2_scene.py), so how far behind a starved node runs does not move
    what is counted. What still differs between runs: the timers' topics (status, /diagnostics) count
    over the window's wall seconds, which the drain lengthens by a second or two of the 12 s; and the
    drivers stamp each frame when they read it, so on a loaded machine (the CI's 2 cores, or ours with a
    dozen runnable processes) frames read in a burst carry closer stamps and a recogniser timing lifts
    and dwells by them can cut a gesture elsewhere. An event topic can then differ by a burst: one bear
    frame carries the subtype changes of all its touched sensors (up to 7 in the scene). 3 messages, or a
    third, covers both; a recogniser that sees other frames (other stamps, other values), a topic that
    goes silent, or a behaviour that never reacts is outside it (an unpaired poke gives
    /behaviour/look_at 0 against 3).

    A recogniser starved for longer than its queue holds loses frames for good: each costs at most one
    message of the topics it publishes per frame (/skin/contact, /patch/posteriors, /touch/sensor_level).
    It says so: its FrameScreen counts the frames its driver's sequence skipped (``frames_missed`` on
    /diagnostics, on either backend), the scene reports them per node, and they widen those topics' bound
    one for one.
    """
    return abs(a - b) <= max(3, 0.34 * max(a, b)) + missed


def missed_by_topic(report: dict) -> dict[str, int]:
    """Input frames that the publishers of each topic missed in the window of ``report`` (a scene run)."""
    missed = {node: window['frames_missed'] for node, window in report['inputs'].items()}
    return {topic: sum(missed.get(node, 0) for node in nodes) for topic, nodes in report['publishers'].items()}


@pytest.mark.slow
@pytest.mark.parametrize('run', ['ours', *(pytest.param(run, marks=pytest.mark.ros2) for run in RUNS if run != 'ours')])
def test_every_scene_node_runs_and_publishes_what_it_does_on_our_runtime(run, tmp_path_factory):
    if run != 'ours':
        require_ros2()
    report = scene_counts(run, tmp_path_factory)
    assert report['error'] is None, report['error']
    assert report['nodes'] == NODES
    assert report['drained_s'] is not None, 'the graph kept publishing after the devices ended'
    counts = report['counts']
    assert report['callback_errors'] in (0, None)
    assert [topic for topic in STEADY if not counts.get(topic)] == [], counts
    # The recognisers say what they took of their drivers' frames and what never reached them.
    assert sorted(report['inputs']) == RECOGNISERS and all(w['frames_admitted'] > 0 for w in report['inputs'].values())
    if run == 'ours':
        return
    if RUNS[run][0] != RUNS[run][1]:  # a mixed graph: our tools see every rclpy node, every time
        assert report['graph_checks'] and all(good == tries for good, tries in report['graph_checks'].values()), \
            report['graph_checks']
    ours_report = scene_counts('ours', tmp_path_factory)
    ours = ours_report['counts']
    print(json.dumps({topic: [ours.get(topic), counts.get(topic)] for topic in sorted({*ours, *counts})}))
    print(json.dumps({'inputs': [ours_report['inputs'], report['inputs']]}))
    # Rate topics: the frames their publishers missed in either run widen the bound (see close).
    missed = {topic: 0 if topic in EVENTS else ours_missed + missed_by_topic(report).get(topic, 0)
              for topic, ours_missed in missed_by_topic(ours_report).items()}
    assert sorted(counts) == sorted(ours)
    # What the drivers published in the window (their own counters) agrees, and so does what every topic carried.
    drivers = {name: (driver['frames'], report['drivers'][name]['frames'])
               for name, driver in scene_counts('ours', tmp_path_factory)['drivers'].items()}
    assert {name: pair for name, pair in drivers.items() if not close(*pair)} == {}, drivers
    differ = {topic: (ours[topic], counts[topic], missed.get(topic, 0)) for topic in counts
              if not close(ours[topic], counts[topic], missed.get(topic, 0))}
    assert differ == {}, f'(ours, {run}, frames missed) counts that differ: {differ}'
    # The events themselves: the recognisers and the behaviour react on this backend as on ours.
    assert sum(ours.get(topic, 0) for topic in EVENTS) > 0 and sum(counts.get(topic, 0) for topic in EVENTS) > 0


def _compat_probe(code: str, env: dict) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=120, env=env,
                          cwd=ROOT)


@pytest.mark.ros2
def test_compat_takes_pypi_rclpy_and_the_colcon_built_messages():
    require_ros2()
    run = _compat_probe(
        'import importlib.util\n'
        'from touch_graph import compat\n'
        'assert compat.USING_ROS and compat.Node.__module__ == "rclpy.node"\n'
        'frame = compat.get_message("social_touch_msgs/msg/SkinFrame")\n'
        'assert frame.__module__.startswith("social_touch_msgs.msg")\n'
        'assert compat.get_message("std_msgs/String") is compat.get_message("std_msgs/msg/String")\n'
        'trigger = compat.get_service("std_srvs/srv/Trigger")\n'
        'print(frame.__name__, trigger.Request.__name__, importlib.util.find_spec("rosidl_runtime_py") is None)\n',
        ros2_env())
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[:2] == ['SkinFrame', 'Trigger_Request']


@pytest.mark.ros2
def test_compat_without_the_interface_package_names_the_cure():
    require_ros2()
    env = ros2_env()
    # The environment without the colcon workspace: rclpy's wheels stay, social_touch_msgs goes.
    env['PYTHONPATH'] = os.pathsep.join(p for p in env.get('PYTHONPATH', '').split(os.pathsep)
                                        if p and 'social_touch_msgs' not in p and '/install' not in p)
    run = _compat_probe(
        'from touch_graph import compat\n'
        'assert compat.USING_ROS\n'
        'print(compat.get_message("std_msgs/msg/String").__name__)\n'
        'compat.get_message("social_touch_msgs/msg/SkinFrame")\n', env)
    assert run.returncode != 0 and run.stdout.strip() == 'String'
    # (From the source tree, the stand-in social_touch_msgs imports, and compat says it is not rosidl's.)
    assert 'ImportError: social_touch_msgs/msg/SkinFrame' in run.stderr and 'rclpy cannot send it' in run.stderr
    assert 'colcon build' in run.stderr and 'docs/ros2.md' in run.stderr


def test_compat_without_rclpy_is_our_runtime():
    run = _compat_probe('from touch_graph import compat\n'
                        'print(compat.USING_ROS, compat.Node.__module__,\n'
                        '      compat.get_message("social_touch_msgs/SkinFrame"))',
                        {**os.environ, 'SOCIAL_TOUCH_SHIM': '1'})
    assert run.returncode == 0, run.stderr
    assert run.stdout.split()[:2] == ['False', 'touch_graph.runtime.node']


def test_compat_under_rclpy_refuses_the_source_trees_stand_in_messages_and_names_the_cure():
    # What compat.get_message does once rclpy is importable (here on our runtime: the same function).
    from touch_graph.compat import _generated
    with pytest.raises(ImportError, match=r'not from the package rosidl generates: rclpy cannot send.*docs/ros2\.md'):
        _generated('social_touch_msgs/msg/SkinFrame', 'msg')
    with pytest.raises(ImportError, match=r'social_touch_msgs\.msg has no type NoSuchType'):
        _generated('social_touch_msgs/NoSuchType', 'msg')
    with pytest.raises(ValueError, match="'std_msgs/srv/String' is not a msg type name"):
        _generated('std_msgs/srv/String', 'msg')
