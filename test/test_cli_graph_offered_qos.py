"""Every tool that subscribes takes the QoS the publishers offer: a best-effort publisher in another process is
heard by ``topic echo`` (also given a type), ``topic hz``, ``record``, the view and the Foxglove server.

The publisher process sends SYNTHETIC skin frames (a constant map) best effort at 150 Hz, as the skin
driver does, and a best-effort counter string at 20 Hz.
"""

import doctest
import json
import struct
import subprocess
import sys
import textwrap
import time

import pytest
from rosbags.rosbag2 import Reader
from test_cli_graph_commands import REPO, cli, graph_env, running_graph
from websockets.sync.client import connect

from touch_graph import messages, offered_qos
from touch_graph.offered_qos import OfferedQosSubscriptions
from touch_graph.runtime import (
    Context,
    DurabilityPolicy,
    Node,
    Parameter,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
)

BEST_EFFORT = textwrap.dedent('''
    import sys
    import numpy as np
    from touch_graph.compat import Node, get_message, sensor_data_qos
    from touch_graph.node_main import run_node
    String = get_message('std_msgs/msg/String')
    SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')

    class BestEffort(Node):
        """/skin/frame at 150 Hz and /be at 20 Hz, both best effort."""

        def __init__(self, **kwargs):
            super().__init__('best_effort_talker', **kwargs)
            self.skin = self.create_publisher(SkinFrame, '/skin/frame', sensor_data_qos())
            self.text = self.create_publisher(String, '/be', sensor_data_qos())
            self.n = 0
            self.frame = SkinFrame(pressure=np.full(144, 0.25, np.float32))
            self.create_timer(1 / 150, self.on_skin)
            self.create_timer(0.05, self.on_text)

        def on_skin(self):
            self.frame.sequence = self.n % 65536
            self.frame.header.stamp = self.get_clock().now().to_msg()
            self.skin.publish(self.frame)
            self.n += 1

        def on_text(self):
            self.text.publish(String(data=f'be {self.n}'))

    sys.exit(run_node(BestEffort, sys.argv[1:]))
''')


@pytest.fixture(scope='module')
def graph():
    yield from running_graph(BEST_EFFORT, ready=lambda g: '/be' in g.topics and '/skin/frame' in g.topics)


def test_offered_qos_doctests():
    result = doctest.testmod(offered_qos)
    assert result.attempted and not result.failed


def test_echo_with_a_type_hears_a_best_effort_publisher(graph, capsys):
    code, out, err = cli(capsys, 'topic', 'echo', '/be', 'std_msgs/msg/String', '-n', '2', '--timeout', '10')
    assert code == 0, err
    assert out.count('data: be ') == 2


def test_hz_and_record_hear_a_best_effort_publisher(graph, capsys, tmp_path):
    code, out, err = cli(capsys, 'topic', 'hz', '/skin/frame', '--duration', '2', '--wall-time')
    assert code == 0 and 'average rate:' in out, err
    bag = tmp_path / 'be'
    code, _, err = cli(capsys, 'record', '/be', '/skin/frame', '-o', str(bag), '--duration', '1.5', '--quiet')
    assert code == 0, err
    with Reader(bag) as reader:
        counts = {t: i.msgcount for t, i in reader.topics.items()}
    assert counts['/be'] >= 5 and counts['/skin/frame'] >= 20, counts


def networked_node(node_class, **parameters):
    """A node of ours in this process, on a networked wall-clock context (as ``social-touch view`` runs it)."""
    context = Context('wall', network=True)
    context.init([])
    executor = SingleThreadedExecutor(context=context)
    node = node_class(context=context, parameter_overrides=[Parameter(k, value=v) for k, v in parameters.items()])
    executor.add_node(node)
    return context, executor, node


def test_the_view_shows_best_effort_skin_frames_of_another_process(graph):
    from touch_view.node import TouchViewNode
    context, executor, node = networked_node(TouchViewNode, port=0)
    try:
        sub = next(s for s in node.subscriptions_by_offer.subscriptions if s.topic == '/skin/frame')
        deadline = time.monotonic() + 20
        while node.state.sensors['skin'].frames < 20 and time.monotonic() < deadline:
            executor.spin_once(0.05)
        assert sub.policies == ('BEST_EFFORT', 'VOLATILE')
        node.state.check_silence()
        skin = node.state.snapshot()['sensors']['skin']
        assert skin['present'] and not skin['silent'] and skin['frames'] >= 20, skin
    finally:
        node.destroy_node()
        executor.shutdown()
        context.try_shutdown()


def test_foxglove_serves_best_effort_skin_frames_of_another_process(graph):
    from touch_view.foxglove_node import FoxgloveServerNode
    context, executor, node = networked_node(FoxgloveServerNode, port=0, discovery_period_s=0.2)
    try:
        with connect(f'ws://127.0.0.1:{node.port}', subprotocols=['foxglove.sdk.v1'], open_timeout=10) as ws:
            frames, channels, subscribed = [], {}, False
            deadline = time.monotonic() + 30
            while len(frames) < 20 and time.monotonic() < deadline:
                executor.spin_once(0.01)
                try:
                    data = ws.recv(timeout=0.01)
                except TimeoutError:
                    continue
                if isinstance(data, str):
                    message = json.loads(data)
                    if message['op'] == 'advertise':
                        channels.update({c['topic']: c['id'] for c in message['channels']})
                    if '/skin/frame' in channels and not subscribed:
                        ws.send(json.dumps({'op': 'subscribe',
                                            'subscriptions': [{'id': 1, 'channelId': channels['/skin/frame']}]}))
                        subscribed = True
                elif data[0] == 1 and struct.unpack_from('<I', data, 1)[0] == 1:
                    frames.append(messages.deserialize(bytes(data[13:]), 'social_touch_msgs/msg/SkinFrame'))
        assert len(frames) >= 20 and all(f.pressure[0] == pytest.approx(0.25) for f in frames)
    finally:
        node.destroy_node()
        executor.shutdown()
        context.try_shutdown()


def test_echo_started_before_a_best_effort_publisher_hears_it(tmp_path):
    """Subscribed reliable while nobody publishes (ros2 topic echo's default); remade best effort once the
    publisher shows up."""
    from dds_testing import allocate_domain
    (tmp_path / 'graph.py').write_text(BEST_EFFORT)
    with allocate_domain() as domain:
        env = graph_env(domain)
        echo = subprocess.Popen([sys.executable, '-m', 'touch_lab.cli.main', 'topic', 'echo', '/be',
                                 'std_msgs/msg/String', '-n', '2', '--timeout', '30'], cwd=REPO, env=env, text=True,
                                stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        publisher = None
        try:
            time.sleep(3.0)  # the echo found no graph and subscribed with the default profile
            publisher = subprocess.Popen([sys.executable, str(tmp_path / 'graph.py')], cwd=REPO, env=env,
                                         stderr=subprocess.DEVNULL)
            out, err = echo.communicate(timeout=60)
        finally:
            for proc in (echo, publisher):
                if proc is not None and proc.poll() is None:
                    proc.kill()
                    proc.communicate()
    assert echo.returncode == 0 and out.count('data: be ') == 2, err


def test_a_subscription_is_remade_only_when_a_publisher_cannot_match_it():
    context = Context('wall')
    context.init([])
    try:
        node = Node('listener', context=context)
        talker = Node('talker', context=context)
        String = messages.get_message('std_msgs/msg/String')
        subs = OfferedQosSubscriptions(node, check_period_s=None)
        sub = subs.create_subscription(String, '/t', lambda m: None, 10)
        assert sub.policies == ('RELIABLE', 'VOLATILE') and sub.guessed
        talker.create_publisher(String, '/t', QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        assert subs.check() == 1 and sub.policies == ('RELIABLE', 'TRANSIENT_LOCAL')   # the first offer known
        assert subs.check() == 0
        talker.create_publisher(String, '/t', QoSProfile(depth=1, reliability=ReliabilityPolicy.BEST_EFFORT))
        assert subs.check() == 1 and sub.policies == ('BEST_EFFORT', 'VOLATILE')  # neither reliable nor latched
        assert sub.remade == 2 and len(node.subscriptions) == 1
        talker.destroy_node()
        assert subs.check() == 0 and sub.policies == ('BEST_EFFORT', 'VOLATILE')  # matches anyone: kept
        info = node.get_publishers_info_by_topic('/t')
        assert info == []
    finally:
        context.try_shutdown()
