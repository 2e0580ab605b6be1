"""How the skin node does on simulated sessions, and what a frame costs it (SYNTHETIC data).

:func:`evaluate_sessions` (``eval skin-sessions``) plays one :func:`~.scene.people_scene` per seed on
the virtual skin through the real ``skin_driver`` and ``haptic_commands`` nodes, and scores every
``/touch/haptic_command`` against the scene: right, wrong, missed, or a false command during another
touch. :func:`bench_frames` (``bench skin-node``) times the node's frame callback.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections import Counter
from typing import Any

import numpy as np

from touch_driver.skin.node import SkinDriverNode
from touch_gestures.skin.node import HapticCommandsNode
from touch_graph.runtime import Context
from touch_sim.harness import Harness
from touch_sim.skin.people import SkinScene, people_scene

__all__ = ['SCENE_OPTIONS', 'add_arguments', 'bench_frames', 'bench_node', 'evaluate_sessions', 'run',
           'run_session']


#: The options of config/scenes/skin_people.yaml but the seed.
SCENE_OPTIONS: dict[str, Any] = {
    'n_people': 2, 'gestures': ('diagonal_down', 'diagonal_up', 'line_right', 'line_left', 'one', 'two',
                                'line_down', 'line_up'),
    'per_person': 4, 'random_touches_n': 2, 'presses': 1, 'two_fingers': 1, 'pause_s': (1.2, 2.0), 'lead_s': 2.0,
}


def run_session(scene: SkinScene, seed: int = 0, frames: list | None = None, **node_params: Any
                ) -> tuple[Any, list[tuple[float, Any]]]:
    """Play ``scene`` through skin_driver + haptic_commands in a simulated-time graph.

    Returns: the node (its counters) and the commands as (scene time s, HapticCommand);
    with ``frames`` a list, the ``SkinFrame`` messages are appended to it too.
    """
    with Harness(log_level='error') as harness:
        node = harness.add_node(HapticCommandsNode, namespace='skin', parameters=node_params)
        commands = harness.collect('/touch/haptic_command', 'HapticCommand', 100)
        if frames is not None:
            harness.subscribe('/skin/frame', 'SkinFrame', frames.append, 100)
        harness.add_node(SkinDriverNode, namespace='skin',
                         parameters={'port': harness.device('skin', scene, seed=seed)})
        harness.spin_for(scene.duration_s)
        return node, [(harness.seconds(c), c) for c in commands]


def evaluate_sessions(seeds: list[int], codebook: str = '', **scene_options: Any) -> dict[str, Any]:
    """Right, wrong and missed commands for the gestures, and false commands for the other touches,
    over one simulated session per seed (module doc)."""
    options = {**SCENE_OPTIONS, **scene_options}
    tally: Counter[str] = Counter()
    per_gesture: dict[str, Counter[str]] = {}
    others: Counter[str] = Counter()
    outcomes: Counter[str] = Counter()
    for seed in seeds:
        scene = people_scene(seed=seed, **options)
        node, commands = run_session(scene, seed=seed, **({'codebook': codebook} if codebook else {}))
        outcomes.update(node.outcomes)
        answered: dict[int, str] = {}
        for t, cmd in commands:
            hits = [i for i, e in enumerate(scene.events) if e.start_s - 0.1 <= t <= e.end_s + 0.1]
            if not hits or scene.events[hits[0]].kind != 'gesture':
                tally['false'] += 1
                others[scene.events[hits[0]].kind if hits else 'no touch'] += 1
            else:
                answered[hits[0]] = cmd.gesture
        for i, e in enumerate(scene.events):
            if e.kind != 'gesture':
                others[f'{e.kind} touches'] += 1
                continue
            verdict = 'missed' if i not in answered else 'right' if answered[i] == e.label else 'wrong'
            tally[verdict] += 1
            per_gesture.setdefault(e.label, Counter())[verdict] += 1
    gestures = tally['right'] + tally['wrong'] + tally['missed']
    return {'sessions': len(seeds), 'gestures': gestures, 'right': tally['right'], 'wrong': tally['wrong'],
            'missed': tally['missed'], 'other_touches': sum(v for k, v in others.items() if k.endswith(' touches')),
            'false_commands': tally['false'], 'false_by_kind': {k: v for k, v in others.items()
                                                               if not k.endswith(' touches')},
            'per_gesture': {g: dict(c) for g, c in sorted(per_gesture.items())}, 'node_outcomes': dict(outcomes)}


def bench_frames(seed: int = 1, repeat: int = 7) -> dict[str, float]:
    """Median wall time (us) of the node's frame callback over a simulated session's frames, for
    frames with and without contact (recognition runs on the frame that ends a gesture)."""
    frames: list[Any] = []
    run_session(people_scene(seed=seed, **SCENE_OPTIONS), seed=seed, frames=frames)
    contact = np.array([bool(f.contact) for f in frames])
    runs: dict[str, list[float]] = {'contact': [], 'no_contact': [], 'all': []}
    for _ in range(repeat):
        ctx = Context('sim')
        ctx.init()
        node = HapticCommandsNode(context=ctx, cli_args=['--ros-args', '--log-level', 'error'])
        cost = np.empty(len(frames))
        for i, f in enumerate(frames):
            t0 = time.perf_counter()
            node._on_frame(f)
            cost[i] = time.perf_counter() - t0
        node.destroy_node()
        ctx.shutdown()
        runs['contact'].append(float(np.median(cost[contact])) * 1e6)
        runs['no_contact'].append(float(np.median(cost[~contact])) * 1e6)
        runs['all'].append(float(cost.mean()) * 1e6)
    return {'frames': len(frames), 'us_median_contact_frame': statistics.median(runs['contact']),
            'us_median_untouched_frame': statistics.median(runs['no_contact']),
            'us_mean_frame': statistics.median(runs['all']), 'budget_us_at_150hz': 1e6 / 150}


def _seeds(text: str) -> list[int]:
    """``'1-3,7'`` -> [1, 2, 3, 7].

    >>> _seeds('1-3,7')
    [1, 2, 3, 7]
    """
    out: list[int] = []
    for part in text.split(','):
        lo, _, hi = part.partition('-')
        out += list(range(int(lo), int(hi or lo) + 1))
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval skin-sessions``."""
    parser.add_argument('--seeds', default='1-20', help="sessions to simulate, e.g. '1-20' (default)")
    parser.add_argument('--codebook', default='', help="codebook .npz (default: the package's)")


def run(args: argparse.Namespace) -> int:
    """Evaluate and print the tally (SYNTHETIC)."""
    r = evaluate_sessions(_seeds(args.seeds), args.codebook)
    print(f"SYNTHETIC: {r['sessions']} simulated sessions (people_scene, seeds {args.seeds}) through skin_driver + "
          f"haptic_commands:\n  gestures {r['gestures']}: right {r['right']}, wrong {r['wrong']}, missed "
          f"{r['missed']}\n  other touches {r['other_touches']}: false commands {r['false_commands']} "
          f"{r['false_by_kind'] or ''}\n  node outcomes {r['node_outcomes']}")
    for g, c in r['per_gesture'].items():
        print(f'  {g:15s} {c}')
    return 0


def bench_node(repeats: int = 7) -> dict[str, float]:
    """``social-touch bench skin-node``: :func:`bench_frames` over ``repeats`` runs."""
    return {**bench_frames(repeat=repeats), 'synthetic': True}
