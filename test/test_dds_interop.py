"""Interoperability with an independent participant: a stand-in for a C++ ROS 2 node on rmw_cyclonedds.

The stand-in (its own process, plain cyclonedds, nothing of ours imported) declares our
message types again by hand as ``IdlStruct``s with ROS 2's type names, joins as a ROS 2
node does (``enclave=/;`` in its participant's user data, its node in
``ros_discovery_info``), subscribes to ``rt/touch/symbolic`` and publishes
``rt/touch/haptic_command``, serialising with cyclonedds' own serialiser. It also calls one
of our parameter services and serves ``get_parameters`` itself, declaring
``rcl_interfaces/srv/GetParameters``' request and reply by hand as rmw_cyclonedds puts them on
the wire: the request header (client id, sequence number) before the fields. Our graph
talks to it both ways, and the CLI lists it and reads its parameter.
"""

import os
import subprocess
import sys

import pytest
from dds_testing import SpinningGraph, wait_until

from touch_graph.cli import main as cli_main
from touch_graph.dds.config import DiscoveryOptions, cyclone_config
from touch_graph.messages import get_message
from touch_graph.runtime import Parameter

STAND_IN = r'''
import sys, time
from dataclasses import dataclass
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import array, bounded_str, float32, float64, int32, int64, sequence, uint8, uint32, uint64
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
class Point_(IdlStruct, typename='geometry_msgs::msg::dds_::Point_'):
    x: float64
    y: float64
    z: float64


@dataclass
class SymbolicGesture_(IdlStruct, typename='social_touch_msgs::msg::dds_::SymbolicGesture_'):
    header: Header_
    gesture: str
    state: uint8
    onset: Time_
    duration_s: float32
    sensors: sequence[str]
    has_centroid: bool
    centroid: Point_
    frame_id: str
    confidence: float32


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
class ParameterValue_(IdlStruct, typename='rcl_interfaces::msg::dds_::ParameterValue_'):
    type: uint8
    bool_value: bool
    integer_value: int64
    double_value: float64
    string_value: str
    byte_array_value: sequence[uint8]
    bool_array_value: sequence[bool]
    integer_array_value: sequence[int64]
    double_array_value: sequence[float64]
    string_array_value: sequence[str]


# rmw_cyclonedds writes cdds_request_header_t (uint64 client id, int64 sequence) before a request's
# or a reply's fields; a C++ node has them from its serdata, this stand-in declares them as fields.
@dataclass
class GetParameters_Request_(IdlStruct, typename='rcl_interfaces::srv::dds_::GetParameters_Request_'):
    client_id: uint64
    sequence_number: int64
    names: sequence[str]


@dataclass
class GetParameters_Response_(IdlStruct, typename='rcl_interfaces::srv::dds_::GetParameters_Response_'):
    client_id: uint64
    sequence_number: int64
    values: sequence[ParameterValue_]


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
# Services: keep last 10, reliable, volatile (ROS 2's services profile). A type it describes is matched only
# if the names of the header's fields are not compared: ROS 2 gives them none.
services = Qos(Policy.Reliability.Reliable(duration(seconds=1)), Policy.History.KeepLast(10),
               Policy.Durability.Volatile, Policy.DataRepresentation(use_cdrv0_representation=True))
service_reader_qos = Qos(Policy.TypeConsistency.AllowTypeCoercion(ignore_member_names=True), base=services)
# calling /bear/bear_gestures/get_parameters of the graph
call_out = DataWriter(participant, Topic(participant, 'rq/bear/bear_gestures/get_parametersRequest',
                                         GetParameters_Request_), services)
call_back = DataReader(participant, Topic(participant, 'rr/bear/bear_gestures/get_parametersReply',
                                          GetParameters_Response_), service_reader_qos)
# serving /robot/behaviour_cpp/get_parameters
served_in = DataReader(participant, Topic(participant, 'rq/robot/behaviour_cpp/get_parametersRequest',
                                          GetParameters_Request_), service_reader_qos)
served_out = DataWriter(participant, Topic(participant, 'rr/robot/behaviour_cpp/get_parametersReply',
                                           GetParameters_Response_), services)
own_parameters = {'volume': ParameterValue_(type=3, bool_value=False, integer_value=0, double_value=0.8,
                                            string_value='', byte_array_value=[], bool_array_value=[],
                                            integer_array_value=[], double_array_value=[], string_array_value=[])}
info = DataWriter(participant, Topic(participant, 'ros_discovery_info', ParticipantEntitiesInfo_), latched)
info.write(ParticipantEntitiesInfo_(gid=gid(participant), node_entities_info_seq=[NodeEntitiesInfo_(
    node_namespace='/robot', node_name='behaviour_cpp',
    reader_gid_seq=[gid(reader), gid(call_back), gid(served_in)],
    writer_gid_seq=[gid(writer), gid(call_out), gid(served_out)])]))
print('ready', flush=True)
n = 0
sent_at = None
answered = False
my_id = 0x5EED
while True:
    for sample in reader.take(N=10):
        if not isinstance(sample, SymbolicGesture_):
            continue  # a writer that went away (no data)
        print('heard', sample.gesture, sample.state, ','.join(sample.sensors), flush=True)
    writer.write(HapticCommand_(header=Header_(stamp=Time_(sec=n, nanosec=5), frame_id='skin'), gesture='circle',
                                command='come_here', recogniser='dollar_p', distance=0.25, margin=0.5,
                                duration_s=1.5, frames=n))
    for request in served_in.take(N=10):  # every client receives every reply and keeps its own (the id)
        if not isinstance(request, GetParameters_Request_):
            continue  # a client that went away (no data)
        values = [own_parameters[name] for name in request.names] if all(
            name in own_parameters for name in request.names) else []
        served_out.write(GetParameters_Response_(client_id=request.client_id,
                                                 sequence_number=request.sequence_number, values=values))
    if not answered and call_out.get_matched_subscriptions() and call_back.get_matched_publications():
        if sent_at is None or time.time() - sent_at > 1.0:  # a reply lost before its reader matched: again
            sent_at = time.time()
            call_out.write(GetParameters_Request_(client_id=my_id, sequence_number=n, names=['threshold']))
        for reply in call_back.take(N=10):
            if isinstance(reply, GetParameters_Response_) and reply.client_id == my_id:
                answered = True
                print('param', reply.sequence_number >= 0, [(v.type, round(v.double_value, 6)) for v in reply.values],
                      flush=True)
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
        # declared as the node is made: the stand-in calls get_parameters as soon as it sees the service
        node = graph.add_node('bear_gestures', namespace='/bear',
                              parameter_overrides=[Parameter('threshold', value=0.3)],
                              automatically_declare_parameters_from_overrides=True)
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
        lines = [stand_in.stdout.readline().strip() for _ in range(2)]  # the gesture and our parameter's reply
        assert 'heard hug 1 head1,belly' in lines
        assert 'param True [(3, 0.3)]' in lines  # it called /bear/bear_gestures/get_parameters over DDS

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
        out = capsys.readouterr().out.splitlines()
        assert '    /touch/symbolic: social_touch_msgs/msg/SymbolicGesture' in out
        assert out[out.index('  Service Servers:') + 1] == \
            '    /robot/behaviour_cpp/get_parameters: rcl_interfaces/srv/GetParameters'
        assert '    /bear/bear_gestures/get_parameters: rcl_interfaces/srv/GetParameters' in out  # its client
        # our CLI reads a foreign node's parameter through its hand-written service
        assert cli_main.main(['param', 'get', '/robot/behaviour_cpp', 'volume']) == 0
        assert capsys.readouterr().out == 'Double value is: 0.8\n'
        assert cli_main.main(['param', 'get', '/robot/behaviour_cpp', 'loudness']) == 1
        assert 'Parameter not set' in capsys.readouterr().err
    finally:
        graph.close()
