"""``social-touch bench frame-steps``: where one skin frame's CPU goes, step by step, hot and paced.

The skin driver (``skin_driver``) and its recogniser (``haptic_commands``) run in one process, in
one executor, on the wall clock, fed the bytes the virtual skin sends for the demo's people scene
(synthetic, :func:`~touch_lab.bench.replay.record_scene`), one wire frame at a time. Each frame's
path is timed per step in CPU time of the thread (``time.thread_time_ns``: on a shared machine a
preempted step would otherwise count the other processes' time):

- ``decode``: the bytes through the driver's stream decoder (framing, checksums, payload order);
- ``calibrate``: :meth:`~touch_driver.skin.calibration.SkinCalibrator.update`;
- ``build message``: the rest of ``handle_frame`` (the stamps, the ``SkinFrame`` and its parts);
- ``publish``: ``Publisher.publish`` (in-process delivery to the recogniser's queue);
- ``recognise``: the executor's turn that runs the recogniser's callback.

Two pacings: ``hot`` (frames back to back, as the simulated-time benches run them) and ``paced``
(a sleep of one frame period, 1/150 s, before each frame, as the launched graph lives: other
processes run meanwhile and the caches go cold). The gap between the two is what the wall clock
adds to the same work; the wake-ups themselves (the port's reader thread, the executor's wait) are
outside these steps and are in ``bench wall-clock``'s figure only.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from touch_driver.skin.node import SkinDriverNode
from touch_gestures.skin.node import HapticCommandsNode
from touch_graph.runtime import Context, SingleThreadedExecutor
from touch_graph.runtime.parameters import Parameter

from .replay import PtyPort, record_scene

__all__ = ['STEPS', 'bench_frame_steps', 'time_steps']

STEPS = ('decode', 'calibrate', 'build message', 'publish', 'recognise')
#: The skin's frame period, s (150 Hz).
SKIN_PERIOD_S = 1.0 / 150.0
_clock = time.thread_time_ns


class _Timed:
    """Wraps a callable; adds the ns each call took to ``totals[step]``."""

    def __init__(self, fn: Any, totals: dict[str, int], step: str) -> None:
        self.fn, self.totals, self.step = fn, totals, step

    def __call__(self, *args: Any) -> Any:
        start = _clock()
        try:
            return self.fn(*args)
        finally:
            self.totals[self.step] += _clock() - start


def time_steps(chunks: tuple[bytes, ...], pause_s: float) -> dict[str, list[int]]:
    """ns per step (:data:`STEPS`) of each frame of ``chunks`` (one wire frame each), ``pause_s`` slept before each.

    Returns ``{step: [ns of frame 0, ns of frame 1, ...]}``; frames that decode to nothing are left out.
    """
    context = Context('wall')
    context.init()
    port = PtyPort()   # a real port, never written: the bench hands the driver its bytes itself
    try:
        recogniser = HapticCommandsNode(context=context, namespace='skin')
        driver = SkinDriverNode(context=context, namespace='skin',
                                parameter_overrides=[Parameter('port', value=port.path)])
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(recogniser)
        executor.add_node(driver)
        totals = dict.fromkeys(STEPS, 0)
        driver.calibrator.update = _Timed(driver.calibrator.update, totals, 'calibrate')
        driver.frame_pub.publish = _Timed(driver.frame_pub.publish, totals, 'publish')
        out: dict[str, list[int]] = {step: [] for step in STEPS}
        clock = _clock
        for chunk in chunks:
            if pause_s:
                time.sleep(pause_s)
            totals.update(dict.fromkeys(STEPS, 0))
            start = clock()
            driver.driver.feed(chunk)
            frames = driver.driver.take_frames()
            decoded = clock()
            driver._publish_frames(frames)   # handle_frame: calibrate, build, publish
            handled = clock()
            executor.spin_once(0)            # the recogniser's callback
            recognised = clock()
            if not frames:
                continue
            out['decode'].append(decoded - start)
            out['build message'].append(handled - decoded - totals['calibrate'] - totals['publish'])
            out['calibrate'].append(totals['calibrate'])
            out['publish'].append(totals['publish'])
            out['recognise'].append(recognised - handled)
        return out
    finally:
        context.shutdown()
        port.close()


def bench_frame_steps(repeats: int = 3, seconds: float = 10.0) -> dict:
    """Median µs per step of a skin frame, hot and paced, and the sum as % of one core at 150 Hz (medians of
    ``repeats`` runs over ``seconds`` of the scene each; synthetic data)."""
    chunks = record_scene('skin', seconds).chunks
    out: dict[str, Any] = {'synthetic_data': True, 'frames_per_run': len(chunks), 'repeats': repeats}
    for pacing, pause in (('hot', 0.0), ('paced', SKIN_PERIOD_S)):
        runs = [time_steps(chunks, pause) for _ in range(repeats)]
        medians = {step: statistics.median(statistics.median(run[step]) for run in runs) / 1e3 for step in STEPS}
        total = sum(medians.values())
        out[pacing] = {**{f'{step} us': round(us, 1) for step, us in medians.items()},
                       'sum us': round(total, 1), 'sum at 150 Hz, % of one core': round(total * 150 / 1e4, 2)}
    out['paced / hot'] = round(out['paced']['sum us'] / out['hot']['sum us'], 2)
    return out
