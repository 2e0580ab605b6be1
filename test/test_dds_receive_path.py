"""The executor's receive path on DDS (touch_graph.dds.waker, DdsReader.drain): what its shortcuts keep.

One wake takes every sample DDS holds onto the subscription's queue; each spin_once then runs
one callback, in the spinning thread, in the order published; the counts stay exact.
"""

import threading

import pytest
from dds_testing import SpinningGraph, wait_until

from touch_graph import messages
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, QoSProfile, SingleThreadedExecutor

String = get_message('std_msgs/msg/String')


@pytest.fixture
def talker(dds_domain):
    graph = SpinningGraph()
    yield graph
    graph.close()


@pytest.fixture
def listener_context(dds_domain):
    ctx = Context(network=True)
    ctx.init()
    yield ctx
    if ctx.ok():
        ctx.shutdown()


def _publisher(graph, topic, depth=100):
    node = graph.add_node('talker')
    return graph.call(lambda: node.create_publisher(String, topic, depth))


def test_one_wake_takes_the_burst_and_each_spin_once_runs_one_callback_in_order(talker, listener_context):
    got, threads = [], []
    node = Node('listener', context=listener_context)
    sub = node.create_subscription(String, '/burst', lambda m: (got.append(m.data), threads.append(
        threading.get_ident())), QoSProfile(depth=100))
    executor = SingleThreadedExecutor(context=listener_context)
    executor.add_node(node)
    pub = _publisher(talker, '/burst')
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the remote reader to match')
    talker.call(lambda: [pub.publish(String(data=f'm{i}')) for i in range(30)])
    reader = sub._dds
    wait_until(lambda: (executor.spin_once(0.05), reader.received)[1] > 0, 10, 'the first wake')
    # the samples that had arrived by then were all taken, one callback ran, the rest wait on the queue
    assert len(got) == 1 and len(sub._queue) == reader.received - 1
    wait_until(lambda: (executor.spin_once(0.05), len(got))[1] == 30, 10, 'every callback')
    assert got == [f'm{i}' for i in range(30)]
    assert set(threads) == {threading.get_ident()}  # in the thread that spins, never Cyclone's
    assert sub.received == reader.received == 30 and sub.dropped == 0 and reader.undecodable == 0


def test_a_full_queue_drops_the_oldest_of_a_take_and_counts_them(talker, listener_context):
    node = Node('listener', context=listener_context)
    sub = node.create_subscription(String, '/burst', lambda m: None, QoSProfile(depth=4))
    executor = SingleThreadedExecutor(context=listener_context)
    executor.add_node(node)
    pub = _publisher(talker, '/burst', depth=4)
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the remote reader to match')
    sub._queue.extend(['old0', 'old1'])  # two messages not yet run
    talker.call(lambda: [pub.publish(String(data=f'n{i}')) for i in range(4)])
    reader = sub._dds
    wait_until(lambda: (reader.drain(), reader.received)[1] == 4, 10, 'the four samples taken')
    assert [getattr(m, 'data', m) for m in sub._queue] == ['n0', 'n1', 'n2', 'n3']
    assert sub.dropped == 2 and sub.received == 4  # the oldest two dropped, and counted
    assert executor._ready.count(sub) == 1  # ready once, however many samples came


def test_raw_subscriptions_with_message_info_get_bytes_and_both_timestamps(talker, listener_context):
    got = []
    node = Node('listener', context=listener_context)
    node.create_subscription(String, '/raw', lambda data, info: got.append((data, info)), 10, raw=True)
    executor = SingleThreadedExecutor(context=listener_context)
    executor.add_node(node)
    pub = _publisher(talker, '/raw')
    wait_until(lambda: pub.get_subscription_count() == 1, 10, 'the remote reader to match')
    before = talker.context.now_ns()
    talker.call(pub.publish, String(data='as bytes'))
    wait_until(lambda: (executor.spin_once(0.05), got)[1], 10, 'the sample')
    data, info = got[0]
    assert isinstance(data, bytes) and messages.deserialize(data, 'std_msgs/msg/String').data == 'as bytes'
    assert before <= info['source_timestamp'] <= info['received_timestamp']


def test_the_wait_reports_readers_not_its_own_wake_up(listener_context):
    from touch_graph.dds.cdds import WaitSet
    waitset = WaitSet(listener_context.transport.participant._ref)
    try:
        keys = set()
        assert waitset.wait_into(0, keys) == 0 and keys == set()
        waitset.wake()
        assert waitset.wait_into(1_000_000_000, keys) == 1 and keys == set()  # the guard: woken, no reader
        assert waitset.wait_into(0, keys) == 0  # and the guard was reset
    finally:
        waitset.close()
