"""The sensor chain as the robot runs it: a virtual bear, the ``bear_driver`` node and ``/bear/frame``.

:class:`GraphChain` yields the same :class:`~.chain.Cycle` objects as :class:`~.chain.DriverChain`,
but they come out of the real node graph: the stimulus is registered
(``touch_sim.scenes.register_stimulus``), a ``BearDriverNode`` reads
``bearsim://<unique>?scene=<name>&rate=..&seed=..`` in a simulated-time ``Context('sim')`` (as fast
as the work allows, deterministic), and every ``BearFrame`` on ``/bear/frame`` becomes one cycle.

Same seed, same bytes: the virtual device behind the URL is the ``BearDevice`` DriverChain builds,
and the driver node's calibrator is DriverChain's ``BearCalibrator`` with the same defaults, so levels
and fault flags are identical frame for frame. Only the time differs: a DriverChain cycle is stamped
with its scan time (``index / rate``), a GraphChain cycle with its header stamp, the graph time at
which the driver's poll timer read the frame, relative to the driver's start. The driver polls at
``poll_rate_hz`` (twice the scan rate by default), so a cycle's time is its scan time plus 0 to one
poll period: the latency the robot has too.

>>> from touch_sim.scenes import BearScript, BearTouch
>>> from touch_gestures.bear.chain import DriverChain
>>> script = BearScript([BearTouch(channels=(1,), start=6.0, duration=2.0)])
>>> graph = list(GraphChain(script, rate_hz=2.0, seed=1).cycles(9.0))
>>> driver = list(DriverChain(script, rate_hz=2.0, seed=1).cycles(9.0))
>>> len(graph) == len(driver) == 18, all(np.array_equal(g.levels, d.levels) for g, d in zip(graph, driver))
(True, True)
>>> [(g.t, d.t, bool(g.levels[1] > 0.5)) for g, d in zip(graph, driver)][11:17]
[(5.5, 5.5, False), (6.0, 6.0, False), (6.5, 6.5, True), (7.0, 7.0, True), (7.5, 7.5, True), (8.0, 8.0, False)]
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from collections.abc import Iterator
from typing import Any

import numpy as np

from touch_sim.virtual_port import forget_device

from .chain import REAL_RATE_HZ, Cycle

__all__ = ['DEVICE_URL_OPTIONS', 'DRIVER_PARAMETERS', 'GraphChain']

#: ``BearDevice`` keyword -> ``bearsim://`` URL option (the sensor model settable through a URL).
DEVICE_URL_OPTIONS = {'rate_hz': 'rate', 'noise': 'noise', 'drift_counts': 'drift', 'crosstalk': 'crosstalk',
                      'scan': 'scan', 'channel_dt_s': 'channel_dt'}
#: ``BearCalibrator`` keywords that are ``bear_driver`` parameters of the same name.
DRIVER_PARAMETERS = ('threshold', 'baseline_frames', 'drift_tau_s', 'fault_after_s', 'saturated_after_s')
_NS = 1_000_000_000
_counter = itertools.count()
#: Simulated seconds spun between hand-overs of cycles to the caller (bounds the frames held at once).
SLICE_S = 10.0


def device_url(name: str, scene: str, rate_hz: float, seed: int, device_options: dict | None = None) -> str:
    """The ``bearsim://`` URL of a virtual bear with DriverChain's ``device_options``.

    >>> device_url('g1', 'people', 3.4, 2, {'scan': 'sequential', 'faults': {'head2': 'dead'}})
    'bearsim://g1?scene=people&rate=3.4&seed=2&scan=sequential&dead=head2'
    """
    options = dict(device_options or {})
    query = [('scene', scene), ('rate', repr(float(rate_hz))), ('seed', str(int(seed)))]
    faults: dict[str, list[str]] = {}
    for channel, kind in dict(options.pop('faults', None) or {}).items():
        faults.setdefault(str(kind), []).append(str(channel))
    for keyword, value in options.items():
        if keyword not in DEVICE_URL_OPTIONS or keyword == 'rate_hz':
            raise ValueError(f'device option {keyword!r} cannot be set through a bearsim URL; settable: '
                             f'{", ".join(k for k in DEVICE_URL_OPTIONS if k != "rate_hz")} and faults '
                             "(use chain='driver' for the others)")
        query.append((DEVICE_URL_OPTIONS[keyword], str(value)))
    query += [(kind, ','.join(names)) for kind, names in faults.items()]
    return f'bearsim://{name}?' + '&'.join(f'{k}={v}' for k, v in query)


class GraphChain:
    """Virtual device -> ``bear_driver`` node -> ``/bear/frame``, in simulated time.

    Args:
        stimulus: a ``BearStimulus`` (``proximity(t) -> (64,) float32``), e.g. a :class:`~.scene.BearScene`.
        rate_hz: the device's scan rate and the driver's expected rate (3.4 Hz real, 25 Hz ideal).
        seed: the device's noise seed (the URL's ``seed``).
        device_options: ``BearDevice`` keywords as for DriverChain; only those a URL can carry
            (:data:`DEVICE_URL_OPTIONS` and ``faults``), else ValueError.
        calibrator_options: ``BearCalibrator`` keywords; only the driver parameters in :data:`DRIVER_PARAMETERS`.
        poll_rate_hz: the driver's poll rate (default: the driver's own, twice the scan rate).

    Attributes:
        counters: after :meth:`cycles` has run: the driver's frames, dropped bytes, checksum errors,
            sequence gaps and reconnects, and the graph's callback errors.
    """

    def __init__(self, stimulus, rate_hz: float = REAL_RATE_HZ, seed: int = 0, device_options: dict | None = None,
                 calibrator_options: dict | None = None, poll_rate_hz: float | None = None) -> None:
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise ValueError(f'rate_hz must be a positive number of scans per second; got {rate_hz}')
        if poll_rate_hz is not None and not (poll_rate_hz > 0 and math.isfinite(poll_rate_hz)):
            raise ValueError(f'poll_rate_hz must be a positive number; got {poll_rate_hz}')
        unknown = sorted(set(calibrator_options or {}) - set(DRIVER_PARAMETERS))
        if unknown:
            raise ValueError(f'calibrator options {unknown} are not bear_driver parameters; settable: '
                             f'{", ".join(DRIVER_PARAMETERS)}')
        self.stimulus = stimulus
        self.rate_hz = float(rate_hz)
        self.seed = int(seed)
        self.frame_period = 1.0 / self.rate_hz
        self.device_options = dict(device_options or {})
        device_url('check', 'check', rate_hz, seed, self.device_options)   # ValueError now, not when iterating
        self.parameters: dict[str, Any] = {'expected_rate_hz': self.rate_hz, **(calibrator_options or {})}
        if poll_rate_hz is not None:
            self.parameters['poll_rate_hz'] = float(poll_rate_hz)
        self.counters: dict[str, int] = {}

    def cycles(self, duration_s: float) -> Iterator[Cycle]:
        """Calibrated scans from t = 0 up to (excluding) ``duration_s`` of device time, as DriverChain's:
        frame ``i`` (scan time ``i / rate``) is yielded when ``i / rate < duration_s``; frames lost on the
        (virtual) wire are skipped. ``Cycle.t`` is the frame's header stamp relative to the driver's start."""
        from touch_driver.bear.node import BearDriverNode
        from touch_graph.messages import get_message
        from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
        from touch_sim.scenes import register_stimulus, unregister_stimulus

        n_frames = int(np.ceil(duration_s * self.rate_hz - 1e-9))
        name = f'graphchain-{next(_counter)}-{id(self):x}'
        register_stimulus(name, self.stimulus)
        context = Context('sim')
        context.init()
        nodes: list[Any] = []
        try:
            url = device_url(name, name, self.rate_hz, self.seed, self.device_options)
            params = [Parameter('port', value=url), *(Parameter(k, value=v) for k, v in self.parameters.items())]
            driver = BearDriverNode(context=context, namespace='bear', parameter_overrides=params,
                                    cli_args=['--ros-args', '--log-level', 'warn'])
            nodes.append(driver)
            start_ns = context.now_ns()
            inbox: deque[Any] = deque()
            listener = Node('graph_chain', context=context)
            nodes.append(listener)
            # Depth covers one slice at any rate: the executor hands every frame over before time moves on.
            listener.create_subscription(get_message('social_touch_msgs/msg/BearFrame'), '/bear/frame', inbox.append,
                                         int(SLICE_S * self.rate_hz * 2) + 16)
            executor = SingleThreadedExecutor(context=context)
            for node in nodes:
                executor.add_node(node)
            poll_s = 1.0 / driver.get_parameter('poll_rate_hz').value
            end_ns = start_ns + round((n_frames * self.frame_period + 2 * poll_s) * _NS)
            last_seq, index, now = None, -1, start_ns
            while index < n_frames - 1 and now < end_ns:
                now = min(now + round(SLICE_S * _NS), end_ns)
                executor.spin_until_time(now)
                while inbox:
                    msg = inbox.popleft()
                    # Unwrap the 16-bit sequence counter into the device's frame index.
                    index = msg.sequence if last_seq is None else index + ((msg.sequence - last_seq) & 0xFFFF)
                    last_seq = msg.sequence
                    if index >= n_frames:
                        break
                    stamp_ns = msg.header.stamp.sec * _NS + msg.header.stamp.nanosec
                    yield Cycle((stamp_ns - start_ns) / _NS, msg.level, msg.faults != 0)
            stats = driver.driver.stats
            self.counters = {'frames': int(driver.frames), 'dropped_bytes': int(stats.dropped_bytes),
                             'checksum_errors': int(stats.checksum_errors), 'sequence_gaps': int(stats.sequence_gaps),
                             'reconnects': int(driver.reconnects), 'callback_errors': int(context.callback_errors)}
        finally:
            for node in reversed(nodes):
                node.destroy_node()
            context.try_shutdown()
            unregister_stimulus(name)
            forget_device(name)




def bench_chains(duration_s: float = 120.0, rate_hz: float = REAL_RATE_HZ, repeats: int = 5, seed: int = 0) -> dict:
    """Wall time per cycle of GraphChain and DriverChain on the same synthetic scene, microseconds.

    Each repeat runs both chains over ``duration_s`` of scene (a fresh chain each time, so the graph's
    start-up is included); the figures are medians over repeats, measured in one run so their ratio is
    fair on a shared machine. ``python -m touch_gestures.bear.graph_chain`` prints them as JSON.
    """
    import time

    from touch_sim.bear.people import make_scene

    from .chain import DriverChain

    scene = make_scene(n_people=1, seed=seed, subtype_reps=1, gesture_reps=1)
    scan = 'sequential' if rate_hz <= 1 / (56 * 0.005) + 1e-9 else 'parallel'
    times: dict[str, list[float]] = {'graph': [], 'driver': []}
    n = 0
    for _ in range(repeats):
        for name, make in (('graph', GraphChain), ('driver', DriverChain)):
            chain = make(scene, rate_hz, seed=seed, device_options={'scan': scan})
            t0 = time.perf_counter()
            n = sum(1 for _ in chain.cycles(duration_s))
            times[name].append((time.perf_counter() - t0) / max(n, 1) * 1e6)
    graph, driver = float(np.median(times['graph'])), float(np.median(times['driver']))
    return {'rate_hz': rate_hz, 'cycles': n, 'repeats': repeats, 'graph_us_per_cycle': round(graph, 1),
            'driver_us_per_cycle': round(driver, 1), 'graph_over_driver': round(graph / driver, 2),
            'data': 'synthetic scene (simulated people)'}
