"""Robustness cases: the web view and the Foxglove server against a page of another site.

Each case sends one real request on loopback with the headers a hostile page (or a DNS-rebound
name) makes the browser send. A refusal is ``handled`` (with the answer's status); a hostile request
that is served is ``wrong``, and so is a legitimate client (the view's own page, the Foxglove app, a
desktop client) that is refused.
"""

from __future__ import annotations

import contextlib
import http.client
import json
import socket
from collections.abc import Callable, Iterator
from typing import Any

import foxglove

from touch_view.server import ViewServer
from touch_view.ws_front import SubprotocolFront

__all__ = ['web_cases']

SECRET = 'what the robot senses'


@contextlib.contextmanager
def _view() -> Iterator[Any]:
    server = ViewServer(lambda: {'secret': SECRET}, {}, port=0).start()
    try:
        yield server
    finally:
        server.stop()


@contextlib.contextmanager
def _foxglove() -> Iterator[Any]:
    server = foxglove.start_server(name='robustness', host='127.0.0.1', port=0, context=foxglove.Context())
    front = SubprotocolFront('127.0.0.1', 0, server.port)
    try:
        yield front
    finally:
        front.close()
        server.stop()


def _http(port: int, method: str, headers: list[tuple[str, str]], path: str = '/state.json') -> tuple[int, bytes]:
    conn = http.client.HTTPConnection('127.0.0.1', port, timeout=10)
    try:
        conn.putrequest(method, path, skip_host=True)
        for name, value in headers:
            conn.putheader(name, value)
        conn.endheaders(b'{}' if method != 'GET' else None)
        answer = conn.getresponse()
        return answer.status, answer.read()
    finally:
        conn.close()


def _view_case(method: str, headers: Callable[[int], list[tuple[str, str]]], served: bool) -> Callable[[], Any]:
    def run() -> Any:
        with _view() as view:
            status, body = _http(view.port, method, headers(view.port))
        if served:
            return f'served: {status}' if status == 200 and SECRET.encode() in body else False
        if SECRET.encode() in body or status == 200:
            return False
        return f'{status}: {body.decode(errors="replace").strip()[:150]}'
    return run


def _handshake(port: int, headers: list[tuple[str, str]]) -> bytes:
    lines = ''.join(f'{name}: {value}\r\n' for name, value in headers)
    with socket.create_connection(('127.0.0.1', port), timeout=10) as sock:
        sock.sendall(f'GET / HTTP/1.1\r\n{lines}Upgrade: websocket\r\nConnection: Upgrade\r\n'
                     'Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n'
                     'Sec-WebSocket-Protocol: foxglove.sdk.v1\r\n\r\n'.encode())
        return sock.recv(4096)


def _foxglove_case(headers: Callable[[int], list[tuple[str, str]]], served: bool) -> Callable[[], Any]:
    def run() -> Any:
        with _foxglove() as front:
            answer = _handshake(front.port, headers(front.port))
        status = answer.split(b'\r\n', 1)[0].decode(errors='replace')
        if served:
            return f'served: {status}' if ' 101 ' in status else False
        if ' 101 ' in status:
            return False
        body = answer.split(b'\r\n\r\n', 1)[-1].decode(errors='replace').strip()
        return f'{status}: {body[:150]}'
    return run


def _own(port: int) -> list[tuple[str, str]]:
    return [('Host', f'127.0.0.1:{port}')]


VIEW_CASES: list[tuple[str, str, Callable[[int], list[tuple[str, str]]], bool]] = [
    ('a DNS-rebound name (Host: attacker.example)', 'GET', lambda p: [('Host', f'attacker.example:{p}')], False),
    ('a page of another site (Origin: https://attacker.example)', 'GET',
     lambda p: [*_own(p), ('Origin', 'https://attacker.example')], False),
    ('a page of another local port (Origin: http://localhost:1)', 'GET',
     lambda p: [*_own(p), ('Origin', 'http://localhost:1')], False),
    ('a sandboxed frame (Origin: null)', 'GET', lambda p: [*_own(p), ('Origin', 'null')], False),
    ('a no-cors fetch of another site (Sec-Fetch-Site: cross-site)', 'GET',
     lambda p: [*_own(p), ('Sec-Fetch-Site', 'cross-site')], False),
    ('two Host headers', 'GET', lambda p: [*_own(p), ('Host', 'attacker.example')], False),
    ('POST from another site', 'POST', lambda p: [*_own(p), ('Origin', 'https://attacker.example')], False),
    ('PUT from the own page', 'PUT', lambda p: [*_own(p), ('Origin', f'http://127.0.0.1:{p}')], False),
    ('its own page (Origin: http://127.0.0.1:PORT)', 'GET', lambda p: [*_own(p), ('Origin', f'http://127.0.0.1:{p}')],
     True),
    ('curl (no Origin)', 'GET', _own, True),
]

FOXGLOVE_CASES: list[tuple[str, Callable[[int], list[tuple[str, str]]], bool]] = [
    ('a page of another site (Origin: https://attacker.example)',
     lambda p: [*_own(p), ('Origin', 'https://attacker.example')], False),
    ('a DNS-rebound name (Host: attacker.example)', lambda p: [('Host', f'attacker.example:{p}')], False),
    ('a sandboxed frame (Origin: null)', lambda p: [*_own(p), ('Origin', 'null')], False),
    ('a page of another local port (Origin: http://127.0.0.1:9)',
     lambda p: [*_own(p), ('Origin', 'http://127.0.0.1:9')], False),
    ('two Origin headers', lambda p: [*_own(p), ('Origin', 'https://app.foxglove.dev'),
                                      ('Origin', 'https://attacker.example')], False),
    ('the Foxglove web app (Origin: https://app.foxglove.dev)',
     lambda p: [*_own(p), ('Origin', 'https://app.foxglove.dev')], True),
    ('a desktop client (no Origin)', _own, True),
]


def _no_client_capabilities() -> Any:
    """The Foxglove server offers nothing a client could change the graph with."""
    from websockets.sync.client import connect  # a test dependency only: loaded when this case runs
    with _foxglove() as front, connect(f'ws://127.0.0.1:{front.port}', subprotocols=['foxglove.sdk.v1'],
                                       open_timeout=10) as ws:
        info = json.loads(ws.recv(timeout=10))
    changing = set(info.get('capabilities', [])) & {'clientPublish', 'services', 'parameters', 'assets',
                                                     'connectionGraph', 'parametersSubscribe'}
    return False if changing else f'capabilities offered: {sorted(info.get("capabilities", [])) or "none"}'


def web_cases() -> list[tuple[str, str, Any]]:
    """``(area, case, callable)`` of this module's cases."""
    cases: list[tuple[str, str, Any]] = []
    for name, method, headers, served in VIEW_CASES:
        cases.append(('web view against a hostile page', f'{method}: {name}', _view_case(method, headers, served)))
    for name, headers, served in FOXGLOVE_CASES:
        cases.append(('Foxglove against a hostile page', f'WebSocket: {name}', _foxglove_case(headers, served)))
    cases.append(('Foxglove against a hostile page', 'what a connected client may change', _no_client_capabilities))
    return cases
