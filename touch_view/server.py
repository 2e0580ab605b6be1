"""The touch view's HTTP server: the page, its assets, and a Server-Sent Events stream of snapshots.

Standard library only (``http.server``). Routes (GET only; others 405):

- ``/``, ``/static/<file>``: the page and its assets, shipped in the package;
- ``/config.json``: what does not change while the view runs (body map and layout, panel names,
  the display rate);
- ``/state.json``: one snapshot;
- ``/events``: the live stream, ``event: state`` frames of snapshot JSON at up to ``rate_hz``.

A request from a page of another site or to another Host is refused with 403 (:mod:`touch_view.origins`).

Threads: ``serve_forever``, one per connected page, and a broadcaster that builds one snapshot per
display tick while a page is connected and offers it to every page's bounded queue
(:mod:`touch_view.clients`). Nothing here runs in, or waits for, the graph's executor.
"""

from __future__ import annotations

import contextlib
import json
import threading
import time
from collections.abc import Callable, Iterable
from http import HTTPStatus
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from importlib import resources
from typing import Any

from .clients import ClientQueue, ClientRegistry
from .errors import ViewError, bind_error
from .origins import OriginPolicy

__all__ = ['ViewServer']

_CONTENT_TYPES = {'.html': 'text/html; charset=utf-8', '.js': 'text/javascript; charset=utf-8',
                  '.css': 'text/css; charset=utf-8', '.svg': 'image/svg+xml', '.png': 'image/png',
                  '.json': 'application/json'}


def _static_files() -> dict[str, tuple[bytes, str]]:
    """name -> (bytes, content type) of the package's ``static/`` directory, read once."""
    out = {}
    for entry in resources.files('touch_view').joinpath('static').iterdir():
        suffix = entry.name[entry.name.rfind('.'):]
        if entry.is_file() and suffix in _CONTENT_TYPES:
            out[entry.name] = (entry.read_bytes(), _CONTENT_TYPES[suffix])
    if 'index.html' not in out:
        raise ViewError('the touch view\'s page (touch_view/static/index.html) is missing from the installed '
                        'package; reinstall it: pip install -e .')
    return out


class ViewServer:
    """Serves the page and streams snapshots to every connected page.

    Args:
        snapshot: returns the JSON-ready picture (called in the broadcaster thread).
        config: the static part, served as ``/config.json``.
        tick: called every display tick, pages or not (e.g. to notice silent sensors).
        host, port: where to listen (port 0: any free port; see :attr:`port`).
        rate_hz: snapshots per second at most (the display rate).
        max_clients: pages served at once; more are refused with 503.
        queue_frames: frames queued per page before its oldest are dropped.
        write_timeout_s: a page that accepts no data for this long is disconnected.
        on_error: ``on_error(text)`` for a broadcaster failure (logged by the node).
        allowed_origins: pages of other origins allowed to read the view (e.g. ``http://robot.local:8080``).

    Raises:
        ViewError: when the port cannot be listened on (it names the flag to change it).
    """

    def __init__(self, snapshot: Callable[[], dict[str, Any]], config: dict[str, Any], *,
                 tick: Callable[[], None] | None = None, host: str = '127.0.0.1', port: int = 8080,
                 rate_hz: float = 20.0, max_clients: int = 32, queue_frames: int = 4,
                 write_timeout_s: float = 10.0, keepalive_s: float = 5.0, flag: str = '--port',
                 on_error: Callable[[str], None] | None = None, allowed_origins: Iterable[str] = ()) -> None:
        if not 0 < rate_hz <= 60:
            raise ValueError(f'rate_hz must be in (0, 60] snapshots per second, got {rate_hz}')
        if not 0 <= port <= 65535:
            raise ValueError(f'port must be in 0..65535, got {port}')
        self._snapshot = snapshot
        self._tick = tick
        self.rate_hz = rate_hz
        self.clients = ClientRegistry(max_clients, queue_frames)
        self.keepalive_s = keepalive_s
        self.broadcast_errors = 0
        self.frames_built = 0
        self._on_error = on_error or (lambda text: None)
        self.origins = OriginPolicy(host, allowed_origins)
        self._stop = threading.Event()
        self._files = _static_files()
        self._config = json.dumps(config, separators=(',', ':')).encode()
        handler = type('ViewRequestHandler', (_Handler,), {'view': self, 'timeout': write_timeout_s})
        try:
            self._httpd = ThreadingHTTPServer((host, port), handler)
        except OSError as err:
            raise bind_error('the touch view', host, port, err, flag) from err
        self._httpd.daemon_threads = True
        self.host = host
        self.port = self._httpd.server_address[1]
        self._threads: list[threading.Thread] = []

    @property
    def url(self) -> str:
        host = f'[{self.host}]' if ':' in self.host else self.host
        return f'http://{host}:{self.port}/'

    def start(self) -> ViewServer:
        for target, name in ((self._httpd.serve_forever, 'serve'), (self._broadcast_loop, 'broadcast')):
            thread = threading.Thread(target=target, name=f'touch_view-{name}', daemon=True)
            thread.start()
            self._threads.append(thread)
        return self

    def stop(self) -> None:
        """Disconnect every page, stop serving and join the threads; safe to call twice."""
        if self._stop.is_set():
            return
        self._stop.set()
        self.clients.close_all()
        if self._threads:
            self._httpd.shutdown()
        self._httpd.server_close()
        for thread in self._threads:
            thread.join(timeout=5.0)

    # ------------------------------------------------------------------ frames
    def state_json(self) -> bytes:
        data = self._snapshot()
        data['server'] = {**self.clients.stats(), 'rate_hz': self.rate_hz, 'frames_built': self.frames_built,
                          'broadcast_errors': self.broadcast_errors, 'refused_requests': self.origins.refused}
        return json.dumps(data, separators=(',', ':'), allow_nan=False).encode()

    def _broadcast_loop(self) -> None:
        period = 1.0 / self.rate_hz
        deadline = time.monotonic()
        while not self._stop.wait(max(0.0, deadline - time.monotonic())):
            deadline = max(deadline + period, time.monotonic())
            try:
                if self._tick is not None:
                    self._tick()
                if len(self.clients):
                    frame = b'event: state\ndata: ' + self.state_json() + b'\n\n'
                    self.frames_built += 1
                    self.clients.broadcast(frame)
            except Exception as err:  # the view must keep serving: count, report, go on
                self.broadcast_errors += 1
                self._on_error(f'building a snapshot failed ({self.broadcast_errors} so far): '
                               f'{type(err).__name__}: {err}')

    def stream(self, client: ClientQueue, write: Callable[[bytes], None]) -> bool:
        """Write ``client``'s frames until it goes or the server stops; True when it timed out."""
        write(b'retry: 1000\nevent: hello\ndata: ' + json.dumps({'client': client.id}).encode() + b'\n\n')
        while not self._stop.is_set():
            frame = client.take(self.keepalive_s)
            if frame is None:
                if client.closed:
                    break
                frame = b': keepalive\n\n'
            try:
                write(frame)
            except TimeoutError:
                return True
            if frame[:1] != b':':
                client.sent += 1
        return False


class _Handler(BaseHTTPRequestHandler):
    """One request; ``view`` and ``timeout`` are set on the per-server subclass."""

    view: ViewServer
    server_version = 'social_touch-view'

    def log_message(self, format: str, *args: Any) -> None:
        pass  # page loads are not worth a line each; the node logs what matters

    def _send(self, body: bytes, content_type: str, status: HTTPStatus = HTTPStatus.OK) -> None:
        self.send_response(status)
        self.send_header('Content-Type', content_type)
        self.send_header('Content-Length', str(len(body)))
        self.send_header('Cache-Control', 'no-store')
        self.end_headers()
        self.wfile.write(body)

    def do_GET(self) -> None:
        path = self.path.split('?', 1)[0]
        view = self.view
        with contextlib.suppress(BrokenPipeError, ConnectionResetError, TimeoutError):
            refusal = view.origins.refusal(self.headers.get_all('Host', []), self.headers.get_all('Origin', []),
                                           self.headers.get('Sec-Fetch-Site'))
            if refusal is not None:
                self._send(f'refused: {refusal}; open the view at {view.url}\n'.encode(),
                           'text/plain; charset=utf-8', HTTPStatus.FORBIDDEN)
            elif path == '/events':
                self._events()
            elif path in ('/', '/index.html'):
                self._send(*view._files['index.html'])
            elif path.startswith('/static/') and path[8:] in view._files:
                self._send(*view._files[path[8:]])
            elif path == '/config.json':
                self._send(view._config, 'application/json')
            elif path == '/state.json':
                self._send(view.state_json(), 'application/json')
            else:
                self._send(b'not found: try /\n', 'text/plain; charset=utf-8', HTTPStatus.NOT_FOUND)

    def _read_only(self) -> None:
        """Any method but GET: the view changes nothing, for any page."""
        self.close_connection = True  # a body it sent is not read
        with contextlib.suppress(BrokenPipeError, ConnectionResetError, TimeoutError):
            self.send_response(HTTPStatus.METHOD_NOT_ALLOWED)
            body = b'the touch view is read-only: GET only\n'
            self.send_header('Allow', 'GET')
            self.send_header('Content-Type', 'text/plain; charset=utf-8')
            self.send_header('Content-Length', str(len(body)))
            self.end_headers()
            self.wfile.write(body)

    do_POST = do_PUT = do_DELETE = do_PATCH = do_OPTIONS = _read_only

    def _events(self) -> None:
        registry = self.view.clients
        client = registry.add(f'{self.client_address[0]}:{self.client_address[1]}')
        if client is None:
            self._send(f'{registry.max_clients} pages are connected already, the most this view serves; close '
                       'one (or start the view with a higher max_clients)\n'.encode(),
                       'text/plain; charset=utf-8', HTTPStatus.SERVICE_UNAVAILABLE)
            return
        timed_out = False
        try:
            self.send_response(HTTPStatus.OK)
            self.send_header('Content-Type', 'text/event-stream')
            self.send_header('Cache-Control', 'no-store')
            self.end_headers()

            def write(data: bytes) -> None:
                self.wfile.write(data)
                self.wfile.flush()
            timed_out = self.view.stream(client, write)
        finally:
            registry.remove(client, timed_out=timed_out)
