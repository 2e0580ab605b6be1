"""How many of the skin's frames ``social-touch view`` and ``social-touch foxglove`` get from another process.

Three processes: the skin scene (``launch/skin.launch.yaml``, SYNTHETIC data; ``/skin/frame`` best
effort, wall clock), ``social-touch view`` and ``social-touch foxglove``, in two orders:
``view-first`` (the view and Foxglove serve before the scene starts) and ``scene-first`` (the scene
runs ``warmup_s`` before they start). Each runs on the backend ``touch_graph.compat`` picks, or on
``scene_backend`` / ``view_backend`` ('ours' or 'rclpy'). After ``warmup_s``, ``repeats`` windows
of ``window_s``: the driver's rate (from the frames' sequence numbers), the frames per second a
Foxglove client and the view's node (``sensors.skin.frames`` of ``/state.json``) received.
Medians per order, side by side in one run::

    social-touch bench view-live --json
"""

from __future__ import annotations

import json
import os
import re
import socket
import statistics
import struct
import subprocess
import sys
import time
import urllib.request
from typing import Any

from websockets.sync.client import connect

from touch_graph import messages
from touch_graph.paths import share_file

__all__ = ['bench_live']


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def _cli(*argv: str, env: dict[str, str]) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, '-m', 'touch_lab.cli.main', *argv], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def _view_frames(port: int) -> int:
    with urllib.request.urlopen(f'http://127.0.0.1:{port}/state.json', timeout=5) as answer:
        return int(json.load(answer)['sensors']['skin']['frames'])


#: How many times a refused subscribe is sent again (see :class:`_FoxgloveCounter`).
MAX_RESUBSCRIBES = 100
_UNKNOWN_CHANNEL = re.compile(r'Unknown channel ID: (\d+)')


class _FoxgloveCounter:
    """A Foxglove client subscribed to /skin/frame: frames received and the last sequence number seen.

    foxglove-sdk's server (0.30.3) advertises a new channel to connected clients a moment before it
    accepts subscriptions to it: a subscribe sent as soon as the advertisement arrives (as this client does)
    is sometimes answered, on a loaded machine, with the status ``Unknown channel ID: N`` and nothing more.
    The counter then sends its subscribe again, on each such answer, up to ``MAX_RESUBSCRIBES`` times.
    """

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        self.received = 0
        self.published = 0     # frames the driver sent since the first one received (sequence, unwrapped)
        self.refused = 0       # subscribes the server answered with 'Unknown channel ID'
        self.statuses: list[str] = []  # the server's status messages, for the error message
        self._last_seq: int | None = None
        self._channel: int | None = None  # the /skin/frame channel subscribed to

    @property
    def _subscribed(self) -> bool:
        return self._channel is not None

    def _subscribe(self) -> None:
        self.ws.send(json.dumps({'op': 'subscribe', 'subscriptions': [{'id': 1, 'channelId': self._channel}]}))

    def _on_text(self, message: dict) -> None:
        if message['op'] == 'advertise' and self._channel is None:
            for channel in message['channels']:
                if channel['topic'] == '/skin/frame':
                    self._channel = channel['id']
                    self._subscribe()
        elif message['op'] == 'status':
            self.statuses.append(str(message.get('message')))
            refused = _UNKNOWN_CHANNEL.search(self.statuses[-1])
            if refused and int(refused.group(1)) == self._channel and self.received == 0 \
                    and self.refused < MAX_RESUBSCRIBES:
                self.refused += 1
                self._subscribe()

    def pump(self, until: float) -> None:
        while time.monotonic() < until:
            try:
                data = self.ws.recv(timeout=max(0.0, until - time.monotonic()))
            except TimeoutError:
                return
            if isinstance(data, str):
                self._on_text(json.loads(data))
            elif data[0] == 1 and struct.unpack_from('<I', data, 1)[0] == 1:
                seq = messages.deserialize(bytes(data[13:]), 'social_touch_msgs/msg/SkinFrame').sequence
                if self._last_seq is not None:
                    self.published += (seq - self._last_seq) % 65536
                self._last_seq = seq
                self.received += 1


def _measure(fox: _FoxgloveCounter, view_port: int, warmup_s: float, windows: int,
             window_s: float) -> dict[str, list[float]]:
    fox.pump(time.monotonic() + warmup_s)
    deadline = time.monotonic() + 30.0
    while (fox.received == 0 or _view_frames(view_port) == 0) and time.monotonic() < deadline:
        fox.pump(time.monotonic() + 0.5)  # a loaded machine starts the processes slowly
    if fox.received == 0 or _view_frames(view_port) == 0:
        raise RuntimeError(f'no skin frame reached the Foxglove client ({fox.received}, channel '
                           f"{'subscribed' if fox._subscribed else 'never advertised'}, {fox.refused} subscribes "
                           f'refused, server said {fox.statuses[-3:]}) or the view ({_view_frames(view_port)}) '
                           f'in {warmup_s + 30:g} s')
    rates: dict[str, list[float]] = {'driver_published': [], 'foxglove_received': [], 'view_received': []}
    for _ in range(windows):
        start, view0, fox0, pub0 = time.monotonic(), _view_frames(view_port), fox.received, fox.published
        fox.pump(start + window_s)
        elapsed = time.monotonic() - start
        rates['view_received'].append((_view_frames(view_port) - view0) / elapsed)
        rates['foxglove_received'].append((fox.received - fox0) / elapsed)
        rates['driver_published'].append((fox.published - pub0) / elapsed)
    return rates


#: The orders in which the processes start (see the module's doc).
ORDERS = ('view-first', 'scene-first')
#: SOCIAL_TOUCH_SHIM for a process on each backend (None: the variable is removed).
_SHIM = {'ours': '1', 'rclpy': None}


def _backend_env(env: dict[str, str], backend: str | None) -> dict[str, str]:
    """``env`` for a process on ``backend`` ('ours', 'rclpy'; None: as ``env`` says)."""
    if backend is None:
        return env
    if backend not in _SHIM:
        raise ValueError(f"backend must be 'ours' or 'rclpy', got {backend!r}")
    out = {k: v for k, v in env.items() if k != 'SOCIAL_TOUCH_SHIM'}
    if _SHIM[backend] is not None:
        out['SOCIAL_TOUCH_SHIM'] = _SHIM[backend]
    return out


def _wait_serving(view_port: int, fox_port: int, timeout_s: float) -> None:
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            _view_frames(view_port)
            socket.create_connection(('127.0.0.1', fox_port), timeout=5).close()
            return
        except OSError:
            if time.monotonic() > deadline:
                raise
            time.sleep(0.2)


def _stop(procs: list[subprocess.Popen]) -> None:
    for proc in procs:
        proc.terminate()
    for proc in procs:
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()


def run_order(order: str, *, repeats: int, warmup_s: float, window_s: float, domain: int,
              scene_backend: str | None = None, view_backend: str | None = None) -> dict[str, list[float]]:
    """Skin frames per second in each window (driver_published, foxglove_received, view_received) with the
    processes started in ``order`` ('view-first' or 'scene-first')."""
    if order not in ORDERS:
        raise ValueError(f'order must be one of {", ".join(ORDERS)}, got {order!r}')
    env = {k: v for k, v in os.environ.items() if k not in ('SOCIAL_TOUCH_NETWORK', 'ROS_STATIC_PEERS',
                                                             'CYCLONEDDS_URI')}
    env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    view_port, fox_port = _free_port(), _free_port()
    total_s = 2 * warmup_s + repeats * window_s + 60

    def scene() -> subprocess.Popen:
        return _cli('launch', str(share_file('launch', 'skin.launch.yaml')), 'monitor:=false', '--duration',
                    str(total_s), env=_backend_env(env, scene_backend))

    def viewers() -> list[subprocess.Popen]:
        view_env = _backend_env(env, view_backend)
        return [_cli('view', '--port', str(view_port), env=view_env),
                _cli('foxglove', '--port', str(fox_port), env=view_env)]

    procs: list[subprocess.Popen] = []
    try:
        if order == 'view-first':
            procs += viewers()
            _wait_serving(view_port, fox_port, 60)
            procs.append(scene())
        else:
            procs.append(scene())
            time.sleep(warmup_s)
            procs += viewers()
            _wait_serving(view_port, fox_port, 60)
        with connect(f'ws://127.0.0.1:{fox_port}', subprotocols=['foxglove.websocket.v1'], open_timeout=20) as ws:
            return _measure(_FoxgloveCounter(ws), view_port, warmup_s, repeats, window_s)
    except RuntimeError as err:
        err.add_note(f'order {order}, scene on {scene_backend or "the environment"}, view and foxglove on '
                     f'{view_backend or "the environment"}')
        raise
    finally:
        _stop(procs)


def bench_live(repeats: int = 5, warmup_s: float = 8.0, window_s: float = 4.0, domain: int | None = None,
               orders: tuple[str, ...] = ORDERS, scene_backend: str | None = None,
               view_backend: str | None = None) -> dict:
    """Median skin frames per second over ``repeats`` windows, per order of start: published by the driver,
    received by the view and by Foxglove (in DDS domain ``domain``; default one of 90-98 from the pid)."""
    domain = domain if domain is not None else 90 + os.getpid() % 9
    out: dict[str, Any] = {
        'scene': 'launch/skin.launch.yaml (virtual skin, synthetic people), wall clock; view and foxglove in '
                 'processes of their own', 'windows': repeats, 'window_s': window_s, 'goal_hz_at_least': 140.0,
        'backends': {'scene': scene_backend or 'environment', 'view': view_backend or 'environment'}}
    for order in orders:
        rates = run_order(order, repeats=repeats, warmup_s=warmup_s, window_s=window_s, domain=domain,
                          scene_backend=scene_backend, view_backend=view_backend)
        result: dict[str, Any] = {f'{name}_hz_median': round(statistics.median(values), 1)
                                  for name, values in rates.items()}
        result['runs_hz'] = {name: [round(v, 1) for v in values] for name, values in rates.items()}
        out[order] = result
    return out
