"""``social-touch bench stack``: the runtime alone at real sensor rates, as a share of one core.

The three drivers and all recognisers, as the launch files start them (``bear_driver`` +
``bear_gestures``, ``patch_driver`` + ``patch_gestures``, ``skin_driver`` + ``haptic_commands``),
are fed the recorded bytes of the demo's people scenes (synthetic; recorded first, so no simulator
is in the loop) through pseudo-terminals, in simulated time at each sensor's own rate
(:mod:`~touch_lab.bench.replay`). The figure is CPU seconds of the graph per second of sensor data:
the fraction of one core the runtime needs. Each sensor runs alone, then all three in one graph
(``total``); medians over repeats. Goal: ``total`` at most 3 % of one core.
"""

from __future__ import annotations

import statistics
from typing import Any

from touch_sim.harness import Harness, node_class

from .drivers import DRIVERS
from .replay import PtyPort, Recording, Replay, record_scene

__all__ = ['GOAL_PERCENT', 'bench_stack', 'run_stack']

GOAL_PERCENT = 3.0
#: sensor -> its recogniser node (as the launch files name it).
RECOGNISERS = {'bear': 'bear_gestures', 'patch': 'patch_gestures', 'skin': 'haptic_commands'}
#: sensor -> (the topic of what its recogniser perceives, its type).
OUTPUTS = {'bear': ('/touch/symbolic', 'SymbolicGesture'), 'patch': ('/touch/gesture', 'GestureEvent'),
           'skin': ('/touch/haptic_command', 'HapticCommand')}


def run_stack(recordings: list[Recording]) -> dict[str, Any]:
    """One run: the sensors' drivers and recognisers in one graph on ``recordings``; CPU s and outputs."""
    ports = [PtyPort() for _ in recordings]
    try:
        with Harness() as harness:
            drivers, outputs = {}, {}
            for port, rec in zip(ports, recordings, strict=True):
                harness.add_node(node_class(RECOGNISERS[rec.sensor]), namespace=rec.sensor)
                drivers[rec.sensor] = harness.add_node(node_class(f'{rec.sensor}_driver'), namespace=rec.sensor,
                                                       parameters={'port': port.path})
                outputs[rec.sensor] = harness.collect(*OUTPUTS[rec.sensor])
            cpu = Replay(harness, list(zip(ports, recordings, strict=True))).run()
            for rec in recordings:
                if drivers[rec.sensor].frames != len(rec.chunks):
                    raise RuntimeError(f'the {rec.sensor} driver read {drivers[rec.sensor].frames} of '
                                       f'{len(rec.chunks)} recorded frames; the benchmark input is broken')
            return {'cpu_s': cpu, 'outputs': {s: len(v) for s, v in outputs.items()},
                    'callback_errors': int(harness.context.callback_errors)}
    finally:
        for port in ports:
            port.close()


def bench_stack(repeats: int = 5, duration_s: float = 60.0) -> dict:
    """CPU share of one core per sensor and for all three together (module doc)."""
    if repeats < 1 or not duration_s > 0:
        raise ValueError(f'repeats >= 1 and duration_s > 0 are required; got {repeats}, {duration_s}')
    recordings = {sensor: record_scene(sensor, duration_s) for sensor in DRIVERS}
    out: dict[str, Any] = {'data_s': duration_s, 'synthetic_data': True, 'repeats': repeats, 'per_sensor': {}}
    for label, recs in [*((s, [r]) for s, r in recordings.items()), ('total', list(recordings.values()))]:
        runs = [run_stack(recs) for _ in range(repeats)]
        share = statistics.median(r['cpu_s'] for r in runs) / duration_s
        entry = {'cpu_s_per_s': share, 'percent_of_core': 100.0 * share, 'outputs': runs[-1]['outputs'],
                 'callback_errors': runs[-1]['callback_errors'],
                 'rates_hz': {r.sensor: round(1.0 / r.period, 2) for r in recs},
                 'bytes_per_s': sum(r.size for r in recs) / duration_s}
        if label == 'total':
            out['total'] = entry
        else:
            out['per_sensor'][label] = entry
    out['sum_of_sensors_percent'] = sum(e['percent_of_core'] for e in out['per_sensor'].values())
    out['goal_percent'] = GOAL_PERCENT
    out['meets_goal'] = out['total']['percent_of_core'] <= GOAL_PERCENT
    out['what'] = ('drivers + recognisers on recorded bytes through pseudo-terminals, simulated time at each '
                   "sensor's rate: CPU seconds of the graph per second of sensor data")
    return out
