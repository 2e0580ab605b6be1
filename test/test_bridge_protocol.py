"""The bridge's pure parts: frame encoding, stream splitting, graph views, discovery helpers."""

import socket

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_graph.bridge.connection import PeerConnection
from touch_graph.bridge.discovery import base_directory, connect_or_clean, domain_id, list_sockets, socket_name
from touch_graph.bridge.graph import GraphView
from touch_graph.bridge.protocol import (
    DATA,
    GRAPH,
    HELLO,
    FrameReader,
    ProtocolError,
    decode_data,
    decode_json,
    encode_data,
    encode_json,
)
from touch_graph.errors import GraphError

frames = st.one_of(
    st.tuples(st.just(DATA), st.text(max_size=40), st.integers(-2**63, 2**63 - 1), st.binary(max_size=300)),
    st.tuples(st.sampled_from([HELLO, GRAPH]), st.dictionaries(st.text(max_size=8), st.integers(), max_size=4)))


def encode(frame):
    if frame[0] == DATA:
        return encode_data(*frame[1:])
    return encode_json(frame[0], frame[1])


@settings(max_examples=60, deadline=None)
@given(st.lists(frames, max_size=12), st.lists(st.integers(1, 64), max_size=30))
def test_frames_survive_any_split_of_the_stream(items, cuts):
    stream = b''.join(encode(f) for f in items)
    reader = FrameReader()
    out, pos = [], 0
    for cut in cuts:
        out += reader.feed(stream[pos:pos + cut])
        pos += cut
    out += reader.feed(stream[pos:])
    assert reader.pending == 0
    decoded = [(k, decode_data(p)) if k == DATA else (k, decode_json(p)) for k, p in out]
    assert decoded == [(f[0], tuple(f[1:])) if f[0] == DATA else (f[0], f[1]) for f in items]


def test_garbage_is_a_protocol_error_not_a_crash():
    with pytest.raises(ProtocolError, match='unknown frame kind 255'):
        FrameReader().feed(b'\x00\x00\x00\x00\xff')
    with pytest.raises(ProtocolError, match='above the limit'):
        FrameReader(max_payload=100).feed(b'\xff\xff\x00\x00\x03')
    with pytest.raises(ProtocolError, match='shorter than its header'):
        decode_data(b'\x01')
    with pytest.raises(ProtocolError, match='cannot hold a 200-byte topic'):
        decode_data(b'\xc8\x00' + b'x' * 20)
    with pytest.raises(ProtocolError, match='JSON'):
        decode_json(b'{not json')
    assert isinstance(ProtocolError('x'), GraphError)


def test_graph_view_merges_peers_and_skips_malformed_entries():
    snaps = [
        {'peer': 'a', 'pid': 1, 'name': 'launch', 'clock': 'sim', 'nodes': [
            {'name': '/bear/driver', 'publishers': [['/bear/frame', 'social_touch_msgs/msg/BearFrame',
                                                     {'depth': 5}]], 'subscriptions': []},
            {'name': '/touch/subtype', 'publishers': [], 'subscriptions': [['/bear/frame',
                                                                            'social_touch_msgs/msg/BearFrame']]},
            {'publishers': []},  # no name: skipped
            {'name': '/bad', 'publishers': [['only-topic']]}]},  # malformed endpoint: node skipped
        {'peer': 'b', 'pid': 2, 'nodes': [
            {'name': '/_bridge_echo', 'publishers': [], 'subscriptions': [['/bear/frame',
                                                                           'social_touch_msgs/msg/BearFrame']]},
            {'name': '/other', 'publishers': [['/bear/frame', 'std_msgs/msg/String', {}]], 'subscriptions': []}]},
        {'nodes': []},  # no peer id: skipped
    ]
    view = GraphView.from_snapshots(snaps)
    assert [n.name for n in view.visible_nodes()] == ['/bear/driver', '/other', '/touch/subtype']
    assert '/_bridge_echo' in [n.name for n in view.visible_nodes(include_hidden=True)]
    topic = view.topics['/bear/frame']
    assert len(topic.publishers) == 2 and len(topic.subscriptions) == 2
    assert topic.type_name == 'social_touch_msgs/msg/BearFrame | std_msgs/msg/String'
    assert topic.publishers[0].qos == {'depth': 5}
    assert view.find_nodes('bear/driver')[0].peer == 'a'
    assert set(view.peers) == {'a', 'b'}


def test_discovery_helpers(tmp_path):
    assert domain_id({}) == 0 and domain_id({'ROS_DOMAIN_ID': ' 12 '}) == 12
    with pytest.raises(GraphError, match='non-negative integer'):
        domain_id({'ROS_DOMAIN_ID': 'robot'})
    assert base_directory({'SOCIAL_TOUCH_GRAPH_DIR': '/x', 'XDG_RUNTIME_DIR': '/run/u'}).as_posix() == '/x'
    assert base_directory({'XDG_RUNTIME_DIR': '/run/u'}).as_posix() == '/run/u/social_touch'
    assert base_directory({}).name.startswith('social_touch-')
    assert socket_name('a/b c', 7, 3) == 'a_b_c.7.3.sock'
    # A socket file whose owner is gone is removed on contact; a live one is connected to.
    dead = tmp_path / 'dead.1.0.sock'
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(dead))
    sock.close()
    (tmp_path / 'notes.txt').write_text('not a socket')
    assert list_sockets(tmp_path) == [dead]
    assert connect_or_clean(dead) is None and not dead.exists()
    live = tmp_path / 'live.1.0.sock'
    server = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    server.bind(str(live))
    server.listen(1)
    client = connect_or_clean(live)
    assert client is not None
    client.close()
    server.close()


def test_send_queue_drops_oldest_and_keeps_control_frames():
    a, b = socket.socketpair()
    try:
        conn = PeerConnection(a, initiated=True, max_frames=3, max_bytes=10_000)
        conn.enqueue_control(encode_json(HELLO, {'peer': 'x'}))
        for i in range(5):
            conn.enqueue_data(encode_data('/t', i, b'x'))
        conn.enqueue_control(encode_json(GRAPH, {'n': 1}), graph=True)
        conn.enqueue_control(encode_json(GRAPH, {'n': 2}), graph=True)  # replaces the unsent one
        assert conn.dropped == 2 and conn.queued() == 3
        a.setblocking(False)
        while conn.write_some():
            pass
        got = FrameReader().feed(b.recv(65536))
        assert [k for k, _ in got] == [HELLO, GRAPH, DATA, DATA, DATA]
        assert decode_json(got[1][1]) == {'n': 2}
        assert [decode_data(p)[1] for _, p in got[2:]] == [2, 3, 4]
        with pytest.raises(ValueError, match='bounds'):
            PeerConnection(a, initiated=True, max_frames=0)
    finally:
        a.close()
        b.close()
