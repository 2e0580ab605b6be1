"""The in-process graph: topics, queues, timers, simulated time, errors in callbacks, threads."""

import threading

import numpy as np
import pytest

from touch_graph.errors import GraphError
from touch_graph.messages import get_message
from touch_graph.runtime import (
    Context,
    DurabilityPolicy,
    Node,
    QoSProfile,
    SingleThreadedExecutor,
)

Frame = get_message('PatchFrame')
Command = get_message('HapticCommand')


@pytest.fixture
def ctx():
    context = Context('sim')
    context.init()
    yield context
    context.try_shutdown()


def make_graph(ctx, *nodes):
    executor = SingleThreadedExecutor(context=ctx)
    for node in nodes:
        executor.add_node(node)
    return executor


class Counter(Node):
    """Publishes a sequence number on 'frame' at 20 Hz."""

    def __init__(self, **kwargs):
        super().__init__('counter', **kwargs)
        self.pub = self.create_publisher(Frame, 'frame', 10)
        self.n = 0
        self.create_timer(0.05, self.tick)

    def tick(self):
        self.n += 1
        self.pub.publish(Frame(sequence=self.n))


def test_timer_in_simulated_time_is_deterministic(ctx):
    counter = Counter(context=ctx)
    seen = []
    listener = Node('listener', context=ctx)
    listener.create_subscription(Frame, '/frame', lambda m: seen.append((ctx.now_ns(), m.sequence)), 10)
    make_graph(ctx, counter, listener).spin_for(1.0)
    assert [s for _, s in seen] == list(range(1, 21))
    start = seen[0][0] - 50_000_000
    assert [t - start for t, _ in seen] == [50_000_000 * k for k in range(1, 21)]


def test_namespaces_remaps_and_private_names(ctx):
    node = Node('driver', context=ctx, namespace='bear',
                cli_args=['--ros-args', '-r', 'frame:=/sensors/bear', '-r', '__node:=bear_driver'])
    assert node.get_fully_qualified_name() == '/bear/bear_driver'
    assert node.resolve_topic_name('frame') == '/sensors/bear'
    assert node.resolve_topic_name('~/status') == '/bear/bear_driver/status'
    assert node.resolve_topic_name('other') == '/bear/other'
    with pytest.raises(GraphError, match='invalid topic name'):
        node.create_publisher(Frame, 'bad name', 10)


def test_full_queue_drops_oldest_and_counts(ctx):
    talker = Node('talker', context=ctx)
    pub = talker.create_publisher(Frame, 'x', 10)
    got = []
    sub = Node('slow', context=ctx).create_subscription(Frame, 'x', lambda m: got.append(m.sequence), 3)
    executor = make_graph(ctx, talker, sub.node)
    for k in range(10):
        pub.publish(Frame(sequence=k))
    executor.spin_for(0.01)
    assert got == [7, 8, 9]
    assert (sub.received, sub.dropped) == (10, 7)


def test_a_raising_callback_ends_the_spin_with_its_exception_as_in_rclpy(ctx):
    counter = Counter(context=ctx)
    bad = Node('bad', context=ctx)

    def explode(msg):
        raise ValueError(f'cannot handle {msg.sequence}')
    bad.create_subscription(Frame, '/frame', explode, 10)
    good = []
    Node('good', context=ctx).create_subscription(Frame, '/frame', lambda m: good.append(m.sequence), 10)
    executor = make_graph(ctx, counter, bad, *[n for n in ctx.nodes if n.get_name() == 'good'])
    end = ctx.now_ns() + 1_000_000_000
    with pytest.raises(ValueError, match='cannot handle 1') as raised:
        executor.spin_until_time(end)
    assert "raised by the subscription to '/frame' callback of node /bad" in raised.value.__notes__[0]
    assert executor.last_failure == (bad, "subscription to '/frame'")
    assert bad.callback_errors == 1 and ctx.callback_errors == 1
    executor.remove_node(bad)                      # it died; the rest of the graph spins on
    executor.spin_until_time(end)
    assert good == list(range(1, 21))


def test_a_raising_timer_ends_spin_once_and_the_next_spin_goes_on(ctx):
    node = Node('ticker', context=ctx)
    ticks = []

    def tick():
        ticks.append(len(ticks))
        if len(ticks) == 1:
            raise OSError('first tick failed')
    node.create_timer(0.1, tick)
    executor = make_graph(ctx, node)
    with pytest.raises(OSError, match='first tick failed'):
        executor.spin_once(1.0)
    executor.spin_for(0.35)
    assert ticks == [0, 1, 2, 3] and node.callback_errors == 1


def test_publishing_the_wrong_type_or_a_second_type_on_a_topic_is_refused(ctx):
    node = Node('n', context=ctx)
    pub = node.create_publisher(Frame, 'x', 10)
    with pytest.raises(TypeError, match='PatchFrame'):
        pub.publish(Command())
    with pytest.raises(GraphError, match='already carries social_touch_msgs/msg/PatchFrame'):
        node.create_subscription(Command, 'x', lambda m: None, 10)


def test_raw_subscription_gets_cdr_and_bytes_can_be_published(ctx):
    node = Node('n', context=ctx)
    pub = node.create_publisher(Frame, 'x', 10)
    raw, typed = [], []
    node.create_subscription(Frame, 'x', raw.append, 10, raw=True)
    node.create_subscription(Frame, 'x', typed.append, 10)
    executor = make_graph(ctx, node)
    msg = Frame(sequence=5, activation=np.full(256, 0.5, np.float32))
    pub.publish(msg)
    executor.spin_for(0.0)
    assert isinstance(raw[0], bytes) and typed[0] is msg
    pub.publish(raw[0])  # publishing CDR bytes delivers a decoded message
    executor.spin_for(0.0)
    assert typed[1] == msg


def test_transient_local_hands_the_last_messages_to_late_joiners(ctx):
    node = Node('n', context=ctx)
    latched = QoSProfile(depth=2, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    pub = node.create_publisher(Command, 'map', latched)
    for k in range(3):
        pub.publish(Command(command=f'c{k}'))
    got = []
    node.create_subscription(Command, 'map', lambda m: got.append(m.command), latched)
    make_graph(ctx, node).spin_for(0.0)
    assert got == ['c1', 'c2']


def test_publish_from_another_thread_reaches_the_spinning_thread():
    ctx = Context('wall')
    ctx.init()
    node = Node('n', context=ctx)
    pub = node.create_publisher(Frame, 'x', 100)
    threads = []
    node.create_subscription(Frame, 'x', lambda m: threads.append(threading.get_ident()), 100)
    executor = make_graph(ctx, node)
    executor.spin_once(0)  # the executor now knows its thread

    def produce():
        for k in range(50):
            pub.publish(Frame(sequence=k))
    worker = threading.Thread(target=produce)
    worker.start()
    worker.join()
    assert executor.spin_until(lambda: len(threads) == 50, timeout_sec=5.0)
    assert set(threads) == {threading.get_ident()}
    ctx.shutdown()


def test_destroy_node_twice_and_endpoints_leave_the_graph(ctx):
    node = Counter(context=ctx)
    executor = make_graph(ctx, node)
    assert '/frame' in ctx.topics
    node.destroy_node()
    node.destroy_node()
    assert '/frame' not in ctx.topics and node not in ctx.nodes
    executor.spin_for(1.0)  # its timer no longer fires
    assert node.n == 0
    with pytest.raises(GraphError, match='destroyed'):
        node.create_timer(1.0, lambda: None)


def test_nodes_need_an_initialised_context():
    with pytest.raises(GraphError, match='init'):
        Node('n', context=Context('sim'))


def test_shutdown_stops_spin_from_a_callback(ctx):
    node = Counter(context=ctx)
    node.create_timer(0.3, ctx.shutdown)
    make_graph(ctx, node).spin()
    assert node.n == 6  # ticks at 0.05..0.30; shutdown's timer was created later, so it runs after


def test_timer_skips_missed_periods_without_drift(ctx):
    node = Node('n', context=ctx)
    calls = []
    timer = node.create_timer(0.1, lambda: calls.append(ctx.now_ns()))
    executor = make_graph(ctx, node)
    ctx.time_source.advance_to(ctx.now_ns() + 350_000_000)  # the executor was away for 0.35 s
    executor.spin_for(0.0)
    assert len(calls) == 1 and timer.missed == 2
    executor.spin_for(0.1)
    assert (calls[1] - calls[0]) % 100_000_000 == 50_000_000  # back on the original grid (0.4 s)


def test_ignore_local_publications_skips_the_nodes_own_messages(ctx):
    bridge, other = Node('bridge', context=ctx), Node('other', context=ctx)
    own = bridge.create_publisher(Frame, 'x', 10)
    foreign = other.create_publisher(Frame, 'x', 10)
    got = []
    bridge.create_subscription(Frame, 'x', lambda m: got.append(m.sequence), 10, ignore_local_publications=True)
    executor = make_graph(ctx, bridge, other)
    own.publish(Frame(sequence=1))
    foreign.publish(Frame(sequence=2))
    executor.spin_for(0.0)
    assert got == [2]
