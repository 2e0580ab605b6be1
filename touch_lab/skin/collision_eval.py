"""``social-touch eval skin-collisions``: collisions, presses and traced gestures told apart (SYNTHETIC).

Simulated contacts (bumps: 4-15 N over 10-40 mm; presses: a still finger, 0.5-3 N; traces: a finger
tracing 15-40 mm) go through the virtual skin, the driver's calibration and, frame by frame, the
haptic_commands node's :class:`~touch_gestures.skin.collisions.CollisionDetector`, segmenter and
screening. Each ends as ``collision``, ``gesture`` or ``nothing``. Reported: the confusion (true kind x
outcome) and the detection latency in frames, for the thresholds given (the node's defaults unless set).
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

import numpy as np

from touch_driver.skin.calibration import calibrate_frames
from touch_gestures.skin.collisions import COLLISION_FORCE_N, COLLISION_RATE_N_S, CollisionDetector
from touch_gestures.skin.screening import screen_gesture
from touch_gestures.skin.segmentation import GestureSegmenter
from touch_graph.cli.options import positive_float, positive_int, seed
from touch_sim.skin.device import render_frames
from touch_sim.skin.stimuli import LineStroke, StaticPress

__all__ = ['KINDS', 'add_arguments', 'evaluate_collisions', 'make_contact', 'run']

KINDS = ('bump', 'press', 'trace')
_RATE_HZ = 150.0


def make_contact(kind: str, rng: np.random.Generator) -> Any:
    """One simulated contact of ``kind`` (module doc), 0.5 s after the start."""
    x, y = rng.uniform(12.0, 35.0, 2)
    if kind == 'bump':
        return StaticPress(x, y, force_n=rng.uniform(4.0, 15.0), radius_mm=rng.uniform(5.0, 20.0),
                           ramp_s=rng.uniform(0.005, 0.02), for_s=rng.uniform(0.1, 0.3), at_s=0.5)
    if kind == 'press':
        return StaticPress(x, y, force_n=rng.uniform(0.5, 3.0), radius_mm=rng.uniform(3.5, 5.0),
                           ramp_s=rng.uniform(0.05, 0.15), for_s=rng.uniform(0.3, 1.0), at_s=0.5)
    if kind == 'trace':
        angle, length = rng.uniform(0, 2 * np.pi), rng.uniform(15.0, 40.0)
        d = 0.5 * length * np.array([np.cos(angle), np.sin(angle)])
        c = np.array([23.5, 23.5])
        return LineStroke(tuple(c - d), tuple(c + d), force_n=rng.uniform(0.8, 2.5), ramp_s=rng.uniform(0.03, 0.1),
                          for_s=rng.uniform(0.4, 1.2), at_s=0.5)
    raise ValueError(f'unknown contact kind {kind!r}; known: {", ".join(KINDS)}')


def _outcome(stimulus: Any, seed: int, force_n: float, rate_n_s: float) -> tuple[str, int | None]:
    frames = render_frames(stimulus, duration_s=stimulus.duration_s + 0.5, seed=seed)
    states = calibrate_frames(frames)
    detector = CollisionDetector(force_n, rate_n_s)
    segmenter = GestureSegmenter()
    latency, gestures = None, []
    for i in range(len(frames)):
        t = i / _RATE_HZ
        s = detector.update(bool(states.contact[i]), states.contact_xy_mm[i], states.force[i], t)
        if s is not None and s.collision is not None and latency is None:
            latency = s.frames
        xy = states.contact_xy_mm[i] if states.contact[i] else None
        gestures += segmenter.update(states.pressure[i], bool(states.contact[i]), xy, t)
    gestures += segmenter.flush()
    if latency is not None:
        return 'collision', latency
    if any(screen_gesture(g) is None for g in gestures):
        return 'gesture', None
    return 'nothing', None


def evaluate_collisions(per_kind: int = 40, seed: int = 0, force_n: float = COLLISION_FORCE_N,
                        rate_n_s: float = COLLISION_RATE_N_S) -> dict:
    """Confusion and latency over ``per_kind`` contacts of each kind (module doc)."""
    if per_kind < 1:
        raise ValueError(f'per_kind must be >= 1, got {per_kind}')
    rng = np.random.default_rng(seed)
    confusion = {k: {'collision': 0, 'gesture': 0, 'nothing': 0} for k in KINDS}
    latencies: dict[str, list[int]] = {k: [] for k in KINDS}
    for kind in KINDS:
        for i in range(per_kind):
            outcome, latency = _outcome(make_contact(kind, rng), seed * 10_000 + i, force_n, rate_n_s)
            confusion[kind][outcome] += 1
            if latency is not None:
                latencies[kind].append(latency)
    bumps = np.asarray(latencies['bump'], dtype=np.float64)
    return {
        'data': 'SYNTHETIC: simulated contacts on the virtual skin', 'per_kind': per_kind, 'seed': seed,
        'collision_force_n': force_n, 'collision_rate_n_s': rate_n_s, 'confusion': confusion,
        'bump_latency_frames': ({'median': float(np.median(bumps)), 'p90': float(np.percentile(bumps, 90)),
                                 'max': float(bumps.max())} if bumps.size else {}),
        'frame_period_ms': 1000.0 / _RATE_HZ,
    }


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval skin-collisions``."""
    parser.add_argument('--per-kind', type=positive_int, default=40,
                        help='simulated contacts of each kind (default 40)')
    parser.add_argument('--seed', type=seed, default=0, help='seed of the contacts and the sensor noise')
    parser.add_argument('--force', type=positive_float, default=COLLISION_FORCE_N,
                        help='collision force threshold, N')
    parser.add_argument('--rate', type=positive_float, default=COLLISION_RATE_N_S,
                        help='collision force-rate threshold, N/s')
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def run(args: argparse.Namespace) -> int:
    """Evaluate and print (SYNTHETIC)."""
    try:
        r = evaluate_collisions(args.per_kind, args.seed, args.force, args.rate)
    except ValueError as err:
        print(f'eval skin-collisions: {err}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(r, indent=1))
        return 0
    print(f"{r['data']}; thresholds {r['collision_force_n']} N, {r['collision_rate_n_s']} N/s; "
          f"{r['per_kind']} contacts per kind\n{'contact':8s} {'collision':>9s} {'gesture':>8s} {'nothing':>8s}")
    for kind, row in r['confusion'].items():
        print(f"{kind:8s} {row['collision']:9d} {row['gesture']:8d} {row['nothing']:8d}")
    lat = r['bump_latency_frames']
    if lat:
        print(f"bump detection latency, frames from the first contact frame ({r['frame_period_ms']:.2f} ms each): "
              f"median {lat['median']:.0f}, p90 {lat['p90']:.0f}, max {lat['max']:.0f}")
    return 0
