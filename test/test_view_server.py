"""The view's HTTP + Server-Sent Events server under bad clients: paused, slow, many, gone; a busy port."""

from __future__ import annotations

import http.client
import json
import socket
import subprocess
import sys
import threading
import time

import pytest

from touch_view.clients import ClientQueue, ClientRegistry
from touch_view.errors import ViewError
from touch_view.server import ViewServer


class Picture:
    """A snapshot source that counts its calls and carries a big payload (so a paused socket fills)."""

    def __init__(self, size: int = 20_000) -> None:
        self.calls = 0
        self.payload = 'x' * size

    def __call__(self) -> dict:
        self.calls += 1
        return {'n': self.calls, 'payload': self.payload}


@pytest.fixture
def server():
    view = ViewServer(Picture(), {'hello': 1}, port=0, rate_hz=50.0, max_clients=12, write_timeout_s=2.0,
                      keepalive_s=0.5).start()
    try:
        yield view
    finally:
        view.stop()


def get(view, path):
    conn = http.client.HTTPConnection('127.0.0.1', view.port, timeout=10)
    conn.request('GET', path)
    response = conn.getresponse()
    return response.status, response.getheader('Content-Type'), response.read()


def read_events(view, n, timeout_s=10.0):
    """The first ``n`` state events a well-behaved page receives."""
    sock = socket.create_connection(('127.0.0.1', view.port), timeout=timeout_s)
    sock.sendall(b'GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n')
    buffer, states = b'', []
    end = time.monotonic() + timeout_s
    while len(states) < n and time.monotonic() < end:
        buffer += sock.recv(65536)
        while b'\n\n' in buffer:
            block, buffer = buffer.split(b'\n\n', 1)
            if b'event: state' in block:
                states.append(json.loads(block.split(b'data: ', 1)[1]))
    sock.close()
    return states


def wait_for(predicate, timeout_s=10.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(0.02)
    return predicate()


def test_routes_serve_the_page_its_assets_config_and_state(server):
    status, kind, body = get(server, '/')
    assert status == 200 and kind.startswith('text/html') and b'/static/view.js' in body
    assert b'http://' not in body and b'https://' not in body  # no CDN: everything comes from this server
    for name, kind_prefix in (('view.js', 'text/javascript'), ('view.css', 'text/css')):
        status, kind, body = get(server, f'/static/{name}')
        assert status == 200 and kind.startswith(kind_prefix) and b'https://' not in body
    assert get(server, '/config.json')[2] == b'{"hello":1}'
    state = json.loads(get(server, '/state.json')[2])
    assert state['n'] >= 1 and state['server']['connected'] == 0
    assert get(server, '/static/../server.py')[0] == 404
    assert get(server, '/nothing')[0] == 404


def test_no_snapshot_is_built_while_no_page_is_connected(server):
    time.sleep(0.3)
    assert server.frames_built == 0
    states = read_events(server, 3)
    assert [s['n'] for s in states] == sorted(s['n'] for s in states) and len(states) == 3
    assert server.frames_built >= 3


def test_a_paused_page_loses_frames_alone_and_is_dropped_the_others_go_on(server):
    paused = socket.create_connection(('127.0.0.1', server.port))
    paused.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    paused.sendall(b'GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n')   # then never reads
    assert wait_for(lambda: len(server.clients) == 1)
    client = server.clients.snapshot()[0]
    # 50 frames a second of 20 kB fill the socket: the paused page's queue drops, the broadcaster never waits.
    assert wait_for(lambda: client.dropped > 10)
    healthy = read_events(server, 20)
    assert len(healthy) == 20
    paused_stats = next(c for c in healthy[-1]['server']['clients'] if c['id'] == client.id)
    assert paused_stats['dropped'] > 0    # every page sees who drops what
    assert all(c['dropped'] == 0 for c in healthy[-1]['server']['clients'] if c['id'] != client.id)
    built_before = server.frames_built
    time.sleep(0.5)
    assert server.frames_built - built_before >= 15  # the display rate held (50 Hz) while a page was paused
    # After write_timeout_s (2 s) with no progress the paused page is disconnected and counted.
    assert wait_for(lambda: server.clients.timed_out == 1, timeout_s=15)
    assert len(server.clients) == 0 and server.clients.stats()['dropped_total'] >= client.dropped
    paused.close()


def test_ten_pages_at_once_and_pages_that_leave(server):
    results = [None] * 10

    def page(i):
        results[i] = read_events(server, 5)
    threads = [threading.Thread(target=page, args=(i,)) for i in range(10)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(30)
    assert all(r is not None and len(r) == 5 for r in results)
    assert wait_for(lambda: len(server.clients) == 0)
    assert server.clients.connected_total == 10 and server.clients.refused == 0 and server.broadcast_errors == 0


def test_more_pages_than_max_clients_are_refused_clearly(server):
    socks = []
    for _ in range(12):
        s = socket.create_connection(('127.0.0.1', server.port))
        s.sendall(b'GET /events HTTP/1.1\r\nHost: 127.0.0.1\r\n\r\n')
        socks.append(s)
    assert wait_for(lambda: len(server.clients) == 12)
    status, _, body = get(server, '/events')
    assert status == 503 and b'12 pages are connected' in body and server.clients.refused == 1
    for s in socks:
        s.close()
    assert wait_for(lambda: len(server.clients) == 0, timeout_s=15)


def test_a_failing_snapshot_is_counted_and_reported_and_serving_goes_on():
    errors = []
    calls = {'n': 0}

    def flaky():
        calls['n'] += 1
        if calls['n'] % 2:
            raise ValueError('bad frame')
        return {'n': calls['n']}
    view = ViewServer(flaky, {}, port=0, rate_hz=50.0, on_error=errors.append).start()
    try:
        states = read_events(view, 3)
        assert len(states) == 3 and all(s['n'] % 2 == 0 for s in states)
        assert view.broadcast_errors >= 2 and 'ValueError: bad frame' in errors[0]
    finally:
        view.stop()


def test_a_port_in_use_is_one_clear_error_naming_the_flag(busy_port):
    with pytest.raises(ViewError, match=rf'127.0.0.1:{busy_port}: the port is already in use.*--port N'):
        ViewServer(Picture(), {}, port=busy_port)
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'view', '--port', str(busy_port)],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert 'already in use' in result.stderr and '--port N' in result.stderr


def test_client_queue_keeps_the_newest_frames_and_counts_the_dropped():
    queue = ClientQueue('peer', capacity=2)
    for frame in (b'1', b'2', b'3'):
        queue.offer(frame)
    assert queue.dropped == 1 and queue.take(0.1) == b'2' and queue.take(0.1) == b'3'
    assert queue.take(0.01) is None
    queue.close()
    assert queue.take(1.0) is None
    registry = ClientRegistry(max_clients=1)
    first = registry.add('a')
    assert registry.add('b') is None and registry.refused == 1
    registry.remove(first)
    registry.remove(first)  # twice is harmless
    assert len(registry) == 0
    with pytest.raises(ValueError):
        ClientQueue('p', capacity=0)
    with pytest.raises(ValueError):
        ViewServer(Picture(), {}, port=0, rate_hz=0)
