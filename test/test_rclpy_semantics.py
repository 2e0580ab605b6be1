"""Where rclpy's semantics are subtle, our runtime does what rclpy does: the same probe on both backends.

test/rclpy_semantics_probe.py runs each case (a raising timer, subscription, service, on-set-parameters
callback...) with only rclpy's API; EXPECTED is what real rclpy (Jazzy) gives. The fast test holds our
runtime to it; the ros2-marked one runs the probe on real rclpy, beside ours, and compares all three.
"""

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from dds_testing import allocate_domain
from ros2_peer import ros2_python

PROBE = Path(__file__).with_name('rclpy_semantics_probe.py')

#: Real rclpy's outcomes (Jazzy; test_real_rclpy_gives_the_same_outcomes checks them there).
EXPECTED = {
    'spin_once': 'raised ValueError: timer raised',
    'spin_once_next': 'returned',
    'rclpy.spin': 'raised ValueError: timer raised',
    'SingleThreadedExecutor.spin': 'raised ValueError: timer raised',
    'MultiThreadedExecutor.spin': 'raised ValueError: timer raised',
    'subscription': 'raised RuntimeError: subscription raised on hello',
    'service': "raised KeyError: 'service raised'",
    'service_client_done': False,
    'set_parameters': 'raised ArithmeticError: on-set raised',
    'set_parameters_atomically': 'raised ArithmeticError: on-set raised',
    'gain_after': 1,
    'set_parameters_accepted': [True],
    'set_parameters_service': 'raised ArithmeticError: on-set raised',
    'set_parameters_service_client_done': False,
    # In one process, as DDS matches QoS: a reliable subscription hears no best-effort publisher, a
    # transient-local one no volatile publisher.
    'qos reliable publisher -> reliable subscription': 'received',
    'qos reliable publisher -> best_effort subscription': 'received',
    'qos reliable publisher -> transient_local subscription': 'nothing',
    'qos best_effort publisher -> reliable subscription': 'nothing',
    'qos best_effort publisher -> best_effort subscription': 'received',
    'qos best_effort publisher -> transient_local subscription': 'nothing',
    'qos transient_local publisher -> reliable subscription': 'received',
    'qos transient_local publisher -> best_effort subscription': 'received',
    'qos transient_local publisher -> transient_local subscription': 'received',
}


def probe(python: str, backend: str, env: dict[str, str], errors: list | None = None) -> dict:
    result = subprocess.run([python, str(PROBE), backend], env=env, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    if errors is not None:
        errors.append(result.stderr)
    return json.loads(result.stdout.strip().splitlines()[-1])


def test_our_runtime_ends_spin_and_matches_qos_as_rclpy_does():
    env = {**os.environ, 'SOCIAL_TOUCH_NETWORK': '0', 'SOCIAL_TOUCH_SHIM': '1'}
    errors = []
    assert probe(sys.executable, 'ours', env, errors) == EXPECTED
    # rclpy's warnings, on the subscription's node and on the publisher's, for each unmatched pair
    warnings = [line for line in errors[0].splitlines() if 'incompatible QoS' in line]
    assert len(warnings) == 6 and "New publisher discovered on topic '/qos_best_effort_to_reliable', offering " \
        'incompatible QoS. No messages will be received from it. Last incompatible policy: RELIABILITY' in errors[0]
    assert "New subscription discovered on topic '/qos_reliable_to_transient_local', requesting incompatible QoS. " \
        'No messages will be sent to it. Last incompatible policy: DURABILITY' in errors[0]


@pytest.mark.ros2
@pytest.mark.skipif(ros2_python() is None, reason='SOCIAL_TOUCH_ROS2_PYTHON does not name a python with rclpy')
def test_real_rclpy_gives_the_same_outcomes():
    with allocate_domain() as domain:
        env = {k: v for k, v in os.environ.items() if k not in ('PYTHONPATH', 'SOCIAL_TOUCH_SHIM')}
        env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
        real = probe(ros2_python(), 'rclpy', env)
    ours = probe(sys.executable, 'ours', {**os.environ, 'SOCIAL_TOUCH_NETWORK': '0', 'SOCIAL_TOUCH_SHIM': '1'})
    assert real == EXPECTED
    assert ours == real


NODES = '''
from touch_graph.compat import Node


class Buggy(Node):
    def __init__(self, **kwargs):
        super().__init__('buggy', **kwargs)
        self.create_timer(0.5, self.tick)

    def tick(self):
        raise ValueError('a bug in a timer')


class Steady(Node):
    def __init__(self, **kwargs):
        super().__init__('steady', **kwargs)
        self.create_timer(0.1, lambda: None)
'''


def launch(tmp_path, *options, env=None):
    (tmp_path / 'buggy_nodes.py').write_text(NODES)
    path = tmp_path / 'scene.launch.yaml'
    path.write_text('launch:\n- node: {pkg: buggy_nodes, exec: Buggy, name: buggy}\n'
                    '- node: {pkg: buggy_nodes, exec: Steady, name: steady}\n')
    env = {**(env or os.environ), 'PYTHONPATH': str(tmp_path), 'SOCIAL_TOUCH_SHIM': '1'}
    return subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', str(path), *options], env=env,
                          capture_output=True, text=True, timeout=120)


def test_a_launched_node_whose_callback_raises_is_reported_dead_and_the_launch_exits_1(tmp_path):
    result = launch(tmp_path, '--sim-time', '--no-network', '--duration', '2')
    assert result.returncode == 1, result.stderr
    err = result.stderr
    assert '[ERROR] [launch]: node /buggy has died: a callback raised ValueError: a bug in a timer' in err
    assert "raise ValueError('a bug in a timer')" in err             # the traceback, to the line
    assert '[launch] 1 node(s) of this process died: /buggy: ValueError: a bug in a timer' in err
    assert err.count('has died') == 1                                   # /steady ran on to the end


def test_a_node_process_whose_callback_raises_exits_1_and_the_launch_reports_it(tmp_path, dds_domain):
    result = launch(tmp_path, '--processes', '--duration', '4')
    assert result.returncode == 1, result.stderr
    err = result.stderr
    assert re.search(r"\[ERROR\] \[buggy-1\]: process has died \[pid \d+, exit code 1, cmd", err), err
    assert '[buggy-1] [ERROR] [launch]: node /buggy has died: a callback raised ValueError' in err
    assert 'steady-2]: process has died' not in err
