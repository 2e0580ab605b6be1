"""The sensor chain as the robot runs it: a virtual patch, the ``patch_driver`` node and ``/patch/frame``.

:class:`PatchGraphChain` gives the frames of a simulated scene as they come out of the real node
graph (SYNTHETIC data): the stimulus is registered (``touch_sim.scenes.register_stimulus``), a
``PatchDriverNode`` reads ``patchsim://<unique>?scene=<name>&seed=..`` in a simulated-time
``Context('sim')`` (as fast as the work allows, deterministic), and every ``PatchFrame`` on
``/patch/frame`` becomes one :class:`GraphFrame`, with the panel contact of the ``PanelContact``
the driver publishes just before it (same header).

Same seed, same activations: behind the URL is the ``PatchDevice(stimulus, seed=seed)`` that the
driver chain (:func:`.sensor_chain.render_scene` with ``chain='driver'``) builds, sampled at the
same wire-frame times (``index / 100 Hz``), and the node's calibrators are the driver chain's
``PatchCalibrator`` and ``PanelCalibrator`` with the same defaults, so activations and panel
contact agree frame for frame (``test/test_patch_node_chain.py``). Only time differs: a frame's
stamp is the graph time at which the driver's poll timer (200 Hz by default) read the scan that
completed it, so 0 to 5 ms after that scan: the latency the robot has too.

>>> from touch_sim.patch.people import make_people, simulate_session
>>> from touch_gestures.patch.sensor_chain import render_scene
>>> slap = simulate_session(make_people(1)[0], 'slap', n_events=1, seed=2, lead_s=(1.0, 1.0), pause_s=(4.0, 4.0))
>>> graph, driver = render_graph(slap, seed=4), render_scene(slap, seed=4, chain='driver')
>>> graph.activations.shape, bool(np.array_equal(graph.activations, driver.activations))
((113, 16, 16), True)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from touch_sim.patch.people import N_PANELS
from touch_sim.virtual_port import forget_device

from .sensor_chain import ChainOutput

__all__ = ['GraphFrame', 'PatchGraphChain', 'render_graph']

_NS = 1_000_000_000
_counter = itertools.count()
#: Simulated seconds spun between hand-overs of frames to the caller (bounds the frames held at once).
SLICE_S = 10.0


@dataclass(frozen=True, slots=True)
class GraphFrame:
    """One ``/patch/frame`` message of the graph.

    Attributes:
        t: header stamp, s since the driver started (graph time).
        scan: index of the wire frame (100 Hz scan) that completed this frame, from the
            unwrapped 16-bit sequence counter.
        activation: (16, 16) float32 activation of eq. (2), unitless in [k, 1], 0 outside the outline.
        panel_contact: (11,) bool contact per capacitive panel at that scan.
    """

    t: float
    scan: int
    activation: np.ndarray
    panel_contact: np.ndarray


class PatchGraphChain:
    """Virtual patch -> ``patch_driver`` node -> ``/patch/frame`` and ``/patch/panels``, in simulated time.

    Args:
        stimulus: a ``PatchStimulus`` (``pressure(t)``, ``panels(t)``), e.g. a :class:`~.scene.PatchScene`.
        seed: the device's seed (the URL's ``seed``): sensor constants and noise.
        url_options: more ``patchsim://`` options (``noise``, ``drift``, ``dead``, ``garbage``, ...; see
            ``touch_sim.urlhandlers.protocol_patchsim``), values as strings.
        driver_parameters: ``patch_driver`` parameters (``gain``, ``tau``, ``k``, ``poll_rate_hz``, ...).

    Attributes:
        counters: after :meth:`frames` has run: the driver's wire frames, dropped bytes, checksum errors,
            sequence gaps and reconnects, and the graph's callback errors.
    """

    def __init__(self, stimulus: Any, seed: int = 0, url_options: dict[str, str] | None = None,
                 driver_parameters: dict[str, Any] | None = None) -> None:
        if not (callable(getattr(stimulus, 'pressure', None)) and callable(getattr(stimulus, 'panels', None))):
            raise TypeError(f'stimulus must have pressure(t) and panels(t); got {type(stimulus).__name__}')
        reserved = sorted({'scene', 'seed'} & set(url_options or {}))
        if reserved:
            raise ValueError(f'url_options {reserved} are set by the chain itself (the stimulus and seed arguments)')
        if 'port' in (driver_parameters or {}):
            raise ValueError("driver_parameters must not set 'port': the chain opens its own virtual device")
        self.stimulus = stimulus
        self.seed = int(seed)
        self.url_options = {str(k): str(v) for k, v in (url_options or {}).items()}
        self.driver_parameters = dict(driver_parameters or {})
        self.counters: dict[str, int] = {}

    def url(self, name: str) -> str:
        """The ``patchsim://`` URL of device ``name`` playing stimulus ``name``."""
        query = [('scene', name), ('seed', str(self.seed)), *self.url_options.items()]
        return f'patchsim://{name}?' + '&'.join(f'{k}={v}' for k, v in query)

    def frames(self, duration_s: float) -> Iterator[GraphFrame]:
        """The 20 Hz frames completed by the scans of device time [0, ``duration_s``), as the driver
        chain renders them (frames lost on the virtual wire are missing, not padded)."""
        from touch_driver.patch.node import PatchDriverNode
        from touch_graph.messages import get_message
        from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
        from touch_sim.scenes import register_stimulus, unregister_stimulus

        if not (duration_s >= 0 and math.isfinite(duration_s)):
            raise ValueError(f'duration_s must be a finite number of seconds >= 0; got {duration_s}')
        name = f'patch-graphchain-{next(_counter)}-{id(self):x}'
        register_stimulus(name, self.stimulus)
        context = Context('sim')
        context.init()
        nodes: list[Any] = []
        try:
            params = [Parameter('port', value=self.url(name)),
                      *(Parameter(k, value=v) for k, v in self.driver_parameters.items())]
            driver = PatchDriverNode(context=context, namespace='patch', parameter_overrides=params,
                                     cli_args=['--ros-args', '--log-level', 'warn'])
            nodes.append(driver)
            if not driver.driver.is_open:
                raise ValueError(f'the patch driver cannot open {self.url(name)}: {driver.last_error}')
            start_ns = context.now_ns()
            period = _device(name).model.frame_period   # 10 ms raw scans, 50 ms with mode=averaged
            n_scans = int(duration_s / period)          # as the driver chain: wire frames 0 .. n_scans-1
            listener = Node('patch_graph_chain', context=context)
            nodes.append(listener)
            inbox: list[GraphFrame] = []
            contact = np.zeros(N_PANELS, dtype=bool)
            state = {'scan': None, 'seq': None}

            def on_panels(msg: Any) -> None:
                nonlocal contact
                contact = np.array(msg.contact, dtype=bool)

            def on_frame(msg: Any) -> None:
                # Unwrap the 16-bit sequence counter into the device's wire-frame index.
                seq = int(msg.sequence)
                scan = seq if state['scan'] is None else state['scan'] + ((seq - state['seq']) & 0xFFFF)
                state['scan'], state['seq'] = scan, seq
                stamp_ns = msg.header.stamp.sec * _NS + msg.header.stamp.nanosec
                inbox.append(GraphFrame((stamp_ns - start_ns) / _NS, scan,
                                        np.asarray(msg.activation, dtype=np.float32).reshape(16, 16), contact))

            depth = int(SLICE_S * 20 * 2) + 16  # a slice of frames at 20 Hz, twice over
            # Panels first: the driver publishes a frame's PanelContact just before the frame, and
            # subscriptions are served in the order messages arrive.
            listener.create_subscription(get_message('social_touch_msgs/msg/PanelContact'), '/patch/panels',
                                         on_panels, depth)
            listener.create_subscription(get_message('social_touch_msgs/msg/PatchFrame'), '/patch/frame', on_frame,
                                         depth)
            executor = SingleThreadedExecutor(context=context)
            for node in nodes:
                executor.add_node(node)
            poll_s = 1.0 / driver.get_parameter('poll_rate_hz').value
            end_ns = start_ns + round((n_scans * period + 2 * poll_s) * _NS)
            now, done = start_ns, False
            while not done and now < end_ns:
                now = min(now + round(SLICE_S * _NS), end_ns)
                executor.spin_until_time(now)
                for frame in inbox:
                    if frame.scan >= n_scans:
                        done = True
                        break
                    yield frame
                inbox.clear()
            status = driver.status()
            self.counters = {'frames': int(driver.frames), 'wire_frames': n_scans,
                             'dropped_bytes': int(status.dropped_bytes),
                             'checksum_errors': int(status.checksum_errors),
                             'sequence_gaps': int(status.sequence_gaps), 'reconnects': int(status.reconnects),
                             'callback_errors': int(context.callback_errors)}
        finally:
            for node in reversed(nodes):
                node.destroy_node()
            context.try_shutdown()
            unregister_stimulus(name)
            forget_device(name)


def render_graph(scene: Any, seed: int = 0, **chain_options: Any) -> ChainOutput:
    """Frames the robot's graph makes of ``scene`` over its ``duration_s`` (a :class:`ChainOutput`,
    ``chain='graph'``; ``stats`` are the chain's counters plus ``stamps_s``, the (T,) frame stamps)."""
    chain = PatchGraphChain(scene, seed=seed, **chain_options)
    frames = list(chain.frames(float(scene.duration_s)))
    stats: dict[str, Any] = {**chain.counters, 'frames': len(frames)}
    stats['stamps_s'] = np.array([f.t for f in frames], dtype=np.float64)
    if not frames:
        return ChainOutput(np.zeros((0, 16, 16), np.float32), np.zeros((0, N_PANELS), bool), 'graph', stats)
    return ChainOutput(np.stack([f.activation for f in frames]), np.stack([f.panel_contact for f in frames]),
                       'graph', stats)


def _device(name: str) -> Any:
    from touch_sim import virtual_port
    return virtual_port.device_state(name)


