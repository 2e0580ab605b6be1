"""The bear's first word: how soon, and how right, /touch/symbolic is before and after its decision.

Per labelled symbolic gesture (window: its start to its end plus :func:`start_grace_s`):

- *first message*: the first CANDIDATE or START of the gesture; latency from the gesture's start.
- *what the bear says tau after the start*: the latest START, else the open CANDIDATE of highest
  confidence; ``said`` is its accuracy, ``decided`` the same from STARTs alone.
- *candidates*: CANDIDATEs, and those confirmed by a START before a WITHDRAWN, per gesture.
"""

from __future__ import annotations

import numpy as np

from touch_gestures.bear.symbolic import CANDIDATE, START, WITHDRAWN, GestureLibrary

__all__ = ['SYMBOLIC_GRACE_S', 'TAUS_S', 'candidate_outcomes', 'score_first_word', 'start_grace_s']

#: Times since a gesture's start at which the curve is read, s (0.1 s steps up to 4 s: past the 2 s dwell).
TAUS_S = tuple(round(0.1 * k, 1) for k in range(41))


def _said_at(events: list, lo: float, t: float, decisions_only: bool) -> str:
    """The gesture the events in [lo, t] say (module doc), 'none' when they say nothing."""
    decided, open_ = None, {}
    for e in events:
        if e.t < lo:
            continue
        if e.t > t:
            break
        if e.state == START:
            decided = e.gesture
        elif e.state == CANDIDATE and not decisions_only:
            open_[e.gesture] = e.confidence
        elif e.state == WITHDRAWN:
            open_.pop(e.gesture, None)
    if decided is not None:
        return decided
    return max(open_, key=open_.get) if open_ else 'none'


def candidate_outcomes(events: list) -> dict[str, dict[str, int]]:
    """Gesture -> {'candidates', 'confirmed', 'withdrawn'} over ``events`` (time order)."""
    out: dict[str, dict[str, int]] = {}
    out_now: set[str] = set()
    for e in events:
        row = out.setdefault(e.gesture, {'candidates': 0, 'confirmed': 0, 'withdrawn': 0})
        if e.state == CANDIDATE:
            row['candidates'] += 1
            out_now.add(e.gesture)
        elif e.gesture in out_now and e.state in (START, WITHDRAWN):
            row['confirmed' if e.state == START else 'withdrawn'] += 1
            out_now.discard(e.gesture)
    return out


#: Seconds after a labelled gesture's end during which its START still counts.
SYMBOLIC_GRACE_S = 1.0


def start_grace_s(gesture) -> float:
    """Seconds after a trial of ``gesture`` (a ``GestureFilter``) during which its START counts: a brief
    gesture (``max_s``) STARTs at its release, ``gap_s`` after its last contact, so it has that much more."""
    return SYMBOLIC_GRACE_S + (gesture.gap_s if gesture.max_s is not None else 0.0)


def score_first_word(scene, events: list, library: GestureLibrary, taus_s=TAUS_S) -> dict:
    """First-message latency and the said / decided accuracy curve over ``scene``'s symbolic labels."""
    names = {g.name for g in library.detectable}
    labels = [lab for lab in scene.labels if lab.kind == 'symbolic' and lab.label in names]
    events = sorted(events, key=lambda e: e.t)
    firsts, firsts_any = [], []
    said = np.zeros(len(taus_s))
    decided = np.zeros(len(taus_s))
    for lab in labels:
        lo, hi = lab.start_s, lab.end_s + start_grace_s(library[lab.label])
        inside = [e for e in events if lo <= e.t <= hi and e.state in (CANDIDATE, START)]
        own = [e for e in inside if e.gesture == lab.label]
        if own:
            firsts.append(own[0].t - lo)
        if inside:
            firsts_any.append(inside[0].t - lo)
        window = [e for e in events if lo <= e.t <= hi]
        for k, tau in enumerate(taus_s):
            t = min(lo + tau, hi)
            said[k] += _said_at(window, lo, t, False) == lab.label
            decided[k] += _said_at(window, lo, t, True) == lab.label
    n = max(len(labels), 1)
    return {
        'labelled': len(labels),
        'median_first_message_s': float(np.median(firsts)) if firsts else None,
        'first_message_rate': len(firsts) / n if labels else None,
        'median_first_any_message_s': float(np.median(firsts_any)) if firsts_any else None,
        'taus_s': list(taus_s),
        'said_accuracy': (said / n).tolist(),
        'decided_accuracy': (decided / n).tolist(),
        'candidates': candidate_outcomes(events),
    }
