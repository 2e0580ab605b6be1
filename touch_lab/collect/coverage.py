"""What a set of sessions covers: classes missing for a person, people with a single trial of a class.

Neither stops training (the model learns a class from the people who performed it), but either
changes what leave-one-person-out measures, so :func:`check_coverage` names them.

>>> from pathlib import Path
>>> from touch_lab.collect.session_bag import LabelRow, SessionRecording
>>> def rec(name, rows):
...     labels = [LabelRow('p1', g, '', s, s + 1) for g, s in rows]
...     return SessionRecording(Path(name), 'patch', True, 0, labels, {}, {})
>>> check_coverage([rec('a', [('stroke', 1), ('slap', 3)]), rec('b', [('stroke', 9)])])
['p1 has a single trial of slap (a at 3.00 s): leave-one-person-out scores it on one example']
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Callable

from .session_bag import SessionRecording, read_sessions

__all__ = ['check_coverage', 'read_checked']


def check_coverage(sessions: list[SessionRecording]) -> list[str]:
    """Warnings about classes a person lacks or performed once, each naming the bag (and the time)."""
    classes = sorted({lab.gesture for s in sessions for lab in s.labels})
    seen: dict[str, dict[str, list[tuple[str, float]]]] = defaultdict(lambda: defaultdict(list))
    bags: dict[str, list[str]] = defaultdict(list)
    for s in sessions:
        for lab in s.labels:
            seen[lab.person][lab.gesture].append((str(s.path), lab.start_s))
            if str(s.path) not in bags[lab.person]:
                bags[lab.person].append(str(s.path))
    out = []
    for person in sorted(seen):
        missing = [c for c in classes if c not in seen[person]]
        if missing:
            out.append(f'{person} ({", ".join(bags[person])}) has no trial of {", ".join(missing)}: the model '
                       f'learns {"it" if len(missing) == 1 else "them"} from the others only; record '
                       f'`collect --gestures {",".join(missing)}` for {person}')
        for gesture, where in sorted(seen[person].items()):
            if len(where) == 1:
                out.append(f'{person} has a single trial of {gesture} ({where[0][0]} at {where[0][1]:.2f} s): '
                           'leave-one-person-out scores it on one example')
    return out


def read_checked(paths: list[str], sensor: str, progress: Callable[[str], None]) -> list[SessionRecording]:
    """Read every session bag of ``sensor`` (:func:`~.session_bag.read_sessions`) and say, through
    ``progress``, each bag's warnings and what the set misses (:func:`check_coverage`)."""
    sessions = read_sessions(paths, sensor, progress)
    for warning in check_coverage(sessions):
        progress(f'warning: {warning}')
    return sessions
