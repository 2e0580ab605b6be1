"""The runtime on DDS: contexts join their domain, deliver in memory inside, over DDS between them."""

import os
import threading
import time

import numpy as np
import pytest
from dds_testing import SpinningGraph, wait_until

from touch_graph.messages import get_message
from touch_graph.runtime import (
    Context,
    DurabilityPolicy,
    Node,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
)

String = get_message('std_msgs/msg/String')
PatchFrame = get_message('PatchFrame')


@pytest.fixture
def graphs(dds_domain):
    made = []

    def make(*args, **kwargs):
        made.append(SpinningGraph(*args, **kwargs))
        return made[-1]
    yield make
    for g in made:
        g.close()


def test_who_joins_the_network(dds_domain, monkeypatch):
    assert Context().network and Context('wall').network
    assert not Context('sim').network  # a simulated world is private unless asked
    assert Context('sim', network=True).network
    monkeypatch.setenv('SOCIAL_TOUCH_NETWORK', '0')
    assert not Context().network and Context(network=True).network
    ctx = Context(network=False)
    ctx.init()
    try:
        assert ctx.transport is None
    finally:
        ctx.shutdown()


def test_messages_cross_contexts_in_order_and_only_once(graphs):
    a, b = graphs(), graphs()
    talker, listener = a.add_node('talker'), b.add_node('listener')
    remote, local = [], []
    a.call(lambda: talker.create_subscription(String, '/chatter', lambda m: local.append(m.data), 100))
    b.call(lambda: listener.create_subscription(String, '/chatter', lambda m: remote.append(m.data), 100))
    pub = a.call(lambda: talker.create_publisher(String, '/chatter', 100))
    wait_until(lambda: pub.get_subscription_count() == 2, 10, 'the remote reader to match')
    a.call(lambda: [pub.publish(String(data=f'hello {i}')) for i in range(50)])
    wait_until(lambda: len(remote) == 50, 10, '50 messages in the other context')
    assert remote == [f'hello {i}' for i in range(50)]
    wait_until(lambda: len(local) == 50, 10, 'the local subscription')
    assert local == remote  # in memory, and not echoed back by DDS: exactly once
    assert pub._dds.written == 50


def test_nothing_is_serialised_for_nobody(graphs):
    a = graphs()
    node = a.add_node('lonely')
    got = []
    a.call(lambda: node.create_subscription(String, '/x', got.append, 10))
    pub = a.call(lambda: node.create_publisher(String, '/x', 10))
    a.call(lambda: [pub.publish(String(data='only here')) for _ in range(5)])
    wait_until(lambda: len(got) == 5, 5, 'local delivery')
    assert pub._dds.written == 0 and pub._dds.skipped == 5


def test_spin_once_runs_the_sample_it_waited_for(graphs):
    """As rclpy's spin_once: a sample that wakes the wait is run in that call, not the next one."""
    a = graphs()
    ctx = Context(network=True)
    ctx.init()
    try:
        got = []
        listener = Node('listener', context=ctx)
        listener.create_subscription(String, '/wake', lambda m: got.append(m.data), 10)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(listener)
        talker = a.add_node('talker')
        pub = a.call(lambda: talker.create_publisher(String, '/wake', 10))
        wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the remote reader to match')
        for _ in range(20):
            executor.spin_once(0)  # what is pending already (the waker's first wake)
        sender = threading.Timer(0.3, lambda: a.call(lambda: pub.publish(String(data='now'))))
        sender.start()
        started = time.monotonic()
        executor.spin_once(5.0)
        sender.join()
        assert got == ['now'] and time.monotonic() - started < 5.0
    finally:
        ctx.shutdown()


def test_sensor_frames_best_effort_and_message_info(graphs):
    a, b = graphs(), graphs()
    driver, recogniser = a.add_node('driver'), b.add_node('recogniser')
    sensor = QoSProfile(depth=5, reliability=ReliabilityPolicy.BEST_EFFORT)
    got = []
    b.call(lambda: recogniser.create_subscription(PatchFrame, '/patch/frame',
                                                  lambda m, info: got.append((m, info)), sensor))
    pub = a.call(lambda: driver.create_publisher(PatchFrame, '/patch/frame', sensor))
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the match')
    frame = PatchFrame(sequence=3, activation=np.linspace(0, 1, 256, dtype=np.float32))
    before = a.context.now_ns()
    a.call(pub.publish, frame)
    wait_until(lambda: got, 10, 'the frame')
    msg, info = got[0]
    assert msg == frame
    assert before <= info['source_timestamp'] <= info['received_timestamp']


def test_transient_local_is_served_to_late_joiners(graphs):
    a, b = graphs(), graphs()
    node = a.add_node('map_server')
    latched = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = a.call(lambda: node.create_publisher(String, '/map', latched))
    a.call(lambda: [pub.publish(String(data=f'map {i}')) for i in range(3)])  # nobody listens yet
    late = b.add_node('late')
    got = []
    b.call(lambda: late.create_subscription(String, '/map', lambda m: got.append(m.data), latched))
    wait_until(lambda: len(got) == 2, 10, 'the last two latched messages')
    assert got == ['map 1', 'map 2']


def test_simulated_time_is_the_source_timestamp(graphs):
    sim, tool = graphs('sim'), graphs()
    stamps = []
    listener = tool.add_node('tool')
    tool.call(lambda: listener.create_subscription(String, '/tick', lambda m, info: stamps.append(
        info['source_timestamp']), 10))
    node = sim.add_node('scene')
    pub = sim.call(lambda: node.create_publisher(String, '/tick', 10))
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the match')
    when = sim.call(lambda: (pub.publish(String(data='t')), sim.context.now_ns())[1])
    wait_until(lambda: stamps, 10, 'the sample')
    assert stamps == [when]


def test_a_full_queue_is_counted_not_blocking(graphs):
    """A subscriber slower than its publisher drops its oldest messages, counts them, and stalls nobody."""
    a, b = graphs(), graphs()
    slow = b.add_node('slow')
    got = []

    def slow_callback(msg):
        time.sleep(0.004)
        got.append(msg.data)
    sub = b.call(lambda: slow.create_subscription(String, '/burst', slow_callback, 5))
    node = a.add_node('fast')
    pub = a.call(lambda: node.create_publisher(String, '/burst', 1000))
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the match')
    start = time.monotonic()
    for i in range(300):  # 1 kHz from this thread: publishing never waits for the slow reader
        pub.publish(String(data=f'm{i}'))
        time.sleep(0.001)
    assert time.monotonic() - start < 5
    wait_until(lambda: sub.received >= 290 and sub.received == len(got) + sub.dropped, 10,
               'the samples taken and the queue drained')
    assert sub.dropped > 50  # the oldest dropped, and counted
    assert got == sorted(got, key=lambda text: int(text[1:]))  # what is left comes in order


def test_shutdown_leaves_no_threads(dds_domain):
    """Neither Python threads nor Cyclone's own (OS threads of this process) outlive the context."""
    def os_threads():
        return len(os.listdir('/proc/self/task'))
    before, os_before = set(threading.enumerate()), os_threads()
    for _ in range(2):
        ctx = Context(network=True)
        ctx.init()
        node = Node('n', context=ctx)
        node.create_publisher(String, '/x', 10)
        node.create_subscription(String, '/x', lambda m: None, 10)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.spin_once(0)
        ctx.shutdown()
        assert ctx.transport is None
    wait_until(lambda: set(threading.enumerate()) <= before, 10, 'threads to end')
    wait_until(lambda: os_threads() <= os_before, 10, "Cyclone's threads to end")


def test_graph_queries_of_a_node_see_the_domain(graphs):
    a, b = graphs(), graphs()
    na = a.add_node('here')
    b.add_node('there', namespace='/far')
    wait_until(lambda: ('there', '/far') in na.get_node_names_and_namespaces(), 10, 'the remote node')
    assert 'there' in na.get_node_names()
