"""Detections and false starts of each symbolic gesture over labelled trials, and which performed touch
caused each false start.

A *trial* is a labelled span of a person's touch, ``(start_s, end_s + grace, kind, name)``: ``kind``
``'symbolic'`` (a gesture, grace :func:`~.first_word.start_grace_s`) or ``'subtype'`` (a single-sensor
touch subtype). Per detectable gesture ``g``:

- *detected*: trials of ``g`` during which ``g`` STARTed, over the trials of ``g``;
- *false starts*: STARTs of ``g`` no trial of ``g`` explains. A START during a subtype trial of ``g``'s
  own subtype (a tap for shoulder_tap) is the gesture's own touch, so neither detected nor false.
  ``false_starts_by_cause`` splits them into ``other_gesture`` (during another gesture's trial),
  ``subtype_trial`` (during a subtype trial of another subtype) and ``outside_trials``;
  ``false_starts_by_touch`` names the performed touch: ``'symbolic/<gesture>'``, ``'subtype/<subtype>'``
  or ``'none'`` (outside every trial);
- *latency*: trial start to ``g``'s first START in it, s.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import TYPE_CHECKING

import numpy as np

from touch_gestures.bear.symbolic import GestureLibrary
from touch_sim.bear.people import PERFORMANCES, split_label

from .first_word import SYMBOLIC_GRACE_S, start_grace_s

if TYPE_CHECKING:   # sessions reads bags and trains models: not needed to count
    from .sessions import BearTrials

__all__ = ['CAUSES', 'STATISTICS', 'Trial', 'format_gesture_starts', 'gesture_starts', 'runs_gesture_starts',
           'summarise']

#: The causes a false start is counted under (module doc).
CAUSES = ('other_gesture', 'subtype_trial', 'outside_trials')
#: What each figure of :func:`summarise` is, in words (JSON outputs carry it).
STATISTICS = {
    'trials': 'labelled trials of the gesture',
    'detected': 'trials of the gesture during which it STARTed',
    'detected_fraction': 'detected / trials',
    'false_starts': 'STARTs of the gesture no trial of it (nor a subtype trial of its own subtype) explains',
    'false_starts_by_cause': 'false starts during another gesture, a subtype trial of another subtype, or '
                             'outside every trial',
    'false_starts_by_touch': "false starts by the performed touch they fell in ('symbolic/<g>', "
                             "'subtype/<s>', 'none')",
    'median_latency_s': 'median over all detected trials of trial start to the first START, s',
}

#: A labelled trial: (start s, end s including its grace, 'symbolic' or 'subtype', gesture or subtype name).
Trial = tuple[float, float, str, str]


def gesture_starts(trials: Iterable[Trial], starts: Iterable[tuple[str, float]], names: Iterable[str],
                   own_subtype: Mapping[str, str | None]) -> dict[str, dict]:
    """Per gesture of ``names``: trials, detected, latencies (s), false starts by cause and by touch.

    Args:
        trials: labelled trials (:data:`Trial`), any order.
        starts: ``(gesture, t)`` of every START, t in s on the trials' clock.
        names: the gestures scored (STARTs of others are ignored).
        own_subtype: gesture -> the touch subtype it is performed with (None: none).
    """
    trials, starts = list(trials), list(starts)
    out = {n: {'trials': 0, 'detected': 0, 'latencies_s': [], 'false_starts': 0,
               'false_starts_by_cause': dict.fromkeys(CAUSES, 0), 'false_starts_by_touch': {}} for n in names}
    explained = np.zeros(len(starts), dtype=bool)
    for lo, hi, kind, name in trials:
        if kind != 'symbolic' or name not in out:
            continue
        out[name]['trials'] += 1
        own = [i for i, (g, t) in enumerate(starts) if g == name and lo <= t <= hi]
        if own:
            out[name]['detected'] += 1
            out[name]['latencies_s'].append(starts[own[0]][1] - lo)
            explained[own] = True
    for i, (g, t) in enumerate(starts):
        if explained[i] or g not in out:
            continue
        during = [(kind, name) for lo, hi, kind, name in trials if lo <= t <= hi]
        if any(kind == 'subtype' and name == own_subtype.get(g) for kind, name in during):
            continue                     # the gesture's own touch on its filter: not false
        symbolic = [name for kind, name in during if kind == 'symbolic']
        if symbolic:
            cause, touch = 'other_gesture', f'symbolic/{symbolic[0]}'
        elif during:
            cause, touch = 'subtype_trial', f'subtype/{during[0][1]}'
        else:
            cause, touch = 'outside_trials', 'none'
        row = out[g]
        row['false_starts'] += 1
        row['false_starts_by_cause'][cause] += 1
        row['false_starts_by_touch'][touch] = row['false_starts_by_touch'].get(touch, 0) + 1
    return out


def runs_gesture_starts(runs: Iterable[BearTrials], starts: Iterable[list[tuple[str, float]]],
                        library: GestureLibrary) -> dict[str, dict]:
    """:func:`gesture_starts` of every detectable gesture of ``library`` over labelled runs, summed:
    ``starts[i]`` the ``(gesture, t)`` STARTs over ``runs[i]`` (t on that run's clock); each run's subtype and
    symbolic labels are its trials, a gesture's with its :func:`~.first_word.start_grace_s`."""
    names = [g.name for g in library.detectable]
    grace = {n: start_grace_s(library[n]) for n in names}
    own = {n: perf.subtype for n, perf in PERFORMANCES.items()}
    total = {n: {'trials': 0, 'detected': 0, 'latencies_s': [], 'false_starts': 0,
                 'false_starts_by_cause': dict.fromkeys(CAUSES, 0), 'false_starts_by_touch': {}} for n in names}
    for run, run_starts in zip(runs, starts, strict=True):
        spans = [(lab.start_s, lab.end_s + grace.get(split_label(lab.gesture)[1], SYMBOLIC_GRACE_S),
                  *split_label(lab.gesture)) for lab in (*run.labels, *run.gestures)]
        for name, part in gesture_starts(spans, run_starts, names, own).items():
            row = total[name]
            for key in ('trials', 'detected', 'false_starts'):
                row[key] += part[key]
            row['latencies_s'] += part['latencies_s']
            for key in ('false_starts_by_cause', 'false_starts_by_touch'):
                for what, n in part[key].items():
                    row[key][what] = row[key].get(what, 0) + n
    return total


def summarise(per_gesture: Mapping[str, dict]) -> dict:
    """Per gesture and over all gestures: the figures of :data:`STATISTICS` (latency medians over all trials,
    never medians of medians)."""
    gestures = {}
    for name, s in per_gesture.items():
        lat = s['latencies_s']
        gestures[name] = {'trials': s['trials'], 'detected': s['detected'],
                          'detected_fraction': s['detected'] / s['trials'] if s['trials'] else None,
                          'false_starts': s['false_starts'], 'false_starts_by_cause': dict(s['false_starts_by_cause']),
                          'false_starts_by_touch': dict(sorted(s['false_starts_by_touch'].items())),
                          'median_latency_s': float(np.median(lat)) if lat else None}
    trials = sum(s['trials'] for s in per_gesture.values())
    detected = sum(s['detected'] for s in per_gesture.values())
    by_touch: dict[str, int] = {}
    for s in per_gesture.values():
        for touch, n in s['false_starts_by_touch'].items():
            by_touch[touch] = by_touch.get(touch, 0) + n
    lat = [v for s in per_gesture.values() for v in s['latencies_s']]
    return {'trials': trials, 'detected': detected, 'detected_fraction': detected / trials if trials else None,
            'false_starts': sum(s['false_starts'] for s in per_gesture.values()),
            'false_starts_by_cause': {c: sum(s['false_starts_by_cause'][c] for s in per_gesture.values())
                                      for c in CAUSES},
            'false_starts_by_touch': dict(sorted(by_touch.items())),
            'median_latency_s': float(np.median(lat)) if lat else None, 'per_gesture': gestures,
            'statistics': STATISTICS}


def format_gesture_starts(summary: dict) -> list[str]:
    """Text lines of a :func:`summarise` result: per gesture, detected / trials, false starts and their touches."""
    lines = [f"Per symbolic gesture: detected / trials, false starts (by performed touch); all: "
             f"{summary['detected']} / {summary['trials']}, {summary['false_starts']} false starts"]
    for name, g in summary['per_gesture'].items():
        touches = ', '.join(f'{touch} {n}' for touch, n in g['false_starts_by_touch'].items())
        lines.append(f"  {name:13s} {g['detected']:>3d} / {g['trials']:<3d} {g['false_starts']:>3d}"
                     + (f'  ({touches})' if touches else ''))
    return lines
