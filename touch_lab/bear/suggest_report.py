"""What ``social-touch train bear --bags`` says and writes about the symbolic gestures (:mod:`.suggest`):
the table, the suggested gesture config beside the model, and the model card's entry.

The suggested config is the user's config (``--gestures-config``, default config/bear_gestures.yaml)
with the suggested ``min_active`` and ``dwell_s`` of the gestures there was enough data for; it is a
new file (``MODEL.gestures.yaml`` by default), never the config it was made from. Launch the scene with
it by ``gestures:=FILE`` (launch/bear.launch.yaml).
"""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path

import numpy as np
import yaml

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.symbolic import GestureLibrary
from touch_graph.errors import ConfigError
from touch_graph.files import write_text
from touch_graph.yamlconf import read_text, safe_load

from . import suggest as sg
from .false_starts import STATISTICS as FALSE_STARTS
from .sessions import BearTrials

__all__ = ['METHOD', 'card_entry', 'default_output', 'format_table', 'run_suggestions', 'write_config']

#: How the suggestion is made, in one sentence (the table, the card and the written config say it).
METHOD = (f'min_active: the {sg.QUANTILE:.0%} quantile of the trials\' peak count of active filter sensors; '
          f'dwell_s: min({sg.QUANTILE:.0%} quantile of how long that match holds, {sg.REACTION_S:g} s (knight2009 '
          f'V.E) - {1 - sg.QUANTILE:.0%} quantile of the time to reach it), rounded down to {sg.DWELL_STEP_S:g} s; '
          'lift_s, gap_s, max_s, quiet_s, both_sides, subtype and supersedes as configured')


def default_output(model_path: str | os.PathLike) -> Path:
    """``bear_model.npz`` -> ``bear_model.gestures.yaml`` (beside the model)."""
    path = Path(model_path)
    return path.with_name(path.stem + '.gestures.yaml')


def run_suggestions(runs: list[BearTrials], library: GestureLibrary, body_map: BodyMap, predictor,
                    fold_predictors: dict | None, progress: Callable[[str], None]) -> dict | None:
    """Statistics, suggestions (all people) and their leave-one-person-out check; None without symbolic trials.

    ``predictor`` gives the subtype codes of the suggestion from all people; ``fold_predictors`` (person ->
    predictor without them) those of the check. Warnings, one per gesture, go through ``progress``.
    """
    if not any(run.gestures for run in runs):
        return None
    codes = [sg.trial_codes(r, predictor) for r in runs]
    stats = sg.gesture_stats(runs, codes, library, body_map, lambda m: progress(f'warning: {m}'))
    suggestions = {g.name: sg.suggest(stats[g.name], g) for g in library.detectable}
    for s in suggestions.values():
        if s.reason:
            progress(f"warning: gesture '{s.name}': {s.reason}; its configured settings are kept")
    for name, st in stats.items():
        silent = sum(p == 0 for p in st.peaks)
        if 0 < silent < len(st.peaks):
            g = library[name]
            what = ' on both sides' if g.both_sides else ''
            what += f' carrying {"/".join(g.subtypes)}' if g.subtypes else ''
            progress(f"warning: gesture '{name}': {silent} of {len(st.peaks)} trials activated none of its "
                     f'filter sensors{what} (strayed, too light, or between two scans)')
    lopo = sg.leave_one_person_out(runs, library, body_map, fold_predictors, progress)
    return {'stats': stats, 'suggestions': suggestions, 'lopo': lopo}


def _pct(part: int, whole: int) -> str:
    return f'{part}/{whole}' if whole else '-'


def _sec(value) -> str:
    return '-' if value is None else f'{value:.2f} s'


def format_table(result: dict, library: GestureLibrary, synthetic: bool) -> str:
    """The text report of :func:`run_suggestions`."""
    stats, suggestions, lopo = result['stats'], result['suggestions'], result['lopo']
    trials = sum(len(s.peaks) for s in stats.values())
    people = {p for s in stats.values() for p in s.people}
    data = 'SYNTHETIC: simulated people' if synthetic else 'recorded sessions'
    lines = [f'Symbolic gesture settings suggested from {trials} labelled trials of {len(people)} people ({data})',
             f'how: {METHOD}']
    if lopo:
        lines.append(f"checked leave-one-person-out over {len(lopo['people'])} people: settings suggested from the "
                     "others, run through the recogniser (priority logic included) over the person's sessions; "
                     f"false starts as eval bear counts them: {FALSE_STARTS['false_starts']}")
    lines += ['', f"{'':14s}{'':>7s}{'':>7s} {'peak active':>11s} {'min_active':>11s} {'dwell_s':>12s}"
                  f" {'held-out detected':>17s} {'false starts':>13s} {'median START latency':>21s}",
              f"{'gesture':14s}{'trials':>7s}{'people':>7s} {'min/med/max':>11s} {'conf -> sug':>11s} "
              f"{'conf -> sug':>12s} {'conf':>8s} {'sug':>8s} {'conf':>6s} {'sug':>6s} {'conf':>10s} {'sug':>10s}"]
    for g in library.detectable:
        st, s = stats[g.name], suggestions[g.name]
        peaks = np.array(st.peaks) if st.peaks else None
        spread = f'{peaks.min()}/{np.median(peaks):g}/{peaks.max()}' if peaks is not None else '-'
        m = f'{g.min_active} -> {s.min_active if s.min_active is not None else "kept"}'
        d = f'{g.dwell_s:g} -> {s.dwell_s:g}' if s.dwell_s is not None else f'{g.dwell_s:g} -> kept'
        row = f'{g.name:14s}{len(st.peaks):7d}{len(set(st.people)):7d} {spread:>11s} {m:>11s} {d:>12s}'
        if lopo:
            c, u = lopo['configured'][g.name], lopo['suggested'][g.name]
            row += (f" {_pct(c['detected'], c['trials']):>8s} {_pct(u['detected'], u['trials']):>8s}"
                    f" {c['false_starts']:6d} {u['false_starts']:6d} {_sec(c['median_start_latency_s']):>10s}"
                    f" {_sec(u['median_start_latency_s']):>10s}")
        lines.append(row)
    if lopo:
        c = _total(lopo['configured'])
        u = _total(lopo['suggested'])
        lines.append(f"{'all':14s}{'':7s}{'':7s} {'':11s} {'':11s} {'':12s} {_pct(*c[:2]):>8s} {_pct(*u[:2]):>8s}"
                     f' {c[2]:6d} {u[2]:6d}')
    lines += ['', "active sensors per gesture (trials in which each was active; * outside the gesture's filter)"]
    for g in library.detectable:
        st = stats[g.name]
        if not st.peaks:
            continue
        inside = set(g.sensor_names)
        top = sorted(st.active_sensors.items(), key=lambda kv: (-kv[1], kv[0]))
        lines.append(f'  {g.name:13s} ' + ', '.join(f'{name}{"" if name in inside else "*"} {n}'
                                                    for name, n in top[:8]) + (' ...' if len(top) > 8 else ''))
    return '\n'.join(lines)


def _total(per_gesture: dict) -> tuple[int, int, int]:
    return (sum(v['detected'] for v in per_gesture.values()), sum(v['trials'] for v in per_gesture.values()),
            sum(v['false_starts'] for v in per_gesture.values()))


def write_config(source: str | os.PathLike, out: str | os.PathLike, suggestions: dict, header: str,
                 body_map: BodyMap | None = None) -> int:
    """Write ``source``'s gesture config with the suggested settings to ``out``; the number of gestures changed.

    Raises:
        ConfigError: ``out`` is ``source`` (a user's config is never overwritten), or the written file
            does not load (it is removed then).
    """
    source, out = Path(source), Path(out)
    if out.resolve() == source.resolve():
        raise ConfigError(f'{out} is the gesture config the suggestion is made from; write the suggestion to '
                          'another file (--suggest-output)')
    doc = safe_load(read_text(source), str(source))
    changed = 0
    for name, s in suggestions.items():
        spec = doc['gestures'].get(name)
        if s.min_active is None or not isinstance(spec, dict):
            continue
        spec['min_active'], spec['dwell_s'] = int(s.min_active), float(s.dwell_s)
        changed += 1
    text = ''.join(f'# {line}\n' if line else '#\n' for line in header.splitlines())
    out.parent.mkdir(parents=True, exist_ok=True)
    write_text(out, text + yaml.safe_dump(doc, sort_keys=False, width=110, allow_unicode=True, default_flow_style=None))
    try:
        GestureLibrary.load(out, body_map)
    except ConfigError:
        out.unlink()
        raise
    return changed


def _round(value: float | None) -> float | None:
    return None if value is None else round(value, 3)


def card_entry(result: dict, config: str, written: str) -> dict:
    """The model card's record of the suggestion: method, files, settings and the leave-one-person-out figures."""
    gestures = {}
    lopo = result['lopo']
    for name, s in result['suggestions'].items():
        entry: dict = {'trials': s.trials, 'people': s.people}
        if s.min_active is None:
            entry['kept'] = s.reason
        else:
            entry.update(min_active=s.min_active, dwell_s=s.dwell_s)
        if lopo:
            u, c = lopo['suggested'][name], lopo['configured'][name]
            entry.update(held_out_detected=f"{u['detected']}/{u['trials']}", false_starts=u['false_starts'],
                         median_start_latency_s=_round(u['median_start_latency_s']),
                         configured_held_out_detected=f"{c['detected']}/{c['trials']}",
                         configured_false_starts=c['false_starts'])
        gestures[name] = entry
    return {'method': METHOD, 'from_config': str(config), 'written_to': str(written),
            'evaluation': 'leave-one-person-out' if lopo else 'none (one person)', 'gestures': gestures}
