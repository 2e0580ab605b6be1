"""``social-touch bench transport``: our DDS path against raw cyclonedds, side by side, across processes.

Per message kind, two echo processes (:mod:`touch_lab.bench.transport_echo`: a runtime node, plain
cyclonedds) answer a runtime node and a raw participant in this process:

- **latency**: half the round trip of one message in flight, timed in the threads that publish and
  take. ``ours``: decoded messages both ends; ``ours_cdr``: CDR bytes (no (de)serialisation); ``raw``:
  cyclonedds bytes; ``raw_codec``: raw plus our codec. The paths take turns in blocks of :data:`BLOCK`
  pings, rotating each round. Reported: median, p99, lowest and highest round median, and
  ``overhead_ratio`` = ours / raw (``_cdr``, ``_codec`` likewise) with its range over rounds.
- **throughput**: one-second bursts at doubling rates up to ``rate_ramp_top_hz`` on a reliable topic
  until one loses a message or cannot keep the rate; the highest lossless rate per path.
- **load**: :class:`touch_lab.bench.load.MachineLoad` meanwhile.

Runs in ``$SOCIAL_TOUCH_BENCH_DOMAIN`` (default 231), discovery on this host only.
"""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import threading
import time
from importlib.metadata import PackageNotFoundError, version
from typing import Any
from unittest.mock import patch

import numpy as np
from cyclonedds._clayer import ddspy_take, ddspy_write
from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import DataWriter
from cyclonedds.sub import DataReader
from cyclonedds.topic import Topic

from touch_graph import messages
from touch_graph.dds.cdds import WaitSet, delete_entity
from touch_graph.dds.config import read_discovery
from touch_graph.dds.domain import acquire_domain, release_domain
from touch_graph.dds.idl import idl_struct
from touch_graph.dds.qos import dds_qos
from touch_graph.runtime import Context, ExternalShutdownException, Node, SingleThreadedExecutor
from touch_lab.bench.load import MachineLoad
from touch_lab.bench.timing import gc_paused
from touch_lab.bench.transport_echo import BENCH_QOS, KINDS

__all__ = ['ECHO_MAIN', 'bench_transport']

#: What an echo process runs (``python -c ECHO_MAIN MODE KIND...``): no module of ours has a
#: ``__main__`` of its own, the CLI being the one way in for people.
ECHO_MAIN = 'import sys; from touch_lab.bench.transport_echo import main; sys.exit(main())'

#: Sensor rates the goal is 10 times of, Hz (bear 25 Hz ideal, patch 100 Hz internal, skin 150 Hz;
#: gesture events are rare, 10 Hz is far above a person's pace).
SENSOR_RATES_HZ = {'bear_frame': 25.0, 'patch_frame': 100.0, 'skin_frame': 150.0, 'gesture_event': 10.0}
DEFAULT_DOMAIN = 231
#: Steps of the rate ramp: goal/4 doubling up to 8 x the goal.
RAMP_STEPS = 6
#: Pings a path sends before the next path takes its turn.
BLOCK = 20


def sample_message(kind: str) -> Any:
    """A message of ``kind`` with synthetic content of the real size (fixed arrays full, 8 classes)."""
    cls = messages.get_message(KINDS[kind])
    rng = np.random.default_rng(0)
    if kind == 'gesture_event':
        return cls(gesture='stroke', probability=0.93, classes=['stroke', 'tickle', 'push', 'slap'] * 2,
                   posteriors=list(rng.random(8)), latency_s=0.4)
    values = {}
    for field, type_str in cls.get_fields_and_field_types().items():
        default = getattr(cls(), field)
        if isinstance(default, np.ndarray) and default.size and default.dtype.kind == 'f':
            values[field] = rng.random(default.size).astype(default.dtype)
        elif isinstance(default, np.ndarray) and default.size and default.dtype.kind in 'iu':
            values[field] = rng.integers(0, 1000 if type_str.startswith('uint16') else 2, default.size,
                                         dtype=default.dtype)
    return cls(**values)


class _Echo:
    def __init__(self, mode: str, env: dict[str, str]) -> None:
        self.proc = subprocess.Popen([sys.executable, '-c', ECHO_MAIN, mode, *KINDS],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env)
        if self.proc.stdout.readline().strip() != 'ready':
            self.close()
            raise RuntimeError(f'the {mode} echo process did not start')

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.stdin.close()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(10)
        self.proc.stdout.close()


class _OursPath:
    """The runtime: a node publishing pings and counting pongs, its executor in a thread."""

    def __init__(self, kind: str, cdr: bool) -> None:
        self.context = Context('wall', network=True)
        self.context.init()
        node = Node(f'bench_{kind}{"_cdr" if cdr else ""}', context=self.context)
        cls = messages.get_message(KINDS[kind])
        suffix = '_cdr' if cdr else ''
        self.pub = node.create_publisher(cls, f'/bench/{kind}/ping{suffix}', BENCH_QOS)
        self.got = 0
        self.arrived_at = 0.0  # time.perf_counter() when the last pong arrived, in the receiving thread
        self.arrived = threading.Event()
        node.create_subscription(cls, f'/bench/{kind}/pong{suffix}', self._on_pong, BENCH_QOS, raw=cdr)
        self.payload = messages.serialize(sample_message(kind)) if cdr else sample_message(kind)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(node)
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _on_pong(self, _msg: Any) -> None:
        self.arrived_at = time.perf_counter()  # the moment a node's callback sees the message
        self.got += 1
        self.arrived.set()

    def _spin(self) -> None:
        try:
            while self.context.ok():
                self.executor.spin_once(0.05)
        except ExternalShutdownException:
            pass

    def ready(self) -> bool:
        return self.pub.get_subscription_count() > 0

    def send(self) -> None:
        self.pub.publish(self.payload)

    def close(self) -> None:
        self.context.try_shutdown()
        self.thread.join(10)


class _RawPath:
    """Plain cyclonedds: bytes written and taken, a thread waiting on the pong reader.

    With ``codec``, our codec without the runtime: each ping is a message encoded on send,
    each pong decoded on take (the echo decodes and encodes again too).
    """

    def __init__(self, participant: Any, kind: str, codec: bool = False) -> None:
        cls = idl_struct(KINDS[kind])
        qos = dds_qos(BENCH_QOS)
        prefix = 'bench_codec' if codec else 'bench_raw'
        self.writer = DataWriter(participant, Topic(participant, f'rt/{prefix}/{kind}/ping', cls), qos)
        self.reader = DataReader(participant, Topic(participant, f'rt/{prefix}/{kind}/pong', cls), qos)
        self.mask = SampleState.Any | ViewState.Any | InstanceState.Any
        self.condition = ReadCondition(self.reader, self.mask)
        self.waitset = WaitSet(participant._ref)
        self.waitset.attach(self.condition._ref, 1)
        self.typename = KINDS[kind] if codec else None
        self.message = sample_message(kind)
        self.payload = messages.serialize(self.message)
        self.got = 0
        self.arrived_at = 0.0  # time.perf_counter() when the last pong arrived, in the receiving thread
        self.arrived = threading.Event()
        self.stopping = False
        self.thread = threading.Thread(target=self._receive, daemon=True)
        self.thread.start()

    def _receive(self) -> None:
        while not self.stopping:
            if self.waitset.wait(50_000_000):
                samples = ddspy_take(self.reader._ref, self.mask, 256)
                samples = [data for data, info in samples if info.valid_data] if isinstance(samples, list) else []
                if samples:
                    if self.typename is not None:
                        for data in samples:
                            messages.deserialize(data, self.typename)
                    self.arrived_at = time.perf_counter()  # the moment the bytes are taken (and decoded)
                    self.got += len(samples)
                    self.arrived.set()

    def ready(self) -> bool:
        return len(self.writer.get_matched_subscriptions()) > 0

    def send(self) -> None:
        ddspy_write(self.writer._ref, self.payload if self.typename is None else messages.serialize(self.message))

    def close(self) -> None:
        self.stopping = True
        self.waitset.wake()
        self.thread.join(10)


def _latencies(path: Any, count: int) -> list[float]:
    out = []
    for _ in range(count):
        path.arrived.clear()
        start = time.perf_counter()
        path.send()
        if not path.arrived.wait(2.0):
            continue  # lost on a reliable topic would be a bug; it is visible as fewer samples
        out.append((path.arrived_at - start) / 2)
    return out


def _lossless_rate(path: Any, goal_hz: float, seconds: float = 1.0, max_steps: int = RAMP_STEPS) -> float:
    """The highest rate (Hz) of the ramp goal/4, goal/2, goal, 2 goal, ... sent and echoed back without loss."""
    best = 0.0
    rate = goal_hz / 4
    for _ in range(max_steps):
        n = max(50, int(rate * seconds))
        start_got = path.got
        start = time.perf_counter()
        for i in range(n):
            due = start + i / rate
            while (wait := due - time.perf_counter()) > 0:
                time.sleep(min(wait, 0.001))
            path.send()
        achieved = n / max(time.perf_counter() - start, 1e-9)
        deadline = time.monotonic() + 3.0
        while path.got - start_got < n and time.monotonic() < deadline:
            time.sleep(0.005)
        if path.got - start_got != n or achieved < 0.9 * rate:
            break
        best = rate
        rate *= 2
        time.sleep(0.2)  # let queues drain between steps
    return best


def _wait_ready(paths: list[Any], timeout_s: float = 15.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not all(p.ready() for p in paths):
        if time.monotonic() > deadline:
            raise RuntimeError('the bench endpoints did not match within 15 s (is discovery on this host blocked?)')
        time.sleep(0.02)
    time.sleep(0.2)


def bench_transport(repeats: int = 5, pings: int = 400, kinds: list[str] | None = None,
                    ramp_steps: int = RAMP_STEPS) -> dict:
    """Per kind: latency median/p99 (us) of ours, ours_cdr and raw, overhead ratios, lossless rates (Hz).

    ``repeats`` rounds of ``pings`` pings per path; ``kinds`` (default all of
    :data:`~touch_lab.bench.transport_echo.KINDS`) and ``ramp_steps`` make a short run (tests).
    """
    domain = int(os.environ.get('SOCIAL_TOUCH_BENCH_DOMAIN', DEFAULT_DOMAIN))
    echoes = []
    results: dict[str, Any] = {}
    load = MachineLoad()
    restore_environ = patch.dict(os.environ, ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    restore_environ.start()
    env = {**os.environ}
    try:
        echoes = [_Echo('ours', env), _Echo('raw', env)]
        load.start(echo.proc.pid for echo in echoes)
        acquire_domain(domain, read_discovery())
        participant = DomainParticipant(domain)
        try:
            for kind in kinds or list(KINDS):
                results[kind] = _bench_kind(participant, kind, repeats, pings, ramp_steps)
        finally:
            delete_entity(participant)
            release_domain(domain)
        machine = load.stop()
    finally:
        for echo in echoes:
            echo.close()
        restore_environ.stop()
    return {'message': 'synthetic messages of the real sizes; latency is half the round trip to an echo process',
            'domain': domain, 'rounds': repeats,
            'pings_per_round': pings, 'block': BLOCK,
            'versions': _versions(), 'load': machine, 'kinds': results}


def _versions() -> dict[str, str]:
    out = {}
    for package in ('cyclonedds', 'numpy', 'rosbags'):
        try:
            out[package] = version(package)
        except PackageNotFoundError:  # pragma: no cover - all are dependencies
            out[package] = 'not installed'
    return out


def _interleaved_latencies(paths: dict[str, Any], rounds: int, pings: int) -> dict[str, list[list[float]]]:
    """Per path, per round, the latencies (s) of ``pings`` pings sent in turns of :data:`BLOCK`."""
    names = list(paths)
    samples: dict[str, list[list[float]]] = {name: [] for name in names}
    for r in range(rounds):
        order = names[r % len(names):] + names[:r % len(names)]
        for name in names:
            samples[name].append([])
        for _ in range(max(1, pings // BLOCK)):
            for name in order:
                samples[name][-1] += _latencies(paths[name], min(BLOCK, pings))
    return samples


def _us(seconds: float) -> float:
    return round(seconds * 1e6, 1)


def _bench_kind(participant: Any, kind: str, repeats: int, pings: int, ramp_steps: int) -> dict:
    paths = {'ours': _OursPath(kind, cdr=False), 'ours_cdr': _OursPath(kind, cdr=True),
             'raw': _RawPath(participant, kind), 'raw_codec': _RawPath(participant, kind, codec=True)}
    try:
        _wait_ready(list(paths.values()))
        for path in paths.values():
            _latencies(path, 50)  # warm up
        with gc_paused():
            samples = _interleaved_latencies(paths, repeats, pings)
        goal = 10 * SENSOR_RATES_HZ[kind]
        rates = {name: _lossless_rate(paths[name], goal, max_steps=ramp_steps) for name in ('ours', 'raw')}
    finally:
        for path in paths.values():
            path.close()
    out: dict[str, Any] = {'bytes': len(messages.serialize(sample_message(kind)))}
    medians: dict[str, list[float]] = {}
    sent = repeats * max(1, pings // BLOCK) * min(BLOCK, pings)
    for name, rounds in samples.items():
        values = [v for one in rounds for v in one]
        medians[name] = [statistics.median(one) if one else float('nan') for one in rounds]
        out[f'{name}_latency_median_us'] = _us(statistics.median(values)) if values else None
        out[f'{name}_latency_p99_us'] = _us(float(np.percentile(values, 99))) if values else None
        out[f'{name}_latency_round_medians_us'] = [_us(min(medians[name])), _us(max(medians[name]))]
        out[f'{name}_lost_pings'] = sent - len(values)
    if out['raw_latency_median_us']:
        for suffix, name in (('', 'ours'), ('_cdr', 'ours_cdr'), ('_codec', 'raw_codec')):
            out[f'overhead_ratio{suffix}'] = round(out[f'{name}_latency_median_us'] / out['raw_latency_median_us'], 2)
            per_round = [a / b for a, b in zip(medians[name], medians['raw'], strict=True)]
            out[f'overhead_ratio{suffix}_rounds'] = [round(min(per_round), 2), round(max(per_round), 2)]
    out['goal_rate_hz'] = goal
    out['rate_ramp_top_hz'] = goal / 4 * 2 ** (ramp_steps - 1)  # a rate equal to this: lossless all the way up
    out['ours_lossless_rate_hz'] = rates['ours']
    out['raw_lossless_rate_hz'] = rates['raw']
    out['meets_rate_goal'] = rates['ours'] >= goal
    return out
