"""Bags as rosbag2 (Jazzy) writes them: ``ros_distro``, log time = receive time, publish time kept, duration.

Data are synthetic (counter strings).
"""

import textwrap
import time

import pytest
import yaml
from mcap.reader import make_reader
from test_cli_graph_commands import cli, running_graph

from touch_graph.bag import BagRecorder, bag_info
from touch_graph.bag.metadata import DEFAULT_ROS_DISTRO
from touch_graph.bag.player import BagPlayer
from touch_graph.messages import deserialize, get_message, serialize

String = get_message('std_msgs/msg/String')


def mcap_times(bag):
    """``(topic, log time, publish time, text)`` of every message of the bag's MCAP file, in log-time order."""
    with (bag / f'{bag.name}.mcap').open('rb') as f:
        return [(channel.topic, message.log_time, message.publish_time, deserialize(message.data, schema.name).data)
                for schema, channel, message in make_reader(f).iter_messages(log_time_order=True)]


def metadata(bag):
    return yaml.safe_load((bag / 'metadata.yaml').read_text())['rosbag2_bagfile_information']


def test_log_time_is_the_receive_time_and_publish_time_is_kept(tmp_path, monkeypatch):
    monkeypatch.delenv('ROS_DISTRO', raising=False)
    bag = tmp_path / 'times'
    with BagRecorder(bag, flush_period_s=None) as rec:
        # a latched sample sent 60 s before the recording, received at its start; then one sent and received
        rec.write('/state', 'std_msgs/msg/String', 100 * 10**9, serialize(String(data='latched')),
                  publish_ns=40 * 10**9)
        rec.write('/state', 'std_msgs/msg/String', 101 * 10**9, serialize(String(data='live')),
                  publish_ns=101 * 10**9 - 2000)
    assert mcap_times(bag) == [('/state', 100 * 10**9, 40 * 10**9, 'latched'),
                               ('/state', 101 * 10**9, 101 * 10**9 - 2000, 'live')]
    info = metadata(bag)
    assert info['ros_distro'] == DEFAULT_ROS_DISTRO == 'jazzy'
    assert info['duration'] == {'nanoseconds': 10**9}  # last receive - first receive, not 61 s
    assert info['starting_time'] == {'nanoseconds_since_epoch': 100 * 10**9}


def test_ros_distro_is_the_environment_s(tmp_path, monkeypatch):
    monkeypatch.setenv('ROS_DISTRO', 'humble')
    bag = tmp_path / 'humble'
    with BagRecorder(bag, flush_period_s=None) as rec:
        rec.write('/x', 'std_msgs/msg/String', 1, serialize(String(data='x')))
    assert metadata(bag)['ros_distro'] == 'humble'


def test_an_old_bag_still_plays(tmp_path):
    """A bag of the earlier recorder: log time = publish time = the sender's stamp, ``ros_distro: rosbags``."""
    bag = tmp_path / 'old'
    with BagRecorder(bag, flush_period_s=None) as rec:
        for i in range(5):
            rec.write('/chatter', 'std_msgs/msg/String', 10**9 + i * 10**8, serialize(String(data=f'hello {i}')))
    text = (bag / 'metadata.yaml').read_text()
    (bag / 'metadata.yaml').write_text(text.replace(f'ros_distro: {DEFAULT_ROS_DISTRO}', 'ros_distro: rosbags'))
    assert metadata(bag)['ros_distro'] == 'rosbags'
    assert all(log == pub for _, log, pub, _ in mcap_times(bag))
    assert bag_info(bag)['messages'] == 5
    with BagPlayer(bag) as player:
        played = [(stamp, deserialize(data, topic.type_name).data) for topic, stamp, data in player.messages()]
        assert [player.play_time(stamp, 0) for stamp, _ in played] == [i * 10**8 for i in range(5)]
    assert [text for _, text in played] == [f'hello {i}' for i in range(5)]


LATCHED = textwrap.dedent('''
    import sys, time
    from touch_graph.compat import DurabilityPolicy, Node, QoSProfile, get_message
    from touch_graph.node_main import run_node
    String = get_message('std_msgs/msg/String')

    class Latched(Node):
        """Publishes one latched /state at start, then /tick at 20 Hz."""

        def __init__(self, **kwargs):
            super().__init__('latched_talker', **kwargs)
            latched = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
            self.create_publisher(String, '/state', latched).publish(String(data='ready'))
            self.tick = self.create_publisher(String, '/tick', 10)
            self.n = 0
            self.create_timer(0.05, self.on_tick)

        def on_tick(self):
            self.tick.publish(String(data=str(self.n)))
            self.n += 1

    sys.exit(run_node(Latched, sys.argv[1:]))
''')


@pytest.fixture(scope='module')
def latched_graph():
    yield from running_graph(LATCHED, ready=lambda graph: '/tick' in graph.topics and '/state' in graph.topics)


def test_recording_a_latched_topic_lasts_as_long_as_the_recording(latched_graph, tmp_path, capsys):
    time.sleep(1.0)  # the latched sample is at least 1 s old when the recording starts
    bag = tmp_path / 'latched'
    started = time.time_ns()
    code, _, err = cli(capsys, 'record', '/state', '/tick', '-o', str(bag), '--duration', '1.0', '--quiet')
    assert code == 0, err
    times = mcap_times(bag)
    state = [(log, pub) for topic, log, pub, _ in times if topic == '/state']
    assert len(state) == 1 and state[0][0] >= started > state[0][1] + 5 * 10**8  # received now, sent >= 1 s ago
    ticks = [(log, pub) for topic, log, pub, _ in times if topic == '/tick']
    assert len(ticks) >= 5 and all(log >= pub for log, pub in ticks)
    info = metadata(bag)
    logs = [log for _, log, _, _ in times]
    assert info['duration']['nanoseconds'] == max(logs) - min(logs)
    assert info['duration']['nanoseconds'] < time.time_ns() - started  # not stretched back to the latched send



def test_every_publisher_s_offered_qos_is_kept(tmp_path):
    bag = tmp_path / 'qos'
    offered = [{'history': 1, 'depth': 1, 'reliability': 1, 'durability': 1},
               {'history': 1, 'depth': 5, 'reliability': 2, 'durability': 2}]
    with BagRecorder(bag, flush_period_s=None) as rec:
        rec.add_topic('/x', 'std_msgs/msg/String', offered)
        rec.write('/x', 'std_msgs/msg/String', 1, serialize(String(data='x')))
    profiles = metadata(bag)['topics_with_message_count'][0]['topic_metadata']['offered_qos_profiles']
    assert [(p['depth'], p['reliability'], p['durability']) for p in profiles] == [
        (1, 'reliable', 'transient_local'), (5, 'best_effort', 'volatile')]
    with BagPlayer(bag) as player:
        assert [int(q.depth) for q in player.topics['/x'].qos] == [1, 5]
