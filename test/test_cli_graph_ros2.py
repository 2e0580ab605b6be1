"""``social-touch node list | topic list | topic echo | topic hz | record`` and Foxglove beside a real
rclpy node (Jazzy, Fast DDS).

Needs ``SOCIAL_TOUCH_ROS2_PYTHON`` (see ``ros2_peer.py``); skipped without it.
"""

import pytest
from dds_testing import allocate_domain
from ros2_peer import ros2_python, start_node, stop
from test_cli_graph_commands import GRAPH_COMMANDS, cli, graph_env

from touch_graph.cli import main as cli_main
from touch_graph.dds.tool import GraphTool

pytestmark = [pytest.mark.ros2, pytest.mark.skipif(ros2_python() is None,
                                                 reason="SOCIAL_TOUCH_ROS2_PYTHON does not name a python with rclpy")]


@pytest.fixture
def domain_env(monkeypatch):
    with allocate_domain() as domain:
        env = graph_env(domain)
        for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE'):
            monkeypatch.setenv(key, env[key])
        for key in ('ROS_STATIC_PEERS', 'CYCLONEDDS_URI', 'ROS_DISTRO'):
            monkeypatch.delenv(key, raising=False)
        monkeypatch.setattr(cli_main, 'COMMANDS', {**cli_main.COMMANDS, **GRAPH_COMMANDS})
        yield env


def test_node_and_topic_list_show_a_rclpy_node_started_just_before(domain_env, capsys):
    for i in range(3):
        node = start_node(f'fast_talker_{i}', domain_env)
        try:
            code, out, err = cli(capsys, 'node', 'list')
            assert code == 0 and f'/fast_talker_{i}' in out.split(), (i, out, err)
            code, out, err = cli(capsys, 'topic', 'list')
            assert code == 0 and '/fast_chatter' in out.split(), (i, out, err)
        finally:
            stop(node)


def test_a_tool_knows_every_participant_complete(domain_env):
    node = start_node('fast_talker', domain_env)
    try:
        with GraphTool('probe') as tool:
            assert tool.discovery.incomplete() == []
            names = [n.name for n in tool.graph().visible_nodes()]
            assert names == ['/fast_talker']
            info = tool.graph().topics['/fast_chatter']
            assert [ep.node for ep in info.publishers] == ['/fast_talker']
    finally:
        stop(node)


def test_echo_and_hz_hear_a_best_effort_rclpy_publisher(domain_env, capsys):
    node = start_node('fast_talker', domain_env)
    try:
        code, out, err = cli(capsys, 'topic', 'echo', '/fast_chatter', 'std_msgs/msg/String', '-n', '2',
                             '--timeout', '10')
        assert code == 0 and out.count('data: fast ') == 2, err
        code, out, err = cli(capsys, 'topic', 'hz', '/fast_chatter', '--duration', '2', '--wall-time')
        assert code == 0 and 'average rate:' in out, err
    finally:
        stop(node)


def test_record_keeps_a_best_effort_rclpy_topic_with_receive_times(domain_env, capsys, tmp_path):
    from rosbags.rosbag2 import Reader
    node = start_node('fast_talker', domain_env)
    bag = tmp_path / 'fast'
    try:
        code, _, err = cli(capsys, 'record', '/fast_chatter', '-o', str(bag), '--duration', '1.5', '--quiet')
        assert code == 0, err
    finally:
        stop(node)
    with Reader(bag) as reader:
        assert reader.topics['/fast_chatter'].msgcount >= 10
        assert reader.topics['/fast_chatter'].connections[0].ext.offered_qos_profiles[0].reliability.name == \
            'BEST_EFFORT'


def test_foxglove_forwards_a_best_effort_rclpy_topic(domain_env):
    import time

    from test_cli_graph_offered_qos import networked_node

    from touch_view.foxglove_node import FoxgloveServerNode
    node = start_node('fast_talker', domain_env)
    try:
        context, executor, fox = networked_node(FoxgloveServerNode, port=0, discovery_period_s=0.2)
        try:
            deadline = time.monotonic() + 20
            while fox.forwarded.get('/fast_chatter', 0) < 10 and time.monotonic() < deadline:
                executor.spin_once(0.05)
            assert fox.forwarded.get('/fast_chatter', 0) >= 10, fox.forwarded
            sub = next(s for s in fox.subscriptions_by_offer.subscriptions if s.topic == '/fast_chatter')
            assert sub.policies == ('BEST_EFFORT', 'VOLATILE')
        finally:
            fox.destroy_node()
            executor.shutdown()
            context.try_shutdown()
    finally:
        stop(node)
