"""The Foxglove front sends the server again a subscribe it refused as ``Unknown channel ID`` (foxglove-sdk 0.30's
race: a subscribe right after the advertisement), so a client that never subscribes twice (the Foxglove app) still
gets its frames.

The server here is a scripted WebSocket server (websockets) speaking the Foxglove protocol's messages: it
advertises channel 8 and refuses the first ``refusals`` subscribes with the status foxglove-sdk sends (its wording
taken from a real foxglove-sdk server asked for a channel it does not have), then sends one frame.
"""

import json
import socket
import struct
import threading
import time

from websockets.sync.client import connect
from websockets.sync.server import serve

from touch_view.ws_front import MAX_REPLAYS, FrameReader, SubprotocolFront, SubscribeReplay, masked_text_frame

ADVERTISE = {'op': 'advertise', 'channels': [{'id': 8, 'topic': '/skin/frame', 'encoding': 'cdr',
                                              'schemaName': 'social_touch_msgs/msg/SkinFrame', 'schema': ''}]}


class ScriptedServer:
    def __init__(self, refusals: int) -> None:
        self.refusals = refusals
        self.subscribes: list[dict] = []
        self._server = serve(self._handle, '127.0.0.1', 0, subprotocols=['foxglove.sdk.v1'],
                             compression=None)  # as foxglove-sdk's server: no permessage-deflate
        self.port = self._server.socket.getsockname()[1]
        threading.Thread(target=self._server.serve_forever, daemon=True).start()

    def _handle(self, ws) -> None:
        ws.send(json.dumps(ADVERTISE))
        for text in ws:
            message = json.loads(text)
            if message['op'] != 'subscribe':
                continue
            self.subscribes.append(message)
            if len(self.subscribes) <= self.refusals:
                ws.send(json.dumps({'op': 'status', 'level': 2, 'message': 'Unknown channel ID: 8'}))
            else:
                ws.send(struct.pack('<BIQ', 1, message['subscriptions'][0]['id'], 0) + b'frame')

    def close(self) -> None:
        self._server.shutdown()


def counted(count, settle_s: float = 0.5, timeout_s: float = 5.0) -> int:
    """``count()`` once it has not changed for ``settle_s`` (bounded by ``timeout_s``): a replaying thread counts
    after its send returns, so the server (and the client after it) may have the frame before it is counted."""
    deadline = time.monotonic() + timeout_s
    value, since = count(), time.monotonic()
    while time.monotonic() < deadline and time.monotonic() - since < settle_s:
        time.sleep(0.01)
        if (now := count()) != value:
            value, since = now, time.monotonic()
    return value


def client_sees(refusals: int) -> tuple[list, ScriptedServer, SubprotocolFront]:
    """What a client that subscribes once receives through the front (statuses and frames, for 3 s at most)."""
    server = ScriptedServer(refusals)
    front = SubprotocolFront('127.0.0.1', 0, server.port)
    received = []
    try:
        with connect(f'ws://127.0.0.1:{front.port}', subprotocols=['foxglove.websocket.v1']) as ws:
            assert json.loads(ws.recv(timeout=5))['op'] == 'advertise'
            ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 1, 'channelId': 8}]}))
            while True:
                try:
                    message = ws.recv(timeout=3)
                except TimeoutError:
                    break
                received.append(message if isinstance(message, bytes) else json.loads(message)['message'])
                if isinstance(message, bytes):
                    break
    finally:
        front.close()
        server.close()
    return received, server, front


def test_a_refused_subscribe_is_sent_again_and_the_client_gets_its_frame():
    received, server, front = client_sees(refusals=2)
    assert received[:2] == ['Unknown channel ID: 8'] * 2  # the client sees what the server said
    assert received[2] == struct.pack('<BIQ', 1, 1, 0) + b'frame'
    assert [s['subscriptions'] for s in server.subscribes] == [[{'id': 1, 'channelId': 8}]] * 3
    assert counted(lambda: front.replayed) == 2


def test_replays_stop_after_the_limit():
    received, server, front = client_sees(refusals=MAX_REPLAYS + 5)
    assert counted(lambda: front.replayed) == MAX_REPLAYS
    assert all(isinstance(m, str) for m in received)
    assert len(server.subscribes) == 1 + MAX_REPLAYS


def test_frames_are_read_whole_across_chunks():
    frame = masked_text_frame('{"op": "subscribe"}' * 10)
    reader = FrameReader()
    assert reader.feed(frame[:3]) == [] and reader.feed(frame[3:-1]) == []
    [(raw, fin, opcode, payload)] = reader.feed(frame[-1:])
    assert (raw, fin, opcode, payload) == (frame, True, 1, b'{"op": "subscribe"}' * 10)


def server_text_frame(message: dict) -> bytes:
    """A server's text frame (unmasked) carrying ``message`` as JSON (short: < 126 bytes)."""
    payload = json.dumps(message).encode()
    assert len(payload) < 126
    return bytes([0x81, len(payload)]) + payload


def test_an_advertise_read_with_the_handshake_answer_counts():
    """A server may send its advertise in the same read as its handshake answer (websockets 13 does, now and
    then): the front forwards it with the answer, and must still know the channel is advertised."""
    client_far, client_near = socket.socketpair()
    server_far, server_near = socket.socketpair()
    streams = SubscribeReplay(client_near, server_near)
    threading.Thread(target=streams.upstream, daemon=True).start()
    advertise = {'op': 'advertise', 'channels': [{'id': 8, 'topic': '/skin/frame'}]}
    down = threading.Thread(target=streams.downstream, kwargs={'forwarded': server_text_frame(advertise)}, daemon=True)
    down.start()
    try:
        subscribe = {'op': 'subscribe', 'subscriptions': [{'id': 1, 'channelId': 8}]}
        client_far.sendall(masked_text_frame(json.dumps(subscribe)))
        server_far.settimeout(5)
        reader = FrameReader()
        got = []
        while not got:
            got = reader.feed(server_far.recv(1 << 16))
        server_far.sendall(server_text_frame({'op': 'status', 'level': 2, 'message': 'Unknown channel ID: 8'}))
        again = []
        while not again:
            again = reader.feed(server_far.recv(1 << 16))
        assert json.loads(again[0][3]) == subscribe
        assert counted(lambda: streams.replayed) == 1
    finally:
        for sock in (client_far, client_near, server_far, server_near):
            sock.close()
        down.join(timeout=5)
