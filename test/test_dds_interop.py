"""Interoperability with an independent participant: a stand-in for a C++ ROS 2 node on rmw_cyclonedds.

The stand-in (its own process, plain cyclonedds, nothing of ours imported) declares our
message types again by hand as ``IdlStruct``s with ROS 2's type names, joins as a ROS 2
node does (``enclave=/;`` in its participant's user data, its node in
``ros_discovery_info``), subscribes to ``rt/touch/symbolic`` and publishes
``rt/touch/haptic_command``, serialising with cyclonedds' own serialiser. Our graph
talks to it both ways, and the CLI lists it.
"""

import os
import subprocess
import sys

import pytest
from dds_testing import SpinningGraph, wait_until

from touch_graph.cli import main as cli_main
from touch_graph.dds.config import DiscoveryOptions, cyclone_config
from touch_graph.messages import get_message

STAND_IN = r'''
import sys, time
from dataclasses import dataclass
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, bounded_str, float32, int32, sequence, uint8, uint32
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from cyclonedds.util import duration


@dataclass
class Time_(IdlStruct, typename='builtin_interfaces::msg::dds_::Time_'):
    sec: int32
    nanosec: uint32


@dataclass
class Header_(IdlStruct, typename='std_msgs::msg::dds_::Header_'):
    stamp: Time_
    frame_id: str


@dataclass
class SymbolicGesture_(IdlStruct, typename='social_touch_msgs::msg::dds_::SymbolicGesture_'):
    header: Header_
    gesture: str
    state: uint8
    onset: Time_
    duration_s: float32
    sensors: sequence[str]


@dataclass
class HapticCommand_(IdlStruct, typename='social_touch_msgs::msg::dds_::HapticCommand_'):
    header: Header_
    gesture: str
    command: str
    recogniser: str
    distance: float32
    margin: float32
    duration_s: float32
    frames: uint32


@dataclass
class Gid_(IdlStruct, typename='rmw_dds_common::msg::dds_::Gid_'):
    data: array[uint8, 16]


@dataclass
class NodeEntitiesInfo_(IdlStruct, typename='rmw_dds_common::msg::dds_::NodeEntitiesInfo_'):
    node_namespace: bounded_str[256]
    node_name: bounded_str[256]
    reader_gid_seq: sequence[Gid_]
    writer_gid_seq: sequence[Gid_]


@dataclass
class ParticipantEntitiesInfo_(IdlStruct, typename='rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_'):
    gid: Gid_
    node_entities_info_seq: sequence[NodeEntitiesInfo_]


def gid(entity):
    return Gid_(data=list(entity.get_guid().bytes))


domain = int(sys.argv[1])
participant = DomainParticipant(domain, qos=Qos(Policy.Userdata(data=b'enclave=/;')))
events = Qos(Policy.Reliability.Reliable(duration(infinite=True)), Policy.History.KeepLast(10),
             Policy.Durability.Volatile, Policy.DataRepresentation(use_cdrv0_representation=True))
reader = DataReader(participant, Topic(participant, 'rt/touch/symbolic', SymbolicGesture_), events)
writer = DataWriter(participant, Topic(participant, 'rt/touch/haptic_command', HapticCommand_), events)
latched = Qos(Policy.Reliability.Reliable(duration(infinite=True)), Policy.History.KeepLast(1),
              Policy.Durability.TransientLocal, Policy.DataRepresentation(use_cdrv0_representation=True))
info = DataWriter(participant, Topic(participant, 'ros_discovery_info', ParticipantEntitiesInfo_), latched)
info.write(ParticipantEntitiesInfo_(gid=gid(participant), node_entities_info_seq=[NodeEntitiesInfo_(
    node_namespace='/robot', node_name='behaviour_cpp', reader_gid_seq=[gid(reader)], writer_gid_seq=[gid(writer)])]))
print('ready', flush=True)
n = 0
while True:
    for sample in reader.take(N=10):
        print('heard', sample.gesture, sample.state, ','.join(sample.sensors), flush=True)
    writer.write(HapticCommand_(header=Header_(stamp=Time_(sec=n, nanosec=5), frame_id='skin'), gesture='circle',
                                command='come_here', recogniser='dollar_p', distance=0.25, margin=0.5,
                                duration_s=1.5, frames=n))
    n += 1
    time.sleep(0.1)
'''


@pytest.fixture
def stand_in(dds_domain, tmp_path):
    script = tmp_path / 'stand_in.py'
    script.write_text(STAND_IN)
    env = {k: v for k, v in os.environ.items() if k != 'PYTHONPATH'}  # nothing of ours on its path
    # Discovery on this host, configured as rmw_cyclonedds configures a node with
    # ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST (the stand-in reads CYCLONEDDS_URI, as Cyclone does).
    env['CYCLONEDDS_URI'] = cyclone_config(DiscoveryOptions('LOCALHOST'), {}).rstrip(',')
    proc = subprocess.Popen([sys.executable, str(script), str(dds_domain)], cwd=tmp_path, env=env,
                            stdout=subprocess.PIPE, text=True)
    assert proc.stdout.readline().strip() == 'ready'
    yield proc
    proc.kill()
    proc.wait(10)
    proc.stdout.close()


def test_an_independent_ros2_style_participant_talks_both_ways_and_is_listed(stand_in, capsys):
    graph = SpinningGraph()
    try:
        node = graph.add_node('bear_gestures', namespace='/bear')
        commands = []
        graph.call(lambda: node.create_subscription(get_message('HapticCommand'), '/touch/haptic_command',
                                                    commands.append, 10))
        symbolic = graph.call(lambda: node.create_publisher(get_message('SymbolicGesture'), '/touch/symbolic', 20))
        wait_until(lambda: commands, 20, "the stand-in's haptic commands")
        command = commands[-1]
        assert (command.gesture, command.command, command.recogniser, command.header.frame_id) == \
            ('circle', 'come_here', 'dollar_p', 'skin')
        assert command.distance == pytest.approx(0.25) and command.header.stamp.nanosec == 5
        wait_until(lambda: symbolic.get_subscription_count() == 1, 20, 'the stand-in to subscribe')
        graph.call(symbolic.publish, get_message('SymbolicGesture')(gesture='hug', state=1, sensors=['head1', 'belly']))
        assert stand_in.stdout.readline().strip() == 'heard hug 1 head1,belly'

        view = graph.view()
        [cpp] = view.find_nodes('/robot/behaviour_cpp')
        assert [e.topic for e in cpp.publishers] == ['/touch/haptic_command']
        assert [e.topic for e in cpp.subscriptions] == ['/touch/symbolic']
        assert view.participants[cpp.participant]['enclave'] == '/'

        assert cli_main.main(['node', 'list']) == 0
        assert '/robot/behaviour_cpp' in capsys.readouterr().out.split()
        assert cli_main.main(['topic', 'list', '-t']) == 0
        out = capsys.readouterr().out.splitlines()
        assert '/touch/haptic_command [social_touch_msgs/msg/HapticCommand]' in out
        assert cli_main.main(['topic', 'info', '/touch/haptic_command', '-v']) == 0
        out = capsys.readouterr().out.splitlines()
        assert 'Node name: behaviour_cpp' in out and 'Node namespace: /robot' in out
        assert cli_main.main(['node', 'info', '/robot/behaviour_cpp']) == 0
        assert '    /touch/symbolic: social_touch_msgs/msg/SymbolicGesture' in capsys.readouterr().out.splitlines()
    finally:
        graph.close()
