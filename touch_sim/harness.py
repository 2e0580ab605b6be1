"""The one harness that runs the runtime's nodes on virtual devices in simulated time (synthetic data).

:class:`Harness`: a ``Context('sim')`` (deterministic, as fast as the work allows), nodes with their
parameters, virtual devices playing a stimulus behind pyserial URLs, subscriptions that collect
what the nodes publish, and a teardown that leaves nothing registered::

    with Harness() as h:
        url = h.device('bear', scene, seed=3)                 # bearsim://<unique>?scene=<unique>&seed=3
        h.add_node(BearDriverNode, namespace='bear', parameters={'port': url})
        h.add_node(BearGesturesNode, namespace='bear')
        events = h.collect('/touch/symbolic', 'SymbolicGesture')
        h.spin_for(scene.duration_s)

:class:`DeviceRun` is one driver node on one virtual device: the messages it publishes for the
device's first ``n`` wire frames, a slice of simulated time at a time. A message's stamp is when
the driver's poll timer read the frame.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from importlib.metadata import entry_points
from typing import Any

from touch_graph.messages import get_message
from touch_graph.runtime import (
    Context,
    Node,
    Parameter,
    QoSProfile,
    ReliabilityPolicy,
    SingleThreadedExecutor,
)
from touch_sim import scenes
from touch_sim.skin import device as skin_device
from touch_sim.virtual_port import device_state, forget_device

__all__ = ['SCHEMES', 'DeviceRun', 'Harness', 'driver_counters', 'node_class', 'stamp_ns', 'wire_frames_before']

_NS = 1_000_000_000
#: sensor -> URL scheme of its virtual device.
SCHEMES = {'bear': 'bearsim', 'patch': 'patchsim', 'skin': 'skinsim'}
_counter = itertools.count()


def stamp_ns(msg: Any) -> int:
    """A message's header stamp in ns."""
    return int(msg.header.stamp.sec) * _NS + int(msg.header.stamp.nanosec)


def driver_counters(driver: Any) -> dict[str, int]:
    """What a driver node counted: frames read, dropped bytes, checksum errors, sequence gaps, corrupt
    frames and reconnects (its ``~/status`` plus the decoder's corrupt payloads)."""
    stats = driver.driver.stats
    return {'frames': int(driver.frames), 'dropped_bytes': int(stats.dropped_bytes),
            'checksum_errors': int(stats.checksum_errors), 'sequence_gaps': int(stats.sequence_gaps),
            'corrupt_frames': int(driver.driver.decoder.corrupt_frames), 'reconnects': int(driver.reconnects)}


class Harness:
    """Nodes, virtual devices and subscriptions in one simulated-time graph; a context manager.

    Args:
        log_level: the nodes' log level (``'warn'``: quiet unless something is wrong).

    Attributes:
        context, executor: the graph.
        nodes: the nodes added, in order (destroyed last first).
        start_ns: the graph time at which the harness started (device time 0 of its devices).
    """

    def __init__(self, *, log_level: str = 'warn') -> None:
        self.log_level = log_level
        self.context = Context('sim')
        self.context.init()
        self.executor = SingleThreadedExecutor(context=self.context)
        self.nodes: list[Any] = []
        self.start_ns = self.context.now_ns()
        self._listener: Any = None
        self._devices: list[tuple[str, str]] = []   # (sensor, name) to unregister and forget
        self.closed = False

    # ------------------------------------------------------------------ building the graph
    def device(self, sensor: str, stimulus: Any, *, seed: int = 0, options: dict[str, Any] | None = None) -> str:
        """Register ``stimulus`` and return the URL of a fresh virtual ``sensor`` playing it.

        Args:
            sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
            stimulus: what the device plays (``proximity(t)``; ``pressure(t)`` and ``panels(t)``; ``contacts(t)``).
            seed: the device's seed (its constants, noise and fault injection).
            options: more URL options (``rate``, ``noise``, ``dead``, ``garbage``, ...), as the URL
                handlers document them; ``scene`` and ``seed`` are the harness's.
        """
        if sensor not in SCHEMES:
            raise ValueError(f"sensor must be one of {', '.join(SCHEMES)}; got {sensor!r}")
        reserved = sorted({'scene', 'seed'} & set(options or {}))
        if reserved:
            raise ValueError(f'options {reserved} are set by the harness (the stimulus and seed arguments)')
        name = f'{sensor}-harness-{next(_counter)}-{id(self):x}'
        _registry(sensor).register_stimulus(name, stimulus)
        self._devices.append((sensor, name))
        query = [('scene', name), ('seed', str(int(seed))), *((str(k), str(v)) for k, v in (options or {}).items())]
        return f'{SCHEMES[sensor]}://{name}?' + '&'.join(f'{k}={v}' for k, v in query)

    def add_node(self, node_class: type, *, namespace: str = '', parameters: dict[str, Any] | None = None) -> Any:
        """Create a node of ``node_class`` in the graph with these parameter overrides and add it."""
        node = node_class(context=self.context, namespace=namespace,
                          parameter_overrides=[Parameter(k, value=v) for k, v in (parameters or {}).items()],
                          cli_args=['--ros-args', '--log-level', self.log_level])
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def subscribe(self, topic: str, msg_type: str, callback: Callable[[Any], None], depth: int = 1000) -> None:
        """Call ``callback`` with every message on ``topic`` (a listener node of the harness subscribes)."""
        if self._listener is None:
            self._listener = self.add_node(_Listener)
        # Best effort hears any publisher (a reliable subscription would not hear a sensor's best-effort frames).
        best_effort = QoSProfile(depth=depth, reliability=ReliabilityPolicy.BEST_EFFORT)
        self._listener.create_subscription(get_message(msg_type), topic, callback, best_effort)

    def collect(self, topic: str, msg_type: str, depth: int = 1000) -> list[Any]:
        """A list that fills with the messages on ``topic``."""
        out: list[Any] = []
        self.subscribe(topic, msg_type, out.append, depth)
        return out

    # ------------------------------------------------------------------ time
    @property
    def now_s(self) -> float:
        """Seconds of graph time since the harness started."""
        return (self.context.now_ns() - self.start_ns) / _NS

    def seconds(self, msg: Any) -> float:
        """A message's stamp in seconds since the harness started."""
        return (stamp_ns(msg) - self.start_ns) / _NS

    def time_ns(self, t_s: float) -> int:
        """The graph time (ns) ``t_s`` seconds after the start."""
        return self.start_ns + round(t_s * _NS)

    def spin_until(self, t_s: float) -> None:
        """Run every callback due up to ``t_s`` seconds since the start."""
        self.executor.spin_until_time(self.time_ns(t_s))

    def spin_for(self, seconds: float) -> None:
        """Run ``seconds`` more of graph time."""
        self.spin_until(self.now_s + seconds)

    # ------------------------------------------------------------------ teardown
    def close(self) -> None:
        """Destroy the nodes (last first), shut the context down, forget the devices; safe twice."""
        if self.closed:
            return
        self.closed = True
        try:
            for node in reversed(self.nodes):
                node.destroy_node()
            self.executor.shutdown()
            self.context.try_shutdown()
        finally:
            for sensor, name in self._devices:
                _registry(sensor).unregister_stimulus(name)  # a long process does not keep every run's scene
                forget_device(name)

    def __enter__(self) -> Harness:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class _Listener(Node):
    def __init__(self, **kwargs: Any) -> None:
        super().__init__('harness', **kwargs)


def _registry(sensor: str) -> Any:
    """The module holding ``register_stimulus``/``unregister_stimulus`` for ``sensor``'s URLs."""
    return skin_device if sensor == 'skin' else scenes


class DeviceRun:
    """One driver node on one virtual device in a :class:`Harness`: the messages it publishes.

    Args:
        sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
        stimulus: what the device plays.
        seed: the device's seed.
        url_options: more URL options of the device (strings).
        driver_parameters: parameters of the driver node (``poll_rate_hz``, calibration, ...).
        log_level: the driver's log level.

    Attributes:
        counters: after :meth:`messages` has run: :func:`driver_counters` of the driver, the
            device's ``wire_frames`` and the graph's ``callback_errors``.
    """

    def __init__(self, sensor: str, stimulus: Any, *, seed: int = 0, url_options: dict[str, Any] | None = None,
                 driver_parameters: dict[str, Any] | None = None, log_level: str = 'warn') -> None:
        if sensor not in SCHEMES:
            raise ValueError(f"sensor must be one of {', '.join(SCHEMES)}; got {sensor!r}")
        if 'port' in (driver_parameters or {}):
            raise ValueError("driver_parameters must not set 'port': the run opens its own virtual device")
        self.sensor = sensor
        self.stimulus = stimulus
        self.seed = int(seed)
        self.url_options = dict(url_options or {})
        self.driver_parameters = dict(driver_parameters or {})
        self.log_level = log_level
        self.counters: dict[str, int] = {}

    def messages(self, wire_frames: int | Callable[[float], int], topics: Iterable[tuple[str, str]] = (),
                 slice_s: float = 10.0) -> Iterator[tuple[str, Any, float]]:
        """``(topic, message, t_s)`` as the driver publishes them, for the device's wire frames ``0 .. n-1``;
        ``t_s`` is the message's stamp in seconds since the driver started (graph time).

        Args:
            wire_frames: ``n``, or a function of the device's frame period (s) giving it (the
                period is only known once the device is open, e.g. 10 ms raw patch scans).
            topics: ``(topic, type)`` to take, e.g. ``('/bear/frame', 'BearFrame')``. A message with a
                ``sequence`` carries the wire frame that completed it: the one of frame ``n - 1`` is the
                last handed over, one of a later frame is not.
            slice_s: simulated seconds spun between hand-overs to the caller.

        Raises:
            ValueError: the driver cannot open its virtual device (a bad option).
        """
        with Harness(log_level=self.log_level) as harness:
            url = harness.device(self.sensor, self.stimulus, seed=self.seed, options=self.url_options)
            driver = harness.add_node(node_class(f'{self.sensor}_driver'), namespace=self.sensor,
                                      parameters={'port': url, **self.driver_parameters})
            if not driver.driver.is_open:
                raise ValueError(f'the {self.sensor} driver cannot open {url}: {driver.last_error}')
            period = float(device_state(url.split('://')[1].split('?')[0]).model.frame_period)
            n = int(wire_frames(period) if callable(wire_frames) else wire_frames)
            inbox: deque[tuple[str, Any]] = deque()
            for topic, msg_type in topics:
                # Depth covers a slice at the sensor's rate twice over: nothing is dropped before the hand-over.
                harness.subscribe(topic, msg_type, lambda msg, topic=topic: inbox.append((topic, msg)),
                                  int(2 * slice_s / period) + 16)
            poll_s = 1.0 / driver.get_parameter('poll_rate_hz').value
            # Whole nanoseconds: a loop on float seconds may never reach an end that rounds down.
            end_ns, slice_ns = harness.time_ns(n * period + 2 * poll_s), round(slice_s * _NS)
            now_ns = harness.context.now_ns
            last_seq: int | None = None
            index, done = -1, n <= 0
            while not done and now_ns() < end_ns:
                harness.executor.spin_until_time(min(now_ns() + slice_ns, end_ns))
                while inbox and not done:
                    topic, msg = inbox.popleft()
                    seq = getattr(msg, 'sequence', None)
                    if seq is not None:
                        # Unwrap the 16-bit sequence counter into the device's wire-frame index.
                        index = seq if last_seq is None else index + ((seq - last_seq) & 0xFFFF)
                        last_seq = seq
                        if index >= n:
                            break
                    yield topic, msg, harness.seconds(msg)
                    done = index >= n - 1
                done = done or index >= n
            self.counters = {**driver_counters(driver), 'wire_frames': n,
                             'callback_errors': int(harness.context.callback_errors)}


def node_class(executable: str) -> type:
    """The node class installed as ``executable`` (``bear_driver``, ``haptic_commands``, ...): the
    ``social_touch.nodes`` entry points, the names launch files use."""
    found = {ep.name: ep for ep in entry_points(group='social_touch.nodes')}
    if executable not in found:
        raise ValueError(f'no node {executable!r} is installed; installed: {", ".join(sorted(found)) or "none"}')
    return found[executable].load()


def wire_frames_before(duration_s: float) -> Callable[[float], int]:
    """The wire frames whose device time ``i * period`` is before ``duration_s``.

    >>> wire_frames_before(1.0)(0.25), wire_frames_before(1.1)(0.25)
    (4, 5)
    """
    if not (duration_s >= 0 and math.isfinite(duration_s)):
        raise ValueError(f'duration_s must be a finite number of seconds >= 0; got {duration_s}')
    return lambda period: math.ceil(duration_s / period - 1e-9)
