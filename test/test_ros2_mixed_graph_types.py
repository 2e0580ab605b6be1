"""Every message type of ours (msg/*.msg) and the standard ones our nodes publish cross between real rclpy
(ROS 2 Jazzy, Fast DDS) and our runtime (Cyclone DDS), both ways, with every field right.

test/ros2_cross_types.py runs one process per backend at once; each publishes a known message of every type
(every field away from its default: integers at the ends of their ranges, non-ASCII strings, full arrays and
sequences, nested and sequences of messages) and reports what it received of the other's.
"""
import json
import subprocess
import sys

import pytest
from dds_testing import allocate_domain
from ros2_cross_types import REPORT, STANDARD, sample, types
from ros2_testing import ROOT, require_ros2, ros2_env

SCRIPT = ROOT / 'test' / 'ros2_cross_types.py'


def _received(proc: subprocess.Popen) -> dict:
    for line in proc.stdout:
        if line.startswith(REPORT):
            return json.loads(line[len(REPORT):])
    return {}


@pytest.mark.ros2
def test_every_message_type_crosses_both_ways_with_every_field_right():
    require_ros2()
    with allocate_domain() as domain:
        env = ros2_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST',
                       ROS_PYTHON_CHECK_FIELDS='1')
        procs = {backend: subprocess.Popen([sys.executable, str(SCRIPT), '--backend', backend, '--peer', peer,
                                            '--timeout', '60'], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                           stderr=subprocess.PIPE, text=True, env=env, cwd=ROOT)
                 for backend, peer in (('ours', 'rclpy'), ('rclpy', 'ours'))}
        try:
            received = {backend: _received(proc) for backend, proc in procs.items()}
        finally:
            for proc in procs.values():
                proc.stdin.close()
            errors = {backend: proc.stderr.read() for backend, proc in procs.items()}
            for proc in procs.values():
                proc.wait(60)
    expected = {typename: json.loads(json.dumps(sample(typename))) for typename in types()}
    assert len(expected) == 17 + len(STANDARD)
    for backend in procs:
        assert procs[backend].returncode == 0, errors[backend][-3000:]
        assert sorted(received[backend]) == sorted(expected), (backend, errors[backend][-3000:])
        wrong = {typename: (received[backend][typename], value) for typename, value in expected.items()
                 if received[backend][typename] != value}
        assert wrong == {}, f'{backend} received (got, sent): {wrong}'


def test_the_samples_leave_no_field_at_its_default():
    from touch_graph.messages import from_dict, get_message, to_dict
    for typename in types():
        default, known = to_dict(get_message(typename)()), sample(typename)
        assert to_dict(from_dict(typename, known)) == json.loads(json.dumps(known)), typename
        same = [name for name in known if known[name] == default[name]]
        assert same == [], (typename, same)
