"""``social-touch launch`` in one process on real rclpy (ROS 2 Jazzy), as on our runtime.

With ROS 2 sourced (and no SOCIAL_TOUCH_SHIM=1), the node classes are rclpy nodes: the launch
runs them on rclpy's context and executor, and a node with rclpy's plain constructor
(``__init__(self)``) gets its launch entry's name, namespace, remaps and parameters through
rclpy's own keywords.
"""
import subprocess
import sys
import textwrap

import pytest
from dds_testing import allocate_domain
from ros2_testing import ROOT, require_ros2, ros2_env

pytestmark = pytest.mark.ros2

PLAIN_NODE = textwrap.dedent('''
    from rclpy.node import Node
    from std_msgs.msg import String


    class Plain(Node):
        """rclpy's shape: no keyword arguments."""

        def __init__(self):
            super().__init__('plain')
            greeting = self.declare_parameter('greeting', 'none').value
            self.create_publisher(String, 'said', 1)
            topics = sorted(name for name, _ in self.get_publisher_names_and_types_by_node(
                self.get_name(), self.get_namespace()))
            print('PLAIN', self.get_fully_qualified_name(), greeting, '/ns/heard' in topics, flush=True)
''')

PLAIN_LAUNCH = textwrap.dedent('''
    launch:
    - node:
        pkg: plain_rclpy_node
        exec: Plain
        name: renamed
        namespace: /ns
        remap: [{from: said, to: heard}]
        param: [{name: greeting, value: hello}]
''')


def _launch(argv, env, timeout=180):
    return subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', *argv], capture_output=True,
                          text=True, timeout=timeout, env=env, cwd=ROOT)


def test_a_plain_constructor_rclpy_node_gets_its_launch_entry(tmp_path):
    require_ros2()
    (tmp_path / 'plain_rclpy_node.py').write_text(PLAIN_NODE)
    (tmp_path / 'plain.launch.yaml').write_text(PLAIN_LAUNCH)
    with allocate_domain() as domain:
        env = ros2_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
        env['PYTHONPATH'] = f'{tmp_path}:{env.get("PYTHONPATH", "")}'
        run = _launch([str(tmp_path / 'plain.launch.yaml'), '--duration', '0.5'], env)
    assert run.returncode == 0, run.stderr[-3000:]
    assert 'PLAIN /ns/renamed hello True' in run.stdout.splitlines(), (run.stdout, run.stderr[-3000:])
    assert '1 node(s) running in this process: /ns/renamed' in run.stderr


def test_the_skin_scene_runs_in_one_rclpy_process_and_publishes(tmp_path):
    require_ros2()
    with allocate_domain() as domain:
        env = ros2_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
        launch = subprocess.Popen([sys.executable, '-m', 'touch_lab.cli.main', 'launch', 'launch/skin.launch.yaml',
                                   'monitor:=false', '--duration', '40'], env=env, cwd=ROOT, text=True,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        try:
            # A user of our runtime beside it: the skin's frames, from the rclpy process.
            echo = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'topic', 'echo', '/skin/frame',
                                   'social_touch_msgs/msg/SkinFrame', '-n', '3', '--timeout', '30'],
                                  capture_output=True, text=True, timeout=120, env={**env, 'SOCIAL_TOUCH_SHIM': '1'},
                                  cwd=ROOT)
        finally:
            launch.terminate()
            _, err = launch.communicate(timeout=60)
    assert echo.returncode == 0 and echo.stdout.count('sequence: ') == 3, (echo.stdout[-2000:], echo.stderr[-2000:])
    assert launch.returncode == 0, err[-3000:]
    assert '2 node(s) running in this process: /skin/haptic_commands, /skin/skin_driver' in err, err[-3000:]
    assert 'remap rule' not in err  # the launch arguments are not taken for rclpy's --ros-args
    assert '[launch] all nodes stopped' in err


def test_sim_time_on_rclpy_is_a_clear_error():
    require_ros2()
    run = _launch(['launch/skin.launch.yaml', '--sim-time', '--duration', '1'], ros2_env())
    assert run.returncode != 0
    assert '--sim-time' in run.stderr and 'use_sim_time' in run.stderr and 'Traceback' not in run.stderr
