"""The graph daemon lists a real rclpy node (Jazzy, Fast DDS) made just before the question.

Needs ``SOCIAL_TOUCH_ROS2_PYTHON`` (see ``ros2_peer.py``); skipped without it.
"""

import time

import pytest
from daemon_peer import daemon, domain_env
from ros2_peer import REPO, ros2_python, start_node, stop

from touch_graph.daemon import client
from touch_graph.daemon.address import daemon_address

pytestmark = [pytest.mark.ros2, pytest.mark.skipif(ros2_python() is None,
                                                 reason="SOCIAL_TOUCH_ROS2_PYTHON does not name a python with rclpy")]


@pytest.fixture
def env(dds_domain, monkeypatch):
    environ = domain_env(dds_domain)
    for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE', 'SOCIAL_TOUCH_DAEMON'):
        monkeypatch.setenv(key, environ[key])
    daemon(environ, 'start')
    try:
        yield environ
    finally:
        client.stop(daemon_address(environ))


def test_a_rclpy_node_made_just_before_the_question_is_listed(env):
    """Asked 0.1 s after the node exists (no command start-up in between), 10 of 10 times."""
    address = daemon_address(env)
    listed = []
    for i in range(10):
        node = start_node(f'fast_talker_{i}', {**env, 'PYTHONPATH': str(REPO)})
        try:
            time.sleep(0.1)
            listed.append(f'/fast_talker_{i}' in {n.name for n in client.fetch(address).nodes})
        finally:
            stop(node)
    assert listed == [True] * 10
