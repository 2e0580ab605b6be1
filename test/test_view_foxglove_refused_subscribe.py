"""The bench's Foxglove client subscribes again when foxglove-sdk refuses a subscribe to a channel it has just
advertised (``Unknown channel ID: N``), instead of waiting for frames that never come.

The server's race (advertisement sent before the channel accepts subscriptions) happens only under load, so the
order of events is scripted: advertise, subscribe, refusal, subscribe again, frame. The refusal's wording is
taken from a real foxglove-sdk server, asked to subscribe to a channel it does not have.
"""

import json
import struct

import foxglove
from websockets.sync.client import connect

from touch_graph import messages
from touch_graph.compat import get_message
from touch_view.bench_live import _UNKNOWN_CHANNEL, MAX_RESUBSCRIBES, _FoxgloveCounter

SKIN_FRAME = 'social_touch_msgs/msg/SkinFrame'


def _frame_data(subscription: int, sequence: int) -> bytes:
    """A Foxglove 'message data' binary message carrying one SkinFrame."""
    msg = get_message(SKIN_FRAME)()
    msg.sequence = sequence
    return struct.pack('<BIQ', 1, subscription, 0) + bytes(messages.serialize(msg, SKIN_FRAME))


class ScriptedServer:
    """A websocket stand-in: advertises /skin/frame as channel 8 and refuses the first ``refusals`` subscribes
    with the status foxglove-sdk sends; the next subscribe gets one frame."""

    def __init__(self, refusals: int) -> None:
        self.refusals = refusals
        self.subscribes: list[dict] = []
        self.inbox: list[str | bytes] = [json.dumps({'op': 'advertise', 'channels': [
            {'id': 7, 'topic': '/skin/contact'}, {'id': 8, 'topic': '/skin/frame'}]})]

    def send(self, text: str) -> None:
        message = json.loads(text)
        assert message['op'] == 'subscribe'
        self.subscribes.append(message)
        if len(self.subscribes) <= self.refusals:
            self.inbox.append(json.dumps({'op': 'status', 'level': 2, 'message': 'Unknown channel ID: 8'}))
        else:
            self.inbox.append(_frame_data(message['subscriptions'][0]['id'], 41))

    def recv(self, timeout: float) -> str | bytes:
        if not self.inbox:
            raise TimeoutError
        return self.inbox.pop(0)


def test_a_refused_subscribe_is_sent_again_until_frames_come():
    server = ScriptedServer(refusals=3)
    counter = _FoxgloveCounter(server)
    counter.pump(until=float('inf'))  # returns when the script has nothing more to say
    assert [s['subscriptions'] for s in server.subscribes] == [[{'id': 1, 'channelId': 8}]] * 4
    assert (counter.refused, counter.received) == (3, 1)
    assert counter.statuses == ['Unknown channel ID: 8'] * 3


def test_resubscribing_stops_after_its_limit():
    server = ScriptedServer(refusals=MAX_RESUBSCRIBES + 5)
    counter = _FoxgloveCounter(server)
    counter.pump(until=float('inf'))
    assert len(server.subscribes) == 1 + MAX_RESUBSCRIBES
    assert (counter.refused, counter.received) == (MAX_RESUBSCRIBES, 0)


def test_the_refusal_matched_is_the_one_foxglove_sdk_sends():
    context = foxglove.Context()
    server = foxglove.start_server(name='refusal', host='127.0.0.1', port=0, context=context)
    try:
        with connect(f'ws://127.0.0.1:{server.port}', subprotocols=['foxglove.sdk.v1'], open_timeout=20) as ws:
            ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 1, 'channelId': 987654}]}))
            while (message := json.loads(ws.recv(timeout=20)))['op'] != 'status':
                pass
    finally:
        server.stop()
    found = _UNKNOWN_CHANNEL.search(message['message'])
    assert found is not None and int(found.group(1)) == 987654, message
