"""Graph processes joined by the bridge: messages both ways, slow readers, dying peers, clean shutdown."""

import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import textwrap
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from touch_graph.bridge import Bridge
from touch_graph.bridge.protocol import HELLO, encode_json
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, SingleThreadedExecutor

String = get_message('std_msgs/msg/String')
Header = get_message('std_msgs/msg/Header')
PatchFrame = get_message('PatchFrame')
REPO = Path(__file__).resolve().parent.parent

TALKER = textwrap.dedent('''
    import sys
    from touch_graph.compat import Node, get_message
    from touch_graph.node_main import run_node
    String = get_message('std_msgs/msg/String')

    class DemoTalker(Node):
        """Says hello 50 times a second; answers every /cmd on /cmd_echo."""

        def __init__(self, **kwargs):
            super().__init__('demo_talker', **kwargs)
            self.pub = self.create_publisher(String, '/chatter', 10)
            self.echo = self.create_publisher(String, '/cmd_echo', 10)
            self.create_subscription(String, '/cmd', lambda m: self.echo.publish(String(data='echo ' + m.data)), 10)
            self.n = 0
            self.create_timer(1 / self.declare_parameter('rate', 50.0).value, self.tick)

        def tick(self):
            self.pub.publish(String(data=f'hello {self.n}'))
            self.n += 1

    sys.exit(run_node(DemoTalker, sys.argv[1:]))
''')


def wait_until(predicate, timeout_s=20.0, what='condition'):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f'timed out after {timeout_s} s waiting for {what}')


@pytest.fixture
def graph_dir(monkeypatch):
    path = Path(tempfile.mkdtemp(prefix='stg', dir='/tmp'))  # short: socket paths are limited to 107 bytes
    monkeypatch.setenv('SOCIAL_TOUCH_GRAPH_DIR', str(path))
    monkeypatch.delenv('ROS_DOMAIN_ID', raising=False)
    yield path
    shutil.rmtree(path, ignore_errors=True)


class Peer:
    """An in-process graph with a bridge, its executor spinning in a thread of its own."""

    def __init__(self, name, clock='wall', **bridge_kwargs):
        self.context = Context(clock)
        self.context.init()
        self.executor = SingleThreadedExecutor(context=self.context)
        self.bridge = Bridge(self.context, self.executor, name=name, **bridge_kwargs).start()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self):
        while self.context.ok():
            self.executor.spin_once(0.05)

    def call(self, fn, *args):
        """Run ``fn(*args)`` in the executor thread and return its result."""
        done, box = threading.Event(), []

        def run():
            try:
                box.append(fn(*args))
            finally:
                done.set()
        self.executor.call_soon_threadsafe(run)
        assert done.wait(10), 'executor did not run the call'
        return box[0] if box else None

    def add_node(self, name):
        def make():
            node = Node(name, context=self.context)
            self.executor.add_node(node)
            return node
        return self.call(make)

    def close(self):
        self.bridge.stop()
        self.context.try_shutdown()
        self.thread.join(10)


@pytest.fixture
def peers(graph_dir):
    """Make in-process peers in the test's private graph directory."""
    made = []

    def make(name, **kwargs):
        made.append(Peer(name, **kwargs))
        return made[-1]
    yield make
    for peer in made:
        peer.close()


@pytest.fixture
def talker(graph_dir):
    script = graph_dir / 'talker.py'
    script.write_text(TALKER)
    proc = subprocess.Popen([sys.executable, str(script)], cwd=REPO, stderr=subprocess.PIPE, text=True,
                            env={**os.environ, 'PYTHONPATH': str(REPO)})
    yield proc
    if proc.poll() is None:
        proc.send_signal(signal.SIGKILL)
    proc.wait(10)
    proc.stderr.close()


def node_names(peer):
    return {n.name for n in peer.bridge.remote_graph().nodes}


def test_messages_cross_processes_both_ways(talker, peers):
    peer = peers('tester')
    wait_until(lambda: '/demo_talker' in node_names(peer), what='the talker process in the graph')
    got, echoes = [], []
    node = peer.add_node('listener')
    pub = peer.call(lambda: node.create_publisher(String, '/cmd', 10))
    peer.call(lambda: node.create_subscription(String, '/chatter', lambda m: got.append(m.data), 10))
    peer.call(lambda: node.create_subscription(String, '/cmd_echo', lambda m: echoes.append(m.data), 10))
    wait_until(lambda: len(got) >= 20, what='20 messages from the talker process')
    numbers = [int(text.split()[1]) for text in got[:20]]
    assert numbers == list(range(numbers[0], numbers[0] + 20))  # in order, none lost
    # The talker announced our subscription's peer as interested; now the other way round.
    wait_until(lambda: pub.get_subscription_count() > 0, what='the bridge linking /cmd to the talker')
    peer.call(pub.publish, String(data='ping'))
    wait_until(lambda: echoes == ['echo ping'], what="the talker's answer")
    assert peer.bridge.stats()['dropped'] == 0


def test_a_peer_that_dies_leaves_no_stale_state(talker, peers, graph_dir):
    peer = peers('survivor')
    wait_until(lambda: '/demo_talker' in node_names(peer), what='the talker process in the graph')
    got = []
    node = peer.add_node('listener')
    peer.call(lambda: node.create_subscription(String, '/chatter', lambda m: got.append(m.data), 10))
    wait_until(lambda: got, what='a message')
    sockets = {p.name for p in (graph_dir / '0').iterdir()}
    assert len(sockets) == 2
    talker.send_signal(signal.SIGKILL)
    talker.wait(10)
    wait_until(lambda: not node_names(peer) and not peer.bridge.peers(), what='the dead peer to vanish')
    # Its socket file is gone too (removed by the survivor), and nothing it offered is still bridged.
    wait_until(lambda: [p.name for p in (graph_dir / '0').iterdir()] == [peer.bridge.peer_id],
               what='the stale socket file to be removed')
    assert peer.bridge.remote_graph().topics == {}
    # A newcomer sees only the survivor.
    other = peers('newcomer')
    assert other.bridge.wait_for_discovery(5)
    assert other.bridge.peers() == [peer.bridge.peer_id]


def test_slow_reader_never_blocks_the_publisher(peers, graph_dir):
    """A peer that stops reading (a paused topic echo) costs dropped frames, not a stalled graph."""
    fast = peers('robot', send_queue_frames=20)
    good = peers('good')
    # The slow peer: a raw client that announces a subscription to /patch/frame and never reads.
    slow = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    slow.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    slow.connect(str(fast.bridge.path))
    snapshot = {'peer': 'slow', 'pid': 0, 'nodes': [
        {'name': '/paused_echo', 'publishers': [], 'subscriptions': [['/patch/frame', PatchFrame.__msgtype__]]}]}
    slow.sendall(encode_json(HELLO, {'protocol': 1, 'peer': 'slow.0.0.sock', 'name': 'slow', 'pid': 0}))
    slow.sendall(encode_json(2, snapshot))
    try:
        received = []
        node = good.add_node('monitor')
        good.call(lambda: node.create_subscription(PatchFrame, '/patch/frame', lambda m: received.append(m), 100))
        robot = fast.add_node('patch_driver')
        pub = fast.call(lambda: robot.create_publisher(PatchFrame, '/patch/frame', 10))
        wait_until(lambda: len(fast.bridge._senders.get('/patch/frame', ())) == 2, what='both readers linked')
        frame = PatchFrame(activation=np.ones(256, np.float32))
        start = time.monotonic()
        for _ in range(40):  # 40 x 200 frames of ~1.8 kB: far more than the slow socket buffers
            fast.call(lambda: [pub.publish(frame) for _ in range(200)])
        elapsed = time.monotonic() - start
        stats = fast.bridge.stats()
        assert stats['dropped'] > 1000, stats  # the slow link dropped its oldest frames
        assert elapsed < 30  # and the publishing executor was never blocked (generous: loaded CI)
        wait_until(lambda: len(received) > 0, what='the good reader to receive')
    finally:
        slow.close()


def test_stamps_carry_the_publishers_simulated_time(peers):
    sim = peers('scene', clock='sim')
    tool = peers('tool')
    stamps = []
    tool.bridge.tap('/touch/gesture', lambda s: stamps.append((s.stamp_ns, s.type_name, s.peer)),
                    'std_msgs/msg/String')
    node = sim.add_node('gestures')
    pub = sim.call(lambda: node.create_publisher(String, '/touch/gesture', 10))
    wait_until(lambda: pub.get_subscription_count() > 0, what='the tap to be linked')
    when = sim.call(lambda: (pub.publish(String(data='stroke')), sim.context.now_ns())[1])
    wait_until(lambda: stamps, what='the sample')
    assert stamps == [(when, 'std_msgs/msg/String', sim.bridge.peer_id)]
    assert abs(when - time.time_ns()) > 10**15  # simulated epoch, far from the wall clock


def test_type_conflict_is_not_bridged(peers):
    a = peers('a')
    b = peers('b')
    got = []
    sub_node = b.add_node('header_listener')
    b.call(lambda: sub_node.create_subscription(Header, '/x', got.append, 10))
    pub_node = a.add_node('string_talker')
    pub = a.call(lambda: pub_node.create_publisher(String, '/x', 10))
    wait_until(lambda: '/x' in a.bridge.remote_graph().topics, what='the subscription to be announced')
    time.sleep(0.2)  # let a sync run; nothing must be linked
    assert pub.get_subscription_count() == 0
    a.call(pub.publish, String(data='not a header'))
    time.sleep(0.2)
    assert got == [] and b.bridge.stats()['received'] == 0
    assert ('/x', Header.__msgtype__) in a.bridge._warned


def test_garbage_from_a_peer_closes_only_that_link(peers):
    a = peers('a')
    b = peers('b')
    assert a.bridge.wait_until(lambda v: b.bridge.peer_id in v.peers, 5)
    junk = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    junk.connect(str(a.bridge.path))
    junk.settimeout(10)
    junk.sendall(b'GET / HTTP/1.1\r\n\r\n')
    data = junk.recv(65536)
    while data:  # the bridge's HELLO/GRAPH, then end of stream when it drops us
        data = junk.recv(65536)
    junk.close()
    assert a.bridge.peers() == [b.bridge.peer_id]


def test_stop_leaves_no_threads_sockets_or_files(graph_dir):
    def fds():
        return len(os.listdir('/proc/self/fd'))
    threads_before, fds_before = set(threading.enumerate()), fds()
    for _ in range(2):
        a, b = Peer('a'), Peer('b')
        assert b.bridge.wait_for_discovery(5) and b.bridge.peers() == [a.bridge.peer_id]
        a.close()
        b.close()
        a.bridge.stop()  # twice is fine
    wait_until(lambda: set(threading.enumerate()) <= threads_before, 10, 'threads to end')
    assert fds() == fds_before
    assert list((graph_dir / '0').iterdir()) == []


def test_domains_are_separate(graph_dir, peers, monkeypatch):
    a = peers('a')
    monkeypatch.setenv('ROS_DOMAIN_ID', '3')
    b = peers('b')
    assert b.bridge.wait_for_discovery(5)
    assert b.bridge.peers() == [] and b.bridge.path.parent.name == '3' and a.bridge.path.parent.name == '0'
