"""``foxglove_server``: a Foxglove WebSocket client receives the graph's messages with their ros2msg schemas.

The client here is written with the ``websockets`` library and speaks the documented Foxglove
WebSocket protocol (JSON ``serverInfo``/``advertise``/``subscribe``, binary message data: opcode 1,
uint32 subscription id, uint64 log time, payload). foxglove-sdk offers no Python client; its
server names the protocol ``foxglove.websocket.v1`` in older releases and ``foxglove.sdk.v1``
in newer ones (same messages); clients asking for either name alone are served. The scene (SYNTHETIC): the skin's
virtual device plays a line traced left to right.
"""

from __future__ import annotations

import json
import struct
import subprocess
import sys
import time

import pytest
from websockets.sync.client import connect

from touch_gestures.patch.model_io import load_model
from touch_graph import messages
from touch_graph.bag.definitions import check_definition
from touch_graph.paths import share_file
from touch_graph.runtime import Context, Parameter
from touch_view.errors import ViewError
from touch_view.foxglove_cli import layout_path
from touch_view.foxglove_layout import POSTERIOR_CLASSES
from touch_view.foxglove_node import IMAGE_TOPICS, FoxgloveServerNode

SUBPROTOCOLS = ['foxglove.websocket.v1', 'foxglove.sdk.v1']


class FoxgloveClient:
    """A minimal Foxglove WebSocket client: advertised channels, subscriptions, received messages."""

    def __init__(self, ws) -> None:
        self.ws = ws
        self.channels: dict[int, dict] = {}
        self.by_topic: dict[str, dict] = {}
        self.subscriptions: dict[int, int] = {}   # subscription id -> channel id
        self.received: dict[str, list[tuple[int, bytes]]] = {}
        self.server_info: dict | None = None

    def subscribe(self, topics: set[str]) -> None:
        new = [c for t, c in self.by_topic.items() if t in topics and c['id'] not in self.subscriptions.values()]
        if new:
            subs = [{'id': len(self.subscriptions) + k, 'channelId': c['id']} for k, c in enumerate(new)]
            self.subscriptions.update({s['id']: s['channelId'] for s in subs})
            self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': subs}))

    def run(self, topics: set[str], until, timeout_s: float = 30.0) -> None:
        end = time.monotonic() + timeout_s
        while time.monotonic() < end and not until(self):
            try:
                data = self.ws.recv(timeout=1.0)
            except TimeoutError:
                continue
            if isinstance(data, str):
                message = json.loads(data)
                if message['op'] == 'serverInfo':
                    self.server_info = message
                elif message['op'] == 'advertise':
                    for channel in message['channels']:
                        self.channels[channel['id']] = channel
                        self.by_topic[channel['topic']] = channel
                    self.subscribe(topics)
            elif data[0] == 1:   # message data
                sub_id, log_time = struct.unpack_from('<IQ', data, 1)
                topic = self.channels[self.subscriptions[sub_id]]['topic']
                self.received.setdefault(topic, []).append((log_time, bytes(data[13:])))


@pytest.fixture
def scene(scene_launch, run_scene):
    return run_scene(scene_launch(
        skin=['line: {from_mm: [6, 23], to_mm: [41, 23], at_s: 2.0, for_s: 0.8, force_n: 1.5}'],
        serve=['foxglove_server']))


def test_a_client_receives_cdr_messages_with_their_ros2msg_schemas_and_the_map_as_an_image(scene):
    node = scene.node('foxglove_server')
    topics = {'/skin/frame', '/touch/haptic_command', '/skin/pressure_image', '/diagnostics'}
    with connect(f'ws://127.0.0.1:{node.port}', subprotocols=SUBPROTOCOLS, open_timeout=10) as ws:
        client = FoxgloveClient(ws)
        client.run(topics, lambda c: '/touch/haptic_command' in c.received and '/skin/pressure_image' in c.received
                   and '/diagnostics' in c.received)
    assert client.server_info is not None
    # Every topic of the scene is advertised, with its type's definition as rosbag2 stores it in MCAP.
    for name, types in node.get_topic_names_and_types():
        if node.count_publishers(name):
            channel = client.by_topic[name]
            assert channel['encoding'] == 'cdr' and channel['schemaEncoding'] == 'ros2msg'
            assert channel['schemaName'] == types[0]
            assert check_definition(name, types[0], channel['schema']).status == 'match', name
    frames = [messages.deserialize(payload, 'social_touch_msgs/msg/SkinFrame')
              for _, payload in client.received['/skin/frame']]
    assert frames and all(f.pressure.shape == (144,) for f in frames)
    assert any(f.contact for f in frames) or len(frames) > 10
    command = messages.deserialize(client.received['/touch/haptic_command'][-1][1],
                                   'social_touch_msgs/msg/HapticCommand')
    assert (command.gesture, command.command) == ('line_right', 'move_right')
    log_time, _ = client.received['/touch/haptic_command'][-1]
    assert abs(log_time - (command.header.stamp.sec * 10**9 + command.header.stamp.nanosec)) < 5 * 10**9
    image = client.by_topic['/skin/pressure_image']
    assert image['schemaName'] == 'foxglove.RawImage' and image['encoding'] == 'protobuf'
    assert all(len(payload) > 96 * 96 * 3 for _, payload in client.received['/skin/pressure_image'])
    assert node.forwarded['/skin/frame'] >= len(frames)


@pytest.mark.parametrize('asked', [['foxglove.websocket.v1'], ['foxglove.sdk.v1']])
def test_clients_asking_for_either_name_of_the_protocol_are_served(scene, asked):
    node = scene.node('foxglove_server')
    renamed = node.front.renamed
    with connect(f'ws://127.0.0.1:{node.port}', subprotocols=asked, open_timeout=10) as ws:
        assert ws.subprotocol == asked[0]
        client = FoxgloveClient(ws)
        client.run({'/skin/frame'}, lambda c: len(c.received.get('/skin/frame', [])) >= 5)
    assert client.server_info is not None and client.server_info['name'] == 'social_touch'
    frames = [messages.deserialize(p, 'social_touch_msgs/msg/SkinFrame') for _, p in client.received['/skin/frame']]
    assert len(frames) >= 5 and all(f.pressure.shape == (144,) for f in frames)
    assert node.front.renamed - renamed == (asked == ['foxglove.websocket.v1'])


def test_a_client_asking_for_another_protocol_is_refused(scene):
    from websockets.exceptions import InvalidStatus
    url = f'ws://127.0.0.1:{scene.node("foxglove_server").port}'
    # Refused either way: newer foxglove-sdk answers HTTP 400, 0.25 (the lowest allowed) drops the
    # client during the handshake. Never a connection that opens, and never a server that is not there.
    with pytest.raises((InvalidStatus, ConnectionError)) as refused:
        connect(url, subprotocols=['rosbridge.v1'], open_timeout=10)
    assert not isinstance(refused.value, ConnectionRefusedError), refused.value
    assert not isinstance(refused.value, InvalidStatus) or '400' in str(refused.value), refused.value
    with connect(url, subprotocols=SUBPROTOCOLS[:1], open_timeout=10) as served:
        assert served.subprotocol in SUBPROTOCOLS


def test_a_port_in_use_is_one_clear_error_naming_the_flag(busy_port):
    ctx = Context('sim')
    ctx.init()
    try:
        with pytest.raises(ViewError, match=rf'Foxglove server cannot listen on 127.0.0.1:{busy_port}: the port is '
                                            r'already in use.*--port N'):
            FoxgloveServerNode(context=ctx, parameter_overrides=[Parameter('port', value=busy_port)])
    finally:
        ctx.shutdown()
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'foxglove', '--port', str(busy_port)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1 and 'already in use' in result.stderr and '--port N' in result.stderr


def test_the_packaged_layout_opens_the_served_topics():
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'foxglove', '--layout'],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 0 and result.stdout.strip() == layout_path()
    with open(layout_path(), encoding='utf-8') as file:
        layout = json.load(file)
    assert layout['version'] == 1

    def panels(node):
        if node.get('type') == 'panel':
            yield node
        for item in node.get('items', []):
            yield from panels(item['content'])
    found = {p['panelType']: p for p in panels(layout['content'])}
    assert set(found) == {'Image', 'Plot', 'StateTransitions', 'RawMessages', 'DiagnosticsSummary'}
    images = {p['config']['imageMode']['imageTopic'] for p in panels(layout['content']) if p['panelType'] == 'Image'}
    assert images == {topic for topic, *_ in IMAGE_TOPICS.values()}
    plotted = [s['value'] for s in found['Plot']['config']['paths']]
    assert plotted == [f'/patch/posteriors.posteriors[{k}]' for k in range(4)]
    # The plot's labels follow the class order of the shipped model (what /patch/posteriors carries).
    assert tuple(load_model(share_file('config', 'patch_gestures.npz')).classes) == POSTERIOR_CLASSES


def test_ws_front_doctests():
    import doctest

    from touch_view import ws_front
    result = doctest.testmod(ws_front)
    assert result.attempted and not result.failed
