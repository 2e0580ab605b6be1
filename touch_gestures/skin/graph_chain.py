"""The skin chain as the robot runs it: virtual skin -> ``skin_driver`` node -> ``/skin/frame`` -> gestures.

:func:`graph_gestures` plays a skin stimulus (e.g. a :class:`~.scene.SkinScene`) on a virtual
skin (``skinsim://<unique>?scene=<registered name>&seed=...``) read by a ``SkinDriverNode`` in a
simulated-time graph (``Context('sim')``: as fast as the work allows, deterministic), and cuts
the ``SkinFrame`` messages of ``/skin/frame`` into gestures with a :class:`~.frames.SkinFrameStream`
(the skin node's own frame handling). Each gesture comes with its start and end in scene
time (device time: the stimulus's ``t``), so it can be matched with the scene's ground truth.
SYNTHETIC data: the frames are simulated.

A gesture's times are its frame stamps minus the graph time at which the driver opened the
port; a stamp is the graph time at which the driver's poll timer (300 Hz) read the frame, so
up to one poll period (3.3 ms) after the frame's device time.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

from .frames import SkinFrameStream
from .gesture import TouchGesture

__all__ = ['TimedGesture', 'graph_gestures']

_NS = 1_000_000_000
_counter = itertools.count()
#: Simulated seconds spun between hand-overs of gestures to the caller.
SLICE_S = 5.0


@dataclass(frozen=True, slots=True)
class TimedGesture:
    """A gesture cut from ``/skin/frame`` with its first and last contact in scene time (s)."""

    start_s: float
    end_s: float
    gesture: TouchGesture


def graph_gestures(stimulus: Any, duration_s: float | None = None, seed: int = 0,
                   stream: SkinFrameStream | None = None, url_options: dict[str, str] | None = None,
                   driver_parameters: dict[str, Any] | None = None) -> Iterator[TimedGesture]:
    """The gestures the skin graph cuts from ``stimulus`` over ``duration_s`` (default: its own).

    Args:
        stimulus: a skin stimulus (``contacts(t)``).
        duration_s: scene seconds to run (default ``stimulus.duration_s``).
        seed: the virtual skin's seed (baselines, noise, repeatability).
        stream: frames -> gestures (default: a :class:`SkinFrameStream` with the default segmenter);
            its counters tell the bad frames afterwards.
        url_options: more ``skinsim://`` options (``noise``, ``dead``, ``garbage``...), strings.
        driver_parameters: ``skin_driver`` parameters (``calibration``, ``poll_rate_hz``...).

    Raises:
        ValueError: a bad duration, or the driver cannot open the virtual skin.
    """
    from touch_driver.skin.node import SkinDriverNode
    from touch_graph.messages import get_message
    from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
    from touch_sim.skin import device
    from touch_sim.virtual_port import forget_device

    if duration_s is None:
        duration_s = float(getattr(stimulus, 'duration_s', math.nan))
    if not (duration_s >= 0 and math.isfinite(duration_s)):
        raise ValueError(f'duration_s must be a finite number of seconds >= 0 (the stimulus has none of its own?); '
                         f'got {duration_s}')
    stream = stream if stream is not None else SkinFrameStream()
    name = f'skin-graphchain-{next(_counter)}-{id(stream):x}'
    device.register_stimulus(name, stimulus)
    query = [('scene', name), ('seed', str(int(seed))), *((str(k), str(v)) for k, v in (url_options or {}).items())]
    url = f'skinsim://{name}?' + '&'.join(f'{k}={v}' for k, v in query)
    context = Context('sim')
    context.init()
    nodes: list[Any] = []
    try:
        params = [Parameter('port', value=url), *(Parameter(k, value=v) for k, v in (driver_parameters or {}).items())]
        driver = SkinDriverNode(context=context, namespace='skin', parameter_overrides=params,
                                cli_args=['--ros-args', '--log-level', 'warn'])
        nodes.append(driver)
        if not driver.driver.is_open:
            raise ValueError(f'the skin driver cannot open {url}: {driver.last_error}')
        start_ns = context.now_ns()
        inbox: list[TouchGesture] = []
        listener = Node('skin_graph_chain', context=context)
        nodes.append(listener)
        listener.create_subscription(get_message('social_touch_msgs/msg/SkinFrame'), '/skin/frame',
                                     lambda msg: inbox.extend(stream.feed(msg)), 1000)
        executor = SingleThreadedExecutor(context=context)
        for node in nodes:
            executor.add_node(node)

        def timed(g: TouchGesture) -> TimedGesture:
            start, end = stream.stamp_ns(g.start_s), stream.end_stamp_ns(g)
            return TimedGesture((start - start_ns) / _NS, (end - start_ns) / _NS, g)

        end_ns = start_ns + round(duration_s * _NS)
        now = start_ns
        while now < end_ns:
            now = min(now + round(SLICE_S * _NS), end_ns)
            executor.spin_until_time(now)
            yield from (timed(g) for g in inbox)
            inbox.clear()
        yield from (timed(g) for g in stream.flush())
    finally:
        for node in reversed(nodes):
            node.destroy_node()
        context.try_shutdown()
        device.unregister_stimulus(name)  # a long process does not keep every run's scene
        forget_device(name)
