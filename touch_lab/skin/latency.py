"""Benchmark: from the end of the gap to the command, through the skin nodes (SYNTHETIC gestures).

Goal (issue 13): the command within 50 ms after the gap ends. The node ends gestures on frames (no
timer), so the latency has two parts:

- **waiting for the frame**: from the gap's end to the first frame stamped at or after it (graph time,
  at most one frame period);
- **processing**: wall time from ``skin_driver`` publishing that frame to ``/touch/haptic_command``
  reaching a subscriber.

``social-touch bench skin-latency`` plays synthetic gestures on the virtual skin, read by the real
``skin_driver`` and ``haptic_commands`` nodes in one simulated-time graph, with a codebook of
``n_gestures`` x ``templates_per_gesture`` for ``recogniser`` (rejection off; a gesture ``fused`` rejects
is not timed); it reports median and p99 over every command.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

from touch_driver.skin.node import SkinDriverNode
from touch_gestures.skin.node import SAFETY_RANGES, HapticCommandsNode, max_distance_bound
from touch_gestures.skin.segmentation import MULTISTROKE_GAP_S
from touch_lab.skin.recognisers import MULTISTROKE_RECOGNISER, make_recogniser, save_codebook
from touch_sim.harness import Harness
from touch_sim.skin.people import traced_scene
from touch_sim.skin.synthetic import SHAPES, synthetic_traces

from .bench import synthetic_codebook

__all__ = ['GOAL_MS', 'bench_latency']

GOAL_MS = 50.0
FRAME_RATE_HZ = 150.0
_NS = 1_000_000_000


def _stamp_ns(msg: Any) -> int:
    return int(msg.header.stamp.sec) * _NS + int(msg.header.stamp.nanosec)


def _session(scene: Any, params: dict[str, Any], seed: int) -> tuple[dict[int, float], list[tuple[float, Any]],
                                                                    dict[str, int]]:
    """Play ``scene`` through skin_driver + haptic_commands (``params``) in a simulated-time graph.

    Returns: frame stamp (ns) -> wall time the driver published it, in publishing order; (wall time,
    HapticCommand) as each command reached a subscriber; the node's outcomes.
    """
    published: dict[int, float] = {}
    delivered: list[tuple[float, Any]] = []
    with Harness(log_level='error') as harness:
        node = harness.add_node(HapticCommandsNode, namespace='skin', parameters=params)
        harness.subscribe('/touch/haptic_command', 'HapticCommand',
                          lambda msg: delivered.append((time.perf_counter(), msg)), 100)
        driver = harness.add_node(SkinDriverNode, namespace='skin',
                                  parameters={'port': harness.device('skin', scene, seed=seed)})
        publish = driver.frame_pub.publish

        def timed_publish(msg: Any) -> None:
            published[_stamp_ns(msg)] = time.perf_counter()
            publish(msg)

        driver.frame_pub.publish = timed_publish
        harness.spin_for(scene.duration_s)
        return published, delivered, dict(node.outcomes)


def bench_latency(repeats: int = 1, n_gestures: int = 16, templates_per_gesture: int = 30,
                  gestures_per_class: int = 4, recogniser: str = MULTISTROKE_RECOGNISER,
                  gap_s: float = MULTISTROKE_GAP_S, seed: int = 0) -> dict:
    """Median and p99 latency from the gap's end to the command (module doc); a JSON-ready dict.

    ``repeats`` sessions of ``n_gestures x gestures_per_class`` gestures each (seeds ``seed + 1``...).
    """
    gestures, labels = synthetic_codebook(n_gestures, templates_per_gesture, seed)
    model = make_recogniser(recogniser).fit(gestures, labels)
    shapes = list(SHAPES)[:n_gestures]
    wait_ms: list[float] = []
    processing_ms: list[float] = []
    outcomes: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as tmp:
        codebook = save_codebook(Path(tmp) / 'bench.npz', model, 'synthetic benchmark codebook', 'bench', gap_s)
        commands = Path(tmp) / 'commands.yaml'   # a command for every gesture, so that each one gives a message
        commands.write_text('format_version: 1\ncommands:\n'
                            + ''.join(f'  {c}: command_{i}\n' for i, c in enumerate(model.classes_)))
        # Rejection as loose as the node allows (its safety ranges keep it from being switched off): every
        # gesture ends in a command to time (a rejected one costs the same, unpublished).
        params = {'codebook': str(codebook), 'commands': str(commands), 'candidate_period_s': 0.0,
                  'max_distance': max_distance_bound(model), 'min_margin': SAFETY_RANGES['min_margin'][0]}
        for run in range(repeats):
            samples = synthetic_traces(shapes, performers=1, repetitions=gestures_per_class, seed=seed + 1 + run,
                                       rate_hz=FRAME_RATE_HZ)
            # The tail outlasts the gap, so that the last gesture ends too.
            scene = traced_scene(samples, lead_s=1.0, pause_s=(gap_s + 0.3, gap_s + 0.6), seed=run,
                                 tail_s=gap_s + 0.5)
            published, delivered, counts = _session(scene, params, seed=run)
            for key, count in counts.items():
                outcomes[key] = outcomes.get(key, 0) + count
            # One thread runs the graph: the frame that ended a gesture is the last one published before its
            # command arrived.
            stamps = np.array(list(published), dtype=np.int64)
            walls = np.array(list(published.values()))
            for wall, cmd in delivered:
                gap_end = _stamp_ns(cmd) + round(gap_s * _NS)   # the command's stamp: the last contact frame
                i = int(np.searchsorted(walls, wall, side='right')) - 1
                wait_ms.append((int(stamps[i]) - gap_end) / 1e6)
                processing_ms.append((wall - walls[i]) * 1e3)
    if not wait_ms:
        raise RuntimeError(f'no command was published (node outcomes {outcomes}): nothing to time')
    wait, processing = np.array(wait_ms), np.array(processing_ms)
    total = wait + processing
    return {'goal_ms': GOAL_MS, 'data': 'synthetic gestures on the virtual skin (SYNTHETIC)',
            'recogniser': model.name, 'gestures': n_gestures, 'templates_per_gesture': templates_per_gesture,
            'gap_s': gap_s, 'frame_rate_hz': FRAME_RATE_HZ, 'commands': len(total), 'node_outcomes': outcomes,
            'ms_median': float(np.median(total)), 'ms_p99': float(np.percentile(total, 99)),
            'ms_max': float(total.max()),
            'wait_for_frame_ms_median': float(np.median(wait)), 'wait_for_frame_ms_max': float(wait.max()),
            'processing_ms_median': float(np.median(processing)),
            'processing_ms_p99': float(np.percentile(processing, 99)),
            'ratio_p99_to_goal': float(np.percentile(total, 99) / GOAL_MS)}
