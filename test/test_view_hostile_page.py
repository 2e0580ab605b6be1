"""The view and the Foxglove server against a page of another site in the user's browser (issue 25).

Real HTTP and WebSocket requests on loopback, carrying the Host and Origin headers a hostile page
(or a DNS-rebound name) makes a browser send; and one real headless Chromium that loads a page of a
second local origin which tries to read both servers.
"""

from __future__ import annotations

import http.client
import json
import os
import socket
import threading
from http.server import SimpleHTTPRequestHandler, ThreadingHTTPServer

import foxglove
import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect

from touch_view.origins import OriginPolicy
from touch_view.server import ViewServer
from touch_view.ws_front import SubprotocolFront

SUBPROTOCOLS = ['foxglove.sdk.v1']


@pytest.fixture
def view():
    server = ViewServer(lambda: {'secret': 'what the robot senses'}, {'hello': 1}, port=0, rate_hz=20.0).start()
    try:
        yield server
    finally:
        server.stop()


@pytest.fixture
def fox():
    context = foxglove.Context()
    server = foxglove.start_server(name='hostile-test', host='127.0.0.1', port=0, context=context)
    front = SubprotocolFront('127.0.0.1', 0, server.port)
    try:
        yield front
    finally:
        front.close()
        server.stop()


def request(port, method='GET', path='/state.json', headers=None, body=None):
    conn = http.client.HTTPConnection('127.0.0.1', port, timeout=10)
    conn.putrequest(method, path, skip_host=True)
    for name, value in (headers or {}).items():
        conn.putheader(name, value)
    if body is not None:
        conn.putheader('Content-Length', str(len(body)))
    conn.endheaders(body)
    response = conn.getresponse()
    return response.status, response.read()


@pytest.mark.parametrize('path', ['/', '/state.json', '/config.json', '/events', '/static/index.html'])
def test_a_rebound_name_is_refused_on_every_route(view, path):
    status, body = request(view.port, path=path, headers={'Host': f'attacker.example:{view.port}'})
    assert status == 403 and b'not this machine' in body
    assert b'what the robot senses' not in body


@pytest.mark.parametrize('origin', ['https://attacker.example', 'http://127.0.0.1:1', 'null', 'http://localhost'])
def test_a_page_of_another_origin_is_refused(view, origin):
    status, body = request(view.port, headers={'Host': f'127.0.0.1:{view.port}', 'Origin': origin})
    assert status == 403 and b'another site' in body
    assert view.origins.refused >= 1


@pytest.mark.parametrize('host', ['127.0.0.1', 'localhost', '[::1]', None])
def test_the_own_page_and_tools_without_headers_are_served(view, host):
    headers = {}
    if host is not None:
        headers = {'Host': f'{host}:{view.port}', 'Origin': f'http://{host}:{view.port}'}
    status, body = request(view.port, headers=headers)
    assert status == 200 and json.loads(body)['secret'] == 'what the robot senses'


def test_an_allowed_origin_is_served():
    server = ViewServer(dict, {}, port=0, allowed_origins=['http://robot.local:8080']).start()
    try:
        status, _ = request(server.port, headers={'Host': 'robot.local:8080', 'Origin': 'http://robot.local:8080'})
        assert status == 200
    finally:
        server.stop()


@pytest.mark.parametrize('method', ['POST', 'PUT', 'DELETE', 'PATCH', 'OPTIONS'])
def test_the_view_changes_nothing_on_request(view, method):
    """No state-changing route exists: every method but GET is refused, from any origin."""
    status, body = request(view.port, method, '/state.json', {'Host': f'127.0.0.1:{view.port}'}, b'{"x": 1}')
    assert status == 405 and b'read-only' in body


def test_foxglove_refuses_a_page_of_another_site(fox):
    url = f'ws://127.0.0.1:{fox.port}'
    for origin in ('https://attacker.example', 'null', 'http://127.0.0.1:9'):
        with pytest.raises(InvalidStatus, match='403'):
            connect(url, subprotocols=SUBPROTOCOLS, origin=origin, open_timeout=10)
    assert fox.policy.refused == 3


@pytest.mark.parametrize('origin', [None, 'https://app.foxglove.dev', 'file://'])
def test_foxglove_serves_its_app_and_desktop_clients(fox, origin):
    """Desktop clients and foxglove-sdk's send no Origin; the web app sends its own; Electron apps file://."""
    with connect(f'ws://127.0.0.1:{fox.port}', subprotocols=SUBPROTOCOLS, origin=origin, open_timeout=10) as ws:
        info = json.loads(ws.recv(timeout=10))
    assert info['op'] == 'serverInfo'
    # Nothing a client may change: no publishing, services, parameters or connection graph.
    assert not set(info.get('capabilities', [])) & {'clientPublish', 'services', 'parameters', 'parametersSubscribe',
                                                     'connectionGraph', 'assets'}


def test_the_policy_is_the_same_for_ipv6_and_case():
    policy = OriginPolicy('127.0.0.1')
    assert policy.refusal(['[::1]:8080'], ['http://[::1]:8080']) is None
    assert policy.refusal(['LOCALHOST:8080'], ['HTTP://LOCALHOST:8080']) is None
    assert policy.refusal(['localhost.attacker.example:8080'], []) is not None
    assert policy.refusal(['127.0.0.1:8080', 'attacker.example'], []) is not None
    assert policy.refusal(['127.0.0.1:8080'], [], 'cross-site') is not None
    assert policy.refusal(['127.0.0.1:8080'], [], 'same-origin') is None


class _Page(SimpleHTTPRequestHandler):
    html = b''

    def do_GET(self):
        self.send_response(200)
        self.send_header('Content-Type', 'text/html')
        self.send_header('Content-Length', str(len(self.html)))
        self.end_headers()
        self.wfile.write(self.html)

    def log_message(self, *args):
        pass


@pytest.mark.skipif(not os.access('/usr/bin/chromium', os.X_OK), reason='no chromium (apt-get install chromium)')
def test_a_real_browser_page_of_another_local_origin_reads_nothing(view, fox):
    """Chromium loads a page from a second local origin; it tries the view's JSON, its stream and Foxglove."""
    from selenium.webdriver.support.ui import WebDriverWait

    from touch_view.browser import headless_chromium
    html = f"""<html><body><script>
window.results = {{}};
fetch('http://127.0.0.1:{view.port}/state.json', {{mode: 'no-cors'}})
  .then(r => window.results.fetch = r.type).catch(e => window.results.fetch = 'error');
const es = new EventSource('http://127.0.0.1:{view.port}/events');
es.onmessage = es.addEventListener('state', () => window.results.events = 'read');
es.onerror = () => {{ window.results.events = window.results.events || 'error'; es.close(); }};
const ws = new WebSocket('ws://127.0.0.1:{fox.port}', ['foxglove.sdk.v1']);
ws.onmessage = () => window.results.ws = 'read';
ws.onerror = () => window.results.ws = window.results.ws || 'error';
</script></body></html>""".encode()
    page_server = ThreadingHTTPServer(('127.0.0.1', 0), type('Page', (_Page,), {'html': html}))
    threading.Thread(target=page_server.serve_forever, daemon=True).start()
    try:
        with headless_chromium(800, 600) as browser:
            browser.get(f'http://localhost:{page_server.server_address[1]}/')
            WebDriverWait(browser, 30, poll_frequency=0.2).until(
                lambda b: len(b.execute_script('return window.results')) == 3)
            results = browser.execute_script('return window.results')
    finally:
        page_server.shutdown()
        page_server.server_close()
    # An opaque answer (the script cannot read it) and nothing streamed or received.
    assert results == {'fetch': 'opaque', 'events': 'error', 'ws': 'error'}, results
    assert fox.policy.refused >= 1 and view.origins.refused >= 2


@pytest.mark.parametrize('lines, words', [
    (b'Host: 127.0.0.1\r\nOrigin: https://attacker.example\r\n', b'another site'),
    (b'Host: attacker.example\r\n', b'not this machine'),
    (b'Host: 127.0.0.1\r\nHost: attacker.example\r\n', b'more than one'),
])
def test_a_raw_hostile_handshake_gets_403_before_the_server_sees_it(fox, lines, words):
    with socket.create_connection(('127.0.0.1', fox.port), timeout=10) as sock:
        sock.sendall(b'GET / HTTP/1.1\r\n' + lines + b'Upgrade: websocket\r\nConnection: Upgrade\r\n'
                     b'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n'
                     b'Sec-WebSocket-Version: 13\r\nSec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n')
        answer = sock.recv(4096)
    assert answer.startswith(b'HTTP/1.1 403') and words in answer


def test_the_view_node_takes_its_allow_list_as_a_parameter():
    from touch_graph.runtime import Context, Parameter
    from touch_view.node import TouchViewNode
    ctx = Context('sim', network=False)
    ctx.init()
    try:
        node = TouchViewNode(context=ctx, parameter_overrides=[
            Parameter('port', value=0), Parameter('allowed_origins', value='https://dashboard.example, ')])
        try:
            host = f'127.0.0.1:{node.server.port}'
            assert node.server.origins.origin_ok('https://dashboard.example', host)
            assert not node.server.origins.origin_ok('https://evil.example', host)
        finally:
            node.destroy_node()
    finally:
        ctx.try_shutdown()
