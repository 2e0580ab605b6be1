"""``social-touch bench drivers``: what each driver node costs per frame, on recorded bytes.

Each sensor's recorded bytes (:func:`~touch_lab.bench.replay.record_scene`, synthetic) are replayed
through a pseudo-terminal into its driver node alone, in simulated time: CPU time of the graph per wire
frame, the median over repeats. The node's decoder and ``handle_frame`` are timed on the same bytes,
``io_us`` is the rest. The goal: at most 1 % of the frame period on one core.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from touch_driver.serial_driver import DecodedFrame
from touch_sim.harness import Harness, node_class

from .replay import PtyPort, Recording, Replay, record_scene

__all__ = ['DRIVERS', 'GOAL_RATIO', 'bench_driver', 'bench_drivers']

GOAL_RATIO = 0.01
DRIVERS = ('bear', 'patch', 'skin')


def _parts(node: Any, recording: Recording) -> tuple[float, float]:
    """CPU s of the node's own decoder over the recording, and of its ``handle_frame`` over the scans."""
    clock = time.process_time
    decoder = node.driver.decoder
    decoder.reset()
    start = clock()
    scans = [scan for chunk in recording.chunks for scan in decoder.update(chunk)]
    decode_s = clock() - start
    start = clock()
    for scan in scans:
        node.handle_frame(DecodedFrame(scan, 0.0))
    return decode_s, clock() - start


def bench_driver(recording: Recording, repeats: int = 5) -> dict:
    """One driver node on one recording: CPU per wire frame, median over ``repeats`` fresh nodes."""
    totals, decodes, handles = [], [], []
    frames = len(recording.chunks)
    for _ in range(repeats):
        port = PtyPort()
        try:
            with Harness() as harness:
                node = harness.add_node(node_class(f'{recording.sensor}_driver'), namespace=recording.sensor,
                                        parameters={'port': port.path})
                if not node.driver.is_open:
                    raise RuntimeError(f'the {recording.sensor} driver cannot open {port.path}: {node.last_error}')
                cpu = Replay(harness, [(port, recording)]).run()
                if node.frames != frames:
                    raise RuntimeError(f'the {recording.sensor} driver read {node.frames} of {frames} recorded frames; '
                                       'the benchmark input is broken')
                decode_s, handle_s = _parts(node, recording)
        finally:
            port.close()
        totals.append(cpu / frames)
        decodes.append(decode_s / frames)
        handles.append(handle_s / frames)
    us = 1e6 * statistics.median(totals)
    decode_us, handle_us = 1e6 * statistics.median(decodes), 1e6 * statistics.median(handles)
    period_us = 1e6 * recording.period
    return {
        'sensor': recording.sensor, 'synthetic_data': True, 'us_per_frame': us, 'decode_us': decode_us,
        'handle_us': handle_us, 'io_us': us - decode_us - handle_us, 'frame_period_us': period_us,
        'ratio': us / period_us, 'goal_ratio': GOAL_RATIO, 'meets_goal': us <= GOAL_RATIO * period_us,
        'frames': frames, 'bytes': recording.size, 'repeats': repeats,
    }


def bench_drivers(repeats: int = 5, duration_s: float = 60.0) -> dict:
    """``{"bear": {...}, "patch": {...}, "skin": {...}}``: each driver node per wire frame (module doc)."""
    if repeats < 1 or not duration_s > 0:
        raise ValueError(f'repeats >= 1 and duration_s > 0 are required; got {repeats}, {duration_s}')
    out: dict[str, Any] = {sensor: bench_driver(record_scene(sensor, duration_s), repeats) for sensor in DRIVERS}
    out['what'] = ('the driver node alone on recorded bytes through a pseudo-terminal, simulated time at the '
                   'sensor rate: CPU per wire frame (us_per_frame = decode_us + handle_us + io_us)')
    out['goal'] = 'the driver node <= 1 % of the frame period on one core'
    return out
