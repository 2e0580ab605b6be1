"""Bad input on the network: foreign layouts, undecodable samples, incompatible QoS, other domains."""

import os
import stat
import time
from dataclasses import dataclass
from pathlib import Path

import pytest
from cyclonedds._clayer import ddspy_write
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import float64
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from dds_testing import SpinningGraph, allocate_domain, wait_until

from touch_graph.dds.cdds import delete_entity
from touch_graph.dds.idl import idl_struct
from touch_graph.dds.qos import dds_qos
from touch_graph.messages import get_message, serialize
from touch_graph.runtime import QoSProfile, ReliabilityPolicy

HapticCommand = get_message('HapticCommand')


@dataclass
class ForeignHapticCommand(IdlStruct, typename='social_touch_msgs::msg::dds_::HapticCommand_'):
    """Our type name, another layout (someone's older or newer .msg)."""

    command: str
    strength: float64


@pytest.fixture
def graphs(dds_domain):
    made = []

    def make(**kwargs):
        made.append(SpinningGraph(**kwargs))
        return made[-1]
    yield make
    for g in made:
        g.close()


@pytest.fixture
def foreign(dds_domain, graphs):
    """A participant of plain cyclonedds in the domain (made after one of ours, which set the domain up)."""
    graphs()
    participant = DomainParticipant(dds_domain)
    yield participant
    delete_entity(participant)


def listening_graph(graphs, depth=10):
    graph = graphs()
    node = graph.add_node('commands')
    got = []
    sub = graph.call(lambda: node.create_subscription(HapticCommand, '/touch/haptic_command', got.append, depth))
    return graph, sub, got


def test_a_foreign_layout_under_our_type_name_is_refused_and_reported_once(graphs, foreign, capsys):
    _, sub, got = listening_graph(graphs)
    writer = DataWriter(foreign, Topic(foreign, 'rt/touch/haptic_command', ForeignHapticCommand),
                        dds_qos(QoSProfile(depth=10)))
    wait_until(lambda: getattr(sub._dds, 'incompatible', 0) >= 1, 10, 'the mismatch to be noticed')
    writer.write(ForeignHapticCommand(command='come_here', strength=2.0))
    time.sleep(1.0)  # a few housekeeping rounds: reported once, not again
    err = capsys.readouterr().err
    lines = [x for x in err.splitlines() if 'incompatible type' in x]
    assert len(lines) == 1, err
    assert "'social_touch_msgs::msg::dds_::HapticCommand_' (participant " in lines[0]
    assert "does not match ours, 'social_touch_msgs/msg/HapticCommand'. No messages will be received" in lines[0]
    assert got == [] and len(writer.get_matched_subscriptions()) == 0
    # The node is fine: a publisher of the right layout is heard.
    other = graphs()
    talker = other.add_node('talker')
    pub = other.call(lambda: talker.create_publisher(HapticCommand, '/touch/haptic_command', 10))
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'a good publisher to match')
    other.call(pub.publish, HapticCommand(command='stop'))
    wait_until(lambda: [m.command for m in got] == ['stop'], 10, 'the good message')


def test_a_sample_that_does_not_decode_is_counted_skipped_and_reported_once(graphs, foreign, capsys):
    graph, sub, got = listening_graph(graphs)
    writer = DataWriter(foreign, Topic(foreign, 'rt/touch/haptic_command', idl_struct(HapticCommand.__msgtype__)),
                        dds_qos(QoSProfile(depth=10)))
    wait_until(lambda: len(writer.get_matched_subscriptions()) == 1, 10, 'the match')
    good = serialize(HapticCommand(command='come_here'))
    # The layout is right, the text is not UTF-8: Cyclone passes it, decoding must not.
    bad = good.replace(b'come_here', b'come\xff\xfeere')
    for data in (bad, bad, good):
        assert ddspy_write(writer._ref, data + b'\0' * (-len(data) % 4)) == 0
    wait_until(lambda: [m.command for m in got] == ['come_here'], 10, 'the good sample after the bad ones')
    assert sub._dds.undecodable == 2 and sub._dds.received == 3
    err = capsys.readouterr().err
    reports = [x for x in err.splitlines() if 'does not decode' in x]
    assert len(reports) == 1, err
    assert "writer of 'social_touch_msgs::msg::dds_::HapticCommand_'" in reports[0]
    assert "as 'social_touch_msgs/msg/HapticCommand'" in reports[0]

    def subscriptions():   # the view lists our own reader once discovery has taken its DCPSSubscription sample
        topic = graph.view().topics.get('/touch/haptic_command')
        return topic.subscriptions if topic else []
    wait_until(lambda: len(subscriptions()) == 1, 10, 'the subscription in the graph view')
    [endpoint] = subscriptions()
    assert endpoint.stats == {'received': 1, 'dropped': 0, 'undecodable': 2}


def test_incompatible_qos_is_reported_as_ros2_reports_it(graphs, capsys):
    _, sub, _ = listening_graph(graphs)  # reliable
    sensor = graphs()
    talker = sensor.add_node('driver')
    pub = sensor.call(lambda: talker.create_publisher(
        HapticCommand, '/touch/haptic_command', QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)))
    wait_until(lambda: getattr(sub._dds, 'incompatible', 0) and getattr(pub._dds, 'incompatible', 0), 10,
               'both ends to notice')
    err = capsys.readouterr().err
    assert ("New publisher discovered on topic '/touch/haptic_command', offering incompatible QoS. No messages will "
            'be received from it. Last incompatible policy: RELIABILITY') in err
    assert ("New subscription discovered on topic '/touch/haptic_command', requesting incompatible QoS. No messages "
            'will be sent to it. Last incompatible policy: RELIABILITY') in err
    assert pub.get_subscription_count() == 0


def test_another_domain_never_crosses(dds_domain):
    with allocate_domain() as other_domain:
        here, there = SpinningGraph(domain_id=dds_domain), SpinningGraph(domain_id=other_domain)
        try:
            node = there.add_node('there')
            got = []
            sub_node = here.add_node('listener')
            here.call(lambda: sub_node.create_subscription(HapticCommand, '/touch/haptic_command', got.append, 10))
            pub = there.call(lambda: node.create_publisher(HapticCommand, '/touch/haptic_command', 10))
            time.sleep(1.5)
            assert pub.get_subscription_count() == 0
            there.call(pub.publish, HapticCommand(command='intrude'))
            time.sleep(0.5)
            assert got == [] and not here.view().remote_participants()
        finally:
            here.close()
            there.close()


def world_writable(roots=('/tmp', '/dev/shm')):
    found = set()
    for root in roots:
        for dirpath, dirnames, filenames in os.walk(root):
            for name in dirnames + filenames:
                path = Path(dirpath, name)
                try:
                    mode = path.lstat().st_mode
                except OSError:
                    continue
                if mode & stat.S_IWOTH and not stat.S_ISLNK(mode) and not (mode & stat.S_ISVTX):
                    found.add(path)
    return found


def test_nothing_of_ours_is_created_world_writable(graphs):
    before = world_writable()
    a, b = graphs(), graphs()
    node = a.add_node('n')
    pub = a.call(lambda: node.create_publisher(HapticCommand, '/x', 10))
    listener = b.add_node('m')
    b.call(lambda: listener.create_subscription(HapticCommand, '/x', lambda m: None, 10))
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the match')
    assert world_writable() - before == set()
