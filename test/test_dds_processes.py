"""Processes on one DDS domain: a plain rclpy-style script hears a launch; ROS 2 reads our discovery info."""

import os
import queue
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

from cyclonedds._clayer import ddspy_take
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsPublication, BuiltinTopicDcpsSubscription
from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic
from dds_testing import SpinningGraph, wait_until
from rosbags.typesys import Stores, get_typestore

from touch_graph.dds.cdds import delete_entity, take_builtin
from touch_graph.dds.idl import idl_struct
from touch_graph.messages import get_message

REPO = Path(__file__).resolve().parent.parent

BEHAVIOUR = '''
from touch_graph.compat import Node, get_message, rclpy
SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
rclpy.init()
node = Node('behaviour')
node.create_subscription(SymbolicGesture, '/touch/symbolic',
                         lambda msg: print('gesture', msg.gesture, msg.state, flush=True), 10)
print('subscribed', flush=True)
rclpy.spin(node)
'''


def child_env(domain):
    env = {k: v for k, v in os.environ.items() if k != 'SOCIAL_TOUCH_NETWORK'}
    return {**env, 'ROS_DOMAIN_ID': str(domain)}


def line_reader(stream):
    """``next_line(timeout_s, what)``: the stream's next line ('' at its end), read in a thread that closes it at
    its end; AssertionError naming ``what`` after ``timeout_s``."""
    lines = queue.Queue()

    def pump():
        with stream:
            for line in stream:
                lines.put(line)
        lines.put('')   # end of the stream
    threading.Thread(target=pump, daemon=True).start()

    def next_line(timeout_s, what):
        try:
            return lines.get(timeout=timeout_s)
        except queue.Empty:
            raise AssertionError(f'timed out after {timeout_s} s waiting for {what}') from None
    return next_line


def stop(proc):
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(10)


def test_a_plain_rclpy_script_hears_a_launch_and_is_listed(dds_domain, tmp_path):
    env = child_env(dds_domain)
    script = tmp_path / 'behaviour.py'
    script.write_text(BEHAVIOUR)
    behaviour = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.PIPE, text=True,
                                 stderr=subprocess.DEVNULL)
    next_line = line_reader(behaviour.stdout)
    launch = None
    try:
        # The scene at 10x is over in seconds: the launch starts once the listener has subscribed.
        assert next_line(60, 'the listener to subscribe') == 'subscribed\n'
        launch = subprocess.Popen([sys.executable, '-m', 'touch_lab.cli.main', 'launch', 'launch/bear.launch.yaml',
                                   'monitor:=false', '--sim-time', '--rate', '10'], cwd=REPO, env=env,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        line = next_line(60, 'a gesture')  # the synthetic people of the scene hug and pat the bear
        assert line.startswith('gesture '), line
        listed = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'node', 'list'], cwd=REPO, env=env,
                                capture_output=True, text=True, timeout=60)
        assert {'/behaviour', '/bear/bear_gestures', '/bear/bear_driver'} <= set(listed.stdout.split()), listed
        info = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'node', 'info', '/behaviour'], cwd=REPO,
                              env=env, capture_output=True, text=True, timeout=60)
        assert '    /touch/symbolic: social_touch_msgs/msg/SymbolicGesture' in info.stdout.splitlines()
    finally:
        if launch is not None:
            stop(launch)
        stop(behaviour)   # the reading thread closes its stdout at the end


def test_ros_discovery_info_is_what_ros2_reads(dds_domain):
    """An independent participant decodes our ros_discovery_info (rosbags' rmw_dds_common, Iron+ layout)
    and finds each node's readers and writers among the DDS endpoints, as `ros2 node info` does."""
    graph = SpinningGraph()
    reader_side = DomainParticipant(dds_domain)
    try:
        node = graph.add_node('haptics', namespace='/skin')
        graph.call(lambda: node.create_publisher(get_message('HapticCommand'), '/touch/haptic_command', 10))
        graph.call(lambda: node.create_subscription(get_message('SkinFrame'), 'frame', lambda m: None, 10))
        store = get_typestore(Stores.LATEST)
        latched = Qos(Policy.Reliability.Reliable(0), Policy.Durability.TransientLocal, Policy.History.KeepLast(1))
        topic = Topic(reader_side, 'ros_discovery_info', idl_struct('rmw_dds_common/msg/ParticipantEntitiesInfo',
                                                                   graph.context.transport.graph.codec.store))
        info_reader = DataReader(reader_side, topic, latched)
        publications = BuiltinDataReader(reader_side, BuiltinTopicDcpsPublication)
        subscriptions = BuiltinDataReader(reader_side, BuiltinTopicDcpsSubscription)
        latest = {}

        def read():
            for data, sample in ddspy_take(info_reader._ref, 0, 100):
                if sample.valid_data:
                    info = store.deserialize_cdr(data, 'rmw_dds_common/msg/ParticipantEntitiesInfo')
                    latest[bytes(info.gid.data)] = info
            # its publisher, /parameter_events, /rosout, the six parameter services' and get_type_description's
            return any(n.node_name == 'haptics' and len(n.writer_gid_seq) == 10 and len(n.reader_gid_seq) == 8
                       for info in latest.values() for n in info.node_entities_info_seq)
        wait_until(read, 10, "our node with its endpoints in ros_discovery_info")
        info = next(i for i in latest.values() if any(n.node_name == 'haptics' for n in i.node_entities_info_seq))
        assert bytes(info.gid.data) == graph.context.transport.gid  # the participant's GUID, 16 bytes (Iron+)
        entry = next(n for n in info.node_entities_info_seq if n.node_name == 'haptics')
        assert entry.node_namespace == '/skin'
        endpoints = {}

        def seen():
            for sample in take_builtin(publications, 100) + take_builtin(subscriptions, 100):
                endpoints[sample.key.bytes] = (sample.topic_name, sample.type_name)
            gids = [bytes(g.data) for g in (*entry.writer_gid_seq, *entry.reader_gid_seq)]
            return all(gid in endpoints for gid in gids)
        wait_until(seen, 10, 'the node\'s endpoints in DCPSPublication/DCPSSubscription')
        writers = {endpoints[bytes(g.data)] for g in entry.writer_gid_seq}
        readers = {endpoints[bytes(g.data)] for g in entry.reader_gid_seq}
        services = ('describe_parameters', 'get_parameters', 'get_parameter_types', 'list_parameters',
                    'set_parameters', 'set_parameters_atomically')
        srv_type = {'describe_parameters': 'DescribeParameters', 'get_parameters': 'GetParameters',
                    'get_parameter_types': 'GetParameterTypes', 'list_parameters': 'ListParameters',
                    'set_parameters': 'SetParameters', 'set_parameters_atomically': 'SetParametersAtomically'}
        assert writers == {('rt/touch/haptic_command', 'social_touch_msgs::msg::dds_::HapticCommand_'),
                           ('rt/parameter_events', 'rcl_interfaces::msg::dds_::ParameterEvent_'),
                           ('rt/rosout', 'rcl_interfaces::msg::dds_::Log_'),
                           *((f'rr/skin/haptics/{s}Reply', f'rcl_interfaces::srv::dds_::{srv_type[s]}_Response_')
                             for s in services),
                           ('rr/skin/haptics/get_type_descriptionReply',
                            'type_description_interfaces::srv::dds_::GetTypeDescription_Response_')}
        assert readers == {('rt/skin/frame', 'social_touch_msgs::msg::dds_::SkinFrame_'),
                           *((f'rq/skin/haptics/{s}Request', f'rcl_interfaces::srv::dds_::{srv_type[s]}_Request_')
                             for s in services),
                           ('rq/skin/haptics/get_type_descriptionRequest',
                            'type_description_interfaces::srv::dds_::GetTypeDescription_Request_')}
    finally:
        delete_entity(reader_side)
        graph.close()


def test_a_vanished_peer_blocks_nobody(dds_domain, tmp_path):
    """A reliable subscriber in another process is killed (SIGKILL): our publisher goes on, nothing waits."""
    env = child_env(dds_domain)
    script = tmp_path / 'listener.py'
    script.write_text(BEHAVIOUR.replace("'behaviour'", "'doomed'"))
    doomed = subprocess.Popen([sys.executable, str(script)], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)
    graph = SpinningGraph()
    try:
        node = graph.add_node('bear_gestures')
        cls = get_message('SymbolicGesture')
        pub = graph.call(lambda: node.create_publisher(cls, '/touch/symbolic', 20))
        wait_until(lambda: pub.get_subscription_count() == 1, 20, 'the other process to subscribe')
        doomed.send_signal(signal.SIGKILL)
        doomed.wait(10)
        msg = cls(gesture='hug', sensors=['head1'] * 50)
        start = time.monotonic()
        for _ in range(2000):  # far beyond the depth of 20: the gone reader's acks never come
            graph.call(pub.publish, msg)
        assert time.monotonic() - start < 20
        assert pub._dds.failed == 0 and pub._dds.written > 0
    finally:
        graph.close()
        if doomed.poll() is None:
            doomed.kill()
            doomed.wait(10)


def test_transport_bench_measures_both_paths(dds_domain, monkeypatch):
    """A short run of `social-touch bench transport`: every ping comes back on both paths, figures are sane."""
    from touch_lab.bench.transport import bench_transport
    monkeypatch.setenv('SOCIAL_TOUCH_BENCH_DOMAIN', str(dds_domain))
    result = bench_transport(repeats=1, pings=20, kinds=['gesture_event'], ramp_steps=1)
    figures = result['kinds']['gesture_event']
    assert result['domain'] == dds_domain
    assert (figures['ours_lost_pings'] == figures['ours_cdr_lost_pings'] == figures['raw_lost_pings']
            == figures['raw_codec_lost_pings'] == 0)
    assert 0 < figures['raw_latency_median_us'] <= figures['raw_latency_p99_us']
    assert figures['overhead_ratio'] > 0 and figures['overhead_ratio_cdr'] > 0 and figures['overhead_ratio_codec'] > 0
    low, high = figures['overhead_ratio_rounds']
    assert 0 < low <= high
    low, high = figures['raw_latency_round_medians_us']
    assert 0 < low <= figures['raw_latency_median_us'] * 1.01 and high >= low
    assert figures['ours_lossless_rate_hz'] == figures['rate_ramp_top_hz'] == 25.0  # goal/4: 10 Hz x 10 / 4
    load = result['load']
    assert load['cpus'] >= 1 and len(load['loadavg_before']) == 3
    if 'machine_busy_pct' in load:  # Linux
        assert 0 <= load['bench_pct'] <= load['machine_busy_pct'] <= 100 and load['others_pct'] >= 0
