"""ROS 2's wire conventions on DDS: names, type descriptions, byte-identical CDR, QoS, discovery settings."""

import array
import doctest
import time

import numpy as np
import pytest
from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import Policy
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from dds_testing import wait_until

from touch_graph import messages, type_description
from touch_graph.dds import config, discovery, endpoints, graph, names, qos
from touch_graph.dds.config import DiscoveryOptions, cyclone_config, read_discovery
from touch_graph.dds.domain import acquire_domain, release_domain
from touch_graph.dds.idl import idl_struct
from touch_graph.errors import GraphError
from touch_graph.runtime.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy


@pytest.mark.parametrize('module', [names, qos, config, discovery, endpoints, graph, type_description])
def test_doctests(module):
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0


def random_message(type_name, rng):
    """A message of ``type_name`` with every field filled from ``rng`` (arrays, strings, nested)."""
    cls = messages.get_message(type_name)
    values = {}
    for field, type_str in messages.msg_field_types(cls).items():
        default = getattr(cls(), field)
        if isinstance(default, messages.Message):
            values[field] = random_message(default.__msgtype__, rng)
        elif isinstance(default, np.ndarray):
            n = len(default) if default.size else int(rng.integers(0, 5))
            if default.dtype.kind == 'f':
                values[field] = rng.normal(size=n).astype(default.dtype)
            elif default.dtype.kind == 'b':
                values[field] = rng.random(n) < 0.5
            else:
                info = np.iinfo(default.dtype)
                values[field] = rng.integers(info.min, info.max, n, dtype=default.dtype, endpoint=True)
        elif isinstance(default, array.array):                 # a numeric sequence, as rclpy gives it
            n = int(rng.integers(0, 5))
            if default.typecode in 'fd':
                values[field] = array.array(default.typecode, rng.normal(size=n).tolist())
            else:
                lo, hi = messages._INT_RANGES[type_str.split('[')[0]]
                values[field] = array.array(default.typecode, rng.integers(max(lo, -2**62), min(hi, 2**62), n,
                                                                          endpoint=True).tolist())
        elif isinstance(default, list):
            element = type_str.split('[')[0]
            if element == 'bool':                                   # bool[N] and bool[]: lists of Python bools
                n = len(default) if type_str != 'bool[]' else int(rng.integers(0, 5))
                values[field] = (rng.random(n) < 0.5).tolist()
            elif element == 'string':
                values[field] = [f's{i}' for i in range(int(rng.integers(0, 3)))]
            else:
                values[field] = [random_message(element, rng) for _ in range(int(rng.integers(0, 3)))]
        elif isinstance(default, bool):
            values[field] = bool(rng.random() < 0.5)
        elif isinstance(default, float):
            values[field] = float(rng.normal())
        elif isinstance(default, int):
            lo, hi = messages._INT_RANGES[type_str]
            hi = 127 if type_str == 'byte' else hi  # rosbags packs a scalar byte as int8
            values[field] = int(rng.integers(max(lo, -2**62), min(hi, 2**62), endpoint=True))
        elif isinstance(default, str):
            values[field] = 'touch ' * int(rng.integers(0, 3)) + 'é'
    return cls(**values)


def to_idl(msg):
    """The same message as an instance of the generated cyclonedds IdlStruct."""
    kwargs = {}
    for field in msg._fields:
        value = getattr(msg, field)
        if isinstance(value, messages.Message):
            value = to_idl(value)
        elif isinstance(value, (np.ndarray, array.array)):
            value = value.tolist()
        elif isinstance(value, bytes):   # a byte field: rclpy's bytes of length 1, cyclonedds' int
            value = value[0]
        elif isinstance(value, list):
            value = [to_idl(v) if isinstance(v, messages.Message) else v[0] if isinstance(v, bytes) else v
                     for v in value]
        kwargs[field] = value
    return idl_struct(msg.__msgtype__)(**kwargs)


TYPES = [*messages.interface_names(), 'std_msgs/msg/String', 'diagnostic_msgs/msg/DiagnosticArray']


@pytest.mark.parametrize('type_name', TYPES)
def test_our_cdr_is_what_the_type_description_serialises(type_name):
    """The bytes we write are the bytes Cyclone's own serialiser makes from the generated type."""
    rng = np.random.default_rng(7)
    for _ in range(5):
        msg = random_message(type_name, rng)
        ours = messages.serialize(msg)
        assert ours[:4] == b'\x00\x01\x00\x00'  # XCDR1 little endian, options 0: what ROS 2 sends
        assert ours == to_idl(msg).serialize()


def test_type_names_and_members_are_ros2s():
    cls = idl_struct('social_touch_msgs/msg/SkinFrame')
    assert cls.__idl__.idl_transformed_typename == 'social_touch_msgs::msg::dds_::SkinFrame_'
    assert list(cls.__annotations__) == list(messages.get_message('SkinFrame')._fields)
    header = cls.__annotations__['header']
    assert header.__idl__.idl_transformed_typename == 'std_msgs::msg::dds_::Header_'
    assert names.dds_type_name('rmw_dds_common/msg/ParticipantEntitiesInfo') == \
        'rmw_dds_common::msg::dds_::ParticipantEntitiesInfo_'


def test_bytes_cross_dds_unchanged_both_ways(dds_domain):
    """Raw CDR written through DDS arrives byte for byte, and an independent writer's samples decode."""
    acquire_domain(dds_domain, read_discovery())
    writer_side = DomainParticipant(dds_domain)
    reader_side = DomainParticipant(dds_domain)
    try:
        cls = idl_struct('social_touch_msgs/msg/HapticCommand')
        rqos = qos.dds_qos(QoSProfile(depth=10))
        writer = DataWriter(writer_side, Topic(writer_side, 'rt/touch/haptic_command', cls), rqos)
        reader = DataReader(reader_side, Topic(reader_side, 'rt/touch/haptic_command', cls), rqos)
        wait_until(lambda: len(writer.get_matched_subscriptions()) == 1, 10, 'the reader to match')
        msg = random_message('social_touch_msgs/msg/HapticCommand', np.random.default_rng(3))
        data = endpoints.pad4(messages.serialize(msg))
        assert ddspy_write(writer._ref, data) == 0
        got = []
        wait_until(lambda: got.extend(ddspy_take(reader._ref, 0, 10)) or got, 10, 'the sample')
        assert got[0][0] == data
        assert messages.deserialize(got[0][0], msg.__msgtype__) == msg
        writer.write(to_idl(msg))  # cyclonedds' own serialiser, as an independent node would send
        got.clear()
        wait_until(lambda: got.extend(ddspy_take(reader._ref, 0, 10)) or got, 10, 'the second sample')
        assert messages.deserialize(got[0][0], msg.__msgtype__) == msg
    finally:
        from touch_graph.dds.cdds import delete_entity
        delete_entity(writer_side)
        delete_entity(reader_side)
        release_domain(dds_domain)


def test_qos_mapping_is_rmw_cyclonedds():
    sensor = qos.dds_qos(QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT), type_hash='RIHS01_ab')
    assert sensor[Policy.Reliability] == Policy.Reliability.BestEffort
    assert sensor[Policy.History] == Policy.History.KeepLast(5)
    assert sensor[Policy.Durability] == Policy.Durability.Volatile
    assert sensor[Policy.IgnoreLocal] == Policy.IgnoreLocal.Participant
    assert sensor[Policy.DataRepresentation] == Policy.DataRepresentation(use_cdrv0_representation=True)
    assert sensor[Policy.Userdata].data == b'typehash=RIHS01_ab;'
    latched = qos.dds_qos(QoSProfile(depth=3, durability=DurabilityPolicy.TRANSIENT_LOCAL))
    assert latched[Policy.Durability] == Policy.Durability.TransientLocal
    assert latched[Policy.DurabilityService].history == Policy.History.KeepLast(3)
    assert isinstance(latched[Policy.Reliability], Policy.Reliability.Reliable)
    keep_all = qos.dds_qos(QoSProfile(depth=0, history=HistoryPolicy.KEEP_ALL))
    assert keep_all[Policy.History] == Policy.History.KeepAll
    assert keep_all[Policy.Reliability].max_blocking_time == int(qos.MAX_BLOCKING_S * 1e9)
    assert qos.qos_to_dict(latched) == {'history': 1, 'depth': 3, 'reliability': 1, 'durability': 1}


@pytest.mark.parametrize('env, expected', [
    ({}, DiscoveryOptions('SUBNET')),
    ({'ROS_LOCALHOST_ONLY': '1'}, DiscoveryOptions('LOCALHOST')),
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'OFF'}, DiscoveryOptions('OFF')),
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'SYSTEM_DEFAULT', 'ROS_STATIC_PEERS': 'a; b'},
     DiscoveryOptions('SYSTEM_DEFAULT', ('a', 'b'))),
    ({'ROS_AUTOMATIC_DISCOVERY_RANGE': 'nearby'}, DiscoveryOptions('LOCALHOST')),  # rcl's fallback
])
def test_discovery_range_as_rcl_reads_it(env, expected):
    assert read_discovery(env) == expected


def test_cyclone_config_as_rmw_cyclonedds_builds_it():
    assert cyclone_config(DiscoveryOptions('SYSTEM_DEFAULT'), {}) == ''
    subnet = cyclone_config(DiscoveryOptions('SUBNET', ('10.1.0.7',)), {'CYCLONEDDS_URI': 'file:///etc/c.xml'})
    assert 'AllowMulticast' not in subnet and '<Peer address="10.1.0.7"/>' in subnet
    assert subnet.endswith('</CycloneDDS>,file:///etc/c.xml')
    off = cyclone_config(DiscoveryOptions('OFF', ('10.1.0.7',)), {})
    assert '<AllowMulticast>false</AllowMulticast>' in off and '<Tag>ros_discovery_off_' in off
    assert '<Peer' not in off


@pytest.mark.parametrize('value', ['-1', '233', 'seven'])
def test_bad_domain_id_is_a_clear_error(value):
    with pytest.raises(GraphError, match='ROS_DOMAIN_ID must be an integer in 0-232'):
        config.domain_id({'ROS_DOMAIN_ID': value})


def test_one_domain_per_process_with_one_discovery_setting(dds_domain):
    acquire_domain(dds_domain, DiscoveryOptions('LOCALHOST'))
    try:
        with pytest.raises(GraphError, match='cannot join it again'):
            acquire_domain(dds_domain, DiscoveryOptions('SUBNET'))
    finally:
        release_domain(dds_domain)


def test_gid_layouts_follow_ros_distro():
    guid = bytes(range(16))
    for size in (16, 24):
        codec = discovery.EntitiesInfoCodec(size)
        data = codec.encode(guid, [('/bear', 'driver', [guid], [guid, guid])])
        assert codec.decode(data) == (guid, [('/bear', 'driver', [guid], [guid, guid])])
        if size == 24:  # Humble's char[24], zero padded after the GUID
            assert data[4:4 + 24] == guid + bytes(8)
    humble = discovery.EntitiesInfoCodec(24).encode(guid, [])
    with pytest.raises(Exception):  # noqa: B017 - any decoding error: the layouts do not mix
        discovery.EntitiesInfoCodec(16).decode(humble + b'\x01')


def test_wait_until_helper_reports_what_it_waited_for():
    start = time.monotonic()
    with pytest.raises(AssertionError, match='the impossible'):
        wait_until(lambda: False, 0.05, 'the impossible')
    assert time.monotonic() - start < 5
