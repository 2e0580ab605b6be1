"""Record a simulated-time scene with the recorder node, replay it into a fresh graph, get the same messages.

The scene data are synthetic (random arrays from a seeded generator).
"""

import math

import numpy as np
import pytest
from rosbags.rosbag2 import Reader

from touch_graph.bag import BagRecorder, bag_info
from touch_graph.bag.player_node import PlayerNode
from touch_graph.bag.recorder_node import RecorderNode
from touch_graph.errors import BagError
from touch_graph.messages import get_message, serialize
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor

SkinFrame = get_message('SkinFrame')
String = get_message('std_msgs/msg/String')
Header = get_message('std_msgs/msg/Header')


class Talker(Node):
    """Publishes synthetic skin frames at 150 Hz and a counter string at 10 Hz."""

    def __init__(self, **kwargs):
        super().__init__('talker', **kwargs)
        self.rng = np.random.default_rng(7)
        self.skin = self.create_publisher(SkinFrame, '/skin/frame', 10)
        self.text = self.create_publisher(String, 'chatter', 10)
        self.sent = {'/skin/frame': [], '/chatter': []}
        self.create_timer(1 / 150, self.on_skin)
        self.create_timer(0.1, self.on_text)

    def on_skin(self):
        n = len(self.sent['/skin/frame'])
        msg = SkinFrame(header=Header(stamp=self.get_clock().now().to_msg(), frame_id='skin'), sequence=n % 65536,
                        raw=self.rng.integers(0, 65535, 144).astype(np.uint16),
                        pressure=self.rng.random(144, dtype=np.float32), contact=bool(n % 2),
                        contact_x=math.nan if n % 3 else 1.5, contact_y=2.5,
                        force=self.rng.normal(size=108).astype(np.float32), total_force=float(n))
        self.skin.publish(msg)
        self.sent['/skin/frame'].append((self.context.now_ns(), msg))

    def on_text(self):
        msg = String(data=f'hello {len(self.sent["/chatter"])}')
        self.text.publish(msg)
        self.sent['/chatter'].append((self.context.now_ns(), msg))


class Crasher(Node):
    """A node whose callback raises on every message: it dies, and recording must go on."""

    def __init__(self, **kwargs):
        super().__init__('crasher', **kwargs)
        self.create_subscription(String, '/chatter', self.boom, 10)

    def boom(self, msg):
        raise RuntimeError('synthetic failure in a callback')


def sim_context(start_s):
    ctx = Context('sim', start_s=start_s)
    ctx.init()
    return ctx


@pytest.fixture
def recorded(tmp_path):
    ctx = sim_context(1_700_000_000.0)
    talker = Talker(context=ctx)
    crasher = Crasher(context=ctx)
    recorder = RecorderNode(context=ctx, parameter_overrides=[Parameter('output', value=str(tmp_path / 'scene')),
                                                              Parameter('topics', value=['/skin/frame', '/chatter'])])
    executor = SingleThreadedExecutor(context=ctx)
    for node in (talker, crasher, recorder):
        executor.add_node(node)
    end = ctx.now_ns() + 1_000_000_000
    with pytest.raises(RuntimeError, match='synthetic failure'):
        executor.spin_until_time(end)                  # its first message ends the spin, as in rclpy
    executor.remove_node(crasher)                      # the crasher died (as its process would); the graph goes on
    executor.spin_until_time(end)
    assert crasher.callback_errors == 1 and len(talker.sent['/chatter']) == 10
    recorder.destroy_node()
    ctx.shutdown()
    return tmp_path / 'scene', talker.sent


def test_bag_opens_with_rosbags_reader_with_types_and_counts(recorded):
    bag, sent = recorded
    with Reader(bag) as reader:
        topics = reader.topics
        assert topics['/skin/frame'].msgtype == 'social_touch_msgs/msg/SkinFrame'
        assert topics['/chatter'].msgtype == 'std_msgs/msg/String'
        assert topics['/skin/frame'].msgcount == len(sent['/skin/frame']) >= 149  # 1/150 s rounds up to whole ns
        assert topics['/chatter'].msgcount == len(sent['/chatter']) == 10
        assert 'float32[108] force' in topics['/skin/frame'].msgdef.data
        assert reader.connections[0].ext.offered_qos_profiles[0].depth == 10
        stamps = [t for _, t, _ in reader.messages()]
    # Simulated time is what was recorded, exactly the publish times.
    assert stamps == sorted(t for msgs in sent.values() for t, _ in msgs)
    info = bag_info(bag)
    assert info['messages'] == len(stamps) and info['storage'] == 'mcap'
    assert info['start_ns'] == stamps[0] and info['end_ns'] == stamps[-1]


def collect(ctx, topics):
    node = Node('collector', context=ctx)
    got = {t: [] for t in topics}
    for topic, cls in topics.items():
        node.create_subscription(cls, topic, lambda m, t=topic: got[t].append((ctx.now_ns(), m)), 1000)
    return node, got


def test_record_then_play_gives_back_identical_messages_and_timing(recorded):
    bag, sent = recorded
    ctx = sim_context(1_800_000_000.0)  # another epoch: replay maps recorded time onto this clock
    collector, got = collect(ctx, {'/skin/frame': SkinFrame, '/chatter': String})
    player = PlayerNode(context=ctx, parameter_overrides=[Parameter('bag', value=str(bag))])
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(collector)
    executor.add_node(player)
    assert executor.spin_until(lambda: player.done, timeout_sec=5.0)
    executor.spin_for(0.0)  # the subscribers' turn for the last message
    for topic in got:
        assert [m for _, m in got[topic]] == [m for _, m in sent[topic]]
    # Recorded timing, shifted to the replay's origin.
    first = min(t for msgs in sent.values() for t, _ in msgs)
    origin = got['/skin/frame'][0][0] - (sent['/skin/frame'][0][0] - first)
    for topic in got:
        assert [t - origin for t, _ in got[topic]] == [t - first for t, _ in sent[topic]]
    assert player.published == len(sent['/skin/frame']) + 10 and player.errors == 0


def test_rate_topics_offset_and_loop(recorded):
    bag, _ = recorded
    ctx = sim_context(1_800_000_000.0)
    collector, got = collect(ctx, {'/chatter': String})
    player = PlayerNode(context=ctx, parameter_overrides=[
        Parameter('bag', value=str(bag)), Parameter('topics', value=['/chatter']), Parameter('rate', value=2.0),
        Parameter('start_offset', value=0.45), Parameter('loop', value=True)])
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(collector)
    executor.add_node(player)
    assert executor.spin_until(lambda: player.passes >= 3, timeout_sec=10.0)
    executor.spin_for(0.0)
    texts = [m.data for _, m in got['/chatter']]
    # chatter was published at 0.1 .. 1.0 s; from 0.45 s on: 0.5 .. 1.0 -> hello 4 .. hello 9, looped.
    assert texts[:12] == [f'hello {i}' for i in range(4, 10)] * 2
    gaps = np.diff([t for t, _ in got['/chatter'][:6]])
    assert np.all(gaps == 50_000_000)  # 0.1 s recorded at rate 2
    assert not player.done


def test_fast_mode_on_a_simulated_clock_loses_nothing(recorded):
    bag, sent = recorded
    ctx = sim_context(1_800_000_000.0)
    collector, got = collect(ctx, {'/skin/frame': SkinFrame, '/chatter': String})
    player = PlayerNode(context=ctx, parameter_overrides=[Parameter('bag', value=str(bag)),
                                                          Parameter('fast', value=True)])
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(collector)
    executor.add_node(player)
    assert executor.spin_until(lambda: player.done, timeout_sec=5.0)
    executor.spin_for(0.0)  # the subscribers' turn for the last message
    assert [m for _, m in got['/skin/frame']] == [m for _, m in sent['/skin/frame']]
    assert [m for _, m in got['/chatter']] == [m for _, m in sent['/chatter']]
    times = sorted(t for msgs in got.values() for t, _ in msgs)
    assert np.all(np.diff(times) == 200_000)  # one message per fast_period (0.2 ms) of simulated time


def test_player_refuses_unknown_topic_with_did_you_mean(recorded):
    bag, _ = recorded
    ctx = sim_context(0.0)
    with pytest.raises(BagError, match=r"no topic '/chatt'.*did you mean '/chatter'"):
        PlayerNode(context=ctx, parameter_overrides=[Parameter('bag', value=str(bag)),
                                                     Parameter('topics', value=['/chatt'])])


def test_player_names_the_field_that_differs_in_an_older_definition(tmp_path):
    """A bag whose SkinFrame.msg had another force array: refuse it and say which field."""
    from rosbags.rosbag2 import StoragePlugin, Writer

    from touch_graph import messages
    type_name = 'social_touch_msgs/msg/SkinFrame'
    msgdef, _ = messages.typestore.generate_msgdef(type_name, ros_version=2)
    old = msgdef.replace('float32[108] force', 'float32[36] force')
    with Writer(tmp_path / 'old', version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        conn = writer.add_connection('/skin/frame', type_name, msgdef=old, rihs01='RIHS01_' + '0' * 64)
        writer.write(conn, 5, serialize(SkinFrame()))
    ctx = sim_context(0.0)
    with pytest.raises(BagError, match=r"field 'force' is float32\[36\] in the bag, float32\[108\] in our .msg"):
        PlayerNode(context=ctx, parameter_overrides=[Parameter('bag', value=str(tmp_path / 'old'))])


def test_unreadable_bag_gives_a_clear_error(tmp_path):
    (tmp_path / 'broken').mkdir()
    (tmp_path / 'broken' / 'broken.mcap').write_bytes(b'\x89MCAP0\r\nnot really')
    with pytest.raises(BagError, match='bag reindex'):
        bag_info(tmp_path / 'broken')
    with pytest.raises(BagError, match='does not exist'):
        bag_info(tmp_path / 'nothing')


def test_recorder_refuses_existing_path_and_writes_after_close(tmp_path):
    (tmp_path / 'taken').mkdir()
    with pytest.raises(BagError, match='exists already'):
        BagRecorder(tmp_path / 'taken').open()
    rec = BagRecorder(tmp_path / 'new', flush_period_s=None).open()
    rec.write('/chatter', 'std_msgs/msg/String', 1, serialize(String(data='x')))
    with pytest.raises(BagError, match="recorded as std_msgs/msg/String"):
        rec.write('/chatter', 'social_touch_msgs/msg/SkinFrame', 2, serialize(SkinFrame()))
    with pytest.raises(BagError, match='unknown message type'):
        rec.write('/x', 'nope_msgs/msg/Nope', 2, b'')
    rec.close()
    rec.close()  # twice is fine
    with pytest.raises(BagError, match='closed'):
        rec.write('/chatter', 'std_msgs/msg/String', 3, serialize(String(data='late')))
