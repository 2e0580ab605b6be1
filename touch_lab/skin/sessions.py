"""Skin codebooks from recorded sessions (``collect skin`` bags), and their leave-one-person-out score.

Sessions are cut into touches by the node's own segmentation
(:class:`~touch_gestures.skin.frames.SkinFrameStream`); a trial takes the touch that overlaps it most (it
may start :data:`GRACE_S` early). A trial without a touch, or screened out, is reported and left out.
Per held-out person a trial is *right*, *wrong*, *rejected* (or screened out) or *missed* (no touch);
latency runs from the end of the touch to the recognition.
"""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from touch_gestures.skin.frames import SkinFrameStream
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.screening import screen_gesture
from touch_graph.errors import SocialTouchError
from touch_lab.collect.coverage import read_checked
from touch_lab.collect.session_bag import LabelRow, SessionError, SessionRecording
from touch_lab.skin.codebook_tools import extend_codebook
from touch_lab.skin.recognisers import load_codebook, make_recogniser

__all__ = ['GRACE_S', 'SkinTrial', 'leave_one_person_out', 'score', 'skin_trials']

#: Seconds a touch may begin before its label's start (an operator marks a trial late) and still belong to it.
GRACE_S = 0.5


@dataclass
class SkinTrial:
    """One labelled trial and its touch (None when the segmentation found none).

    Attributes:
        label: the trial.
        gesture: the touch, or None.
        screened: why the node would refuse the touch (``screen_gesture``), or None.
        where: ``'BAG at T s'`` for messages.
    """

    label: LabelRow
    gesture: TouchGesture | None
    screened: str | None
    where: str


def skin_trials(session: SessionRecording, warn: Callable[[str], None] | None = None) -> list[SkinTrial]:
    """Every labelled trial of a skin session with the touch that overlaps it most (module doc)."""
    say = warn or (lambda _m: None)
    stream = SkinFrameStream()
    touches: list[tuple[float, float, TouchGesture]] = []
    origin = session.origin_ns
    for msg in session.frames['/skin/frame']:
        for g in stream.update(msg):
            start = (stream.stamp_ns(g.start_s) - origin) / 1e9
            touches.append((start, start + g.duration_s, g))
    for g in stream.flush():
        start = (stream.stamp_ns(g.start_s) - origin) / 1e9
        touches.append((start, start + g.duration_s, g))
    out = []
    for lab in session.labels:
        where = f'{session.path} at {lab.start_s:.2f} s'
        best, overlap = None, 0.0
        for t0, t1, g in touches:
            o = min(t1, lab.end_s) - max(t0, lab.start_s - GRACE_S)
            if o > overlap or (best is None and o >= 0 and t0 >= lab.start_s - GRACE_S and t0 <= lab.end_s):
                best, overlap = g, max(o, overlap)
        if best is None:
            say(f'{where}: no touch found for {lab.person}\'s {lab.gesture!r}; left out')
            out.append(SkinTrial(lab, None, None, where))
            continue
        reason = screen_gesture(best)
        if reason:
            say(f'{where}: {lab.person}\'s {lab.gesture!r} is no usable gesture ({reason}); left out of the codebook')
        out.append(SkinTrial(lab, best, reason, where))
    return out


def usable(trials: list[SkinTrial]) -> list[SkinTrial]:
    """The trials a codebook can take a template from."""
    return [t for t in trials if t.gesture is not None and t.screened is None]


def fit_codebook(trials: list[SkinTrial], recogniser: str, base=None):
    """A recogniser fitted on ``trials`` (added to ``base``'s templates when given).

    Raises:
        SessionError: no usable trial, or fewer than two classes (a codebook tells gestures apart).
    """
    keep = usable(trials)
    names = sorted({t.label.gesture for t in keep} | set(getattr(base, 'classes_', ())))
    if len(names) < 2:
        raise SessionError(f'a codebook needs usable trials of at least two gestures; got {names or "none"} '
                           '(see the warnings above)')
    model = make_recogniser(recogniser) if base is None else base
    gestures = [t.gesture for t in keep]
    labels = [t.label.gesture for t in keep]
    if base is None:
        return model.fit(gestures, labels)
    return extend_codebook(model, gestures, labels)


def score(model, trials: list[SkinTrial]) -> dict:
    """Right, wrong, rejected, missed and latency of ``model`` on ``trials`` (module doc)."""
    counts = {'right': 0, 'wrong': 0, 'rejected': 0, 'missed': 0}
    latencies = []
    confusion: dict[str, dict[str, int]] = {}
    for t in trials:
        row = confusion.setdefault(t.label.gesture, {})
        if t.gesture is None:
            counts['missed'] += 1
            row['(missed)'] = row.get('(missed)', 0) + 1
            continue
        if t.screened:
            counts['rejected'] += 1
            row['(rejected)'] = row.get('(rejected)', 0) + 1
            continue
        t0 = time.perf_counter()
        match = model.predict(t.gesture)
        latencies.append(time.perf_counter() - t0)
        name = match.label if match.label is not None else '(rejected)'
        row[name] = row.get(name, 0) + 1
        if match.label is None:
            counts['rejected'] += 1
        elif match.label == t.label.gesture:
            counts['right'] += 1
        else:
            counts['wrong'] += 1
    n = len(trials)
    return {**counts, 'trials': n, 'accuracy': counts['right'] / n if n else None, 'confusion': confusion,
            'median_latency_s': float(np.median(latencies)) if latencies else None}


def leave_one_person_out(trials: list[SkinTrial], recogniser: str,
                         progress: Callable[[str], None] | None = None) -> dict:
    """For each person, a codebook of everybody else's trials scored on theirs; pooled and per person."""
    say = progress or (lambda _m: None)
    people = sorted({t.label.person for t in trials})
    if len(people) < 2:
        raise SessionError(f'leave-one-person-out needs sessions of at least two people; got {people}')
    pooled = {'right': 0, 'wrong': 0, 'rejected': 0, 'missed': 0, 'trials': 0}
    confusion: dict[str, dict[str, int]] = {}
    per_person, latencies = {}, []
    for i, person in enumerate(people):
        say(f'person {person} ({i + 1}/{len(people)}): codebook of the {len(people) - 1} others')
        model = fit_codebook([t for t in trials if t.label.person != person], recogniser)
        result = score(model, [t for t in trials if t.label.person == person])
        per_person[person] = result['accuracy']
        for k in pooled:
            pooled[k] += result[k]
        for truth, row in result['confusion'].items():
            for pred, n in row.items():
                confusion.setdefault(truth, {})[pred] = confusion.get(truth, {}).get(pred, 0) + n
        if result['median_latency_s'] is not None:
            latencies.append(result['median_latency_s'])
    return {'people': people, **pooled, 'accuracy': pooled['right'] / pooled['trials'] if pooled['trials'] else None,
            'per_person': per_person, 'confusion': confusion, 'recogniser': recogniser,
            'median_latency_s': float(np.median(latencies)) if latencies else None}


def format_lopo(result: dict, synthetic: bool) -> str:
    """The text report of :func:`leave_one_person_out`."""
    n = result['trials']
    data = 'SYNTHETIC: simulated people' if synthetic else 'recorded sessions'
    pct = (lambda k: f"{result[k]} ({100 * result[k] / n:.1f} %)") if n else (lambda k: str(result[k]))
    method = result.get('method', 'leave-one-person-out')
    lines = [f"Skin haptic commands ({result['recogniser']}), {method}, {len(result['people'])} people ({data})",
             f'trials {n}: right {pct("right")}, wrong {pct("wrong")}, rejected {pct("rejected")}, '
             f'missed {pct("missed")}',
             f"recognition latency after the touch ends (median compute): "
             f"{1e3 * (result['median_latency_s'] or 0):.2f} ms",
             'per person: ' + ', '.join(f'{p} {100 * a:.1f} %' for p, a in result['per_person'].items()
                                        if a is not None),
             '', 'per gesture (rows: truth): recognised as']
    for truth, row in sorted(result['confusion'].items()):
        total = sum(row.values())
        lines.append(f'  {truth:18s} {100 * row.get(truth, 0) / total:5.1f} %  ' +
                     ', '.join(f'{k} {v}' for k, v in sorted(row.items(), key=lambda kv: -kv[1])))
    return '\n'.join(lines)


def load_trials(paths: list[str], progress: Callable[[str], None]) -> tuple[list[SkinTrial], bool]:
    """Read, check and segment every session bag; (trials, synthetic)."""
    sessions = read_checked(paths, 'skin', progress)
    trials = []
    for i, session in enumerate(sessions):
        progress(f'segmenting {session.path} ({i + 1}/{len(sessions)}, {len(session.labels)} trials)')
        trials += skin_trials(session, lambda m: progress(f'warning: {m}'))
    return trials, any(s.synthetic for s in sessions)


# ----------------------------------------------------------------------------- commands
def _say(prefix: str, quiet: bool = False) -> Callable[[str], None]:
    return (lambda _m: None) if quiet else (lambda m: print(f'[{prefix}] {m}', file=sys.stderr, flush=True))


def run_eval_bags(args, recogniser: str) -> int:
    """``social-touch eval skin --bags BAG...``: leave-one-person-out on session bags."""
    say = _say('eval skin')
    try:
        trials, synthetic = load_trials(args.bags, say)
        if getattr(args, 'codebook', None):
            book = load_codebook(args.codebook)
            result = score(book, trials)
            people = sorted({t.label.person for t in trials})
            result.update(people=people, recogniser=args.codebook,
                          method=f'the codebook {args.codebook} on every trial',
                          per_person={p: score(book, [t for t in trials if t.label.person == p])['accuracy']
                                      for p in people})
        else:
            result = leave_one_person_out(trials, recogniser, say)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval skin: error: {err}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps({**result, 'synthetic': synthetic, 'bags': list(args.bags)}))
    else:
        print(format_lopo(result, synthetic))
    return 0
