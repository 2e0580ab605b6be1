"""How often a symbolic gesture's CANDIDATE is confirmed: the confidence it is announced with.

A candidate's *evidence level* when it is announced: 0 when its filter is touched but not matched yet
(fewer than ``min_active`` sensors, one side only, or without the subtype), 1 when it matches, 2 when
it matches with more sensors than ``min_active`` (:data:`MAX_LEVEL`). For every gesture and level the table holds
``[confirmed, candidates]``, counted on a simulated scene by ``social-touch train bear-candidates``;
the confidence is Laplace's rule of succession, ``(confirmed + 1) / (candidates + 2)``: the fraction
confirmed, pulled towards 0.5 when few were seen (0.5 when none were). The table ships as
``config/bear_candidates.yaml`` (format below); a gesture it does not name gets 0.5.

.. code-block:: yaml

    format: 1
    data: synthetic ...           # what the counts come from (free text)
    gestures:
      hug: [[4, 9], [3, 5], [10, 11]]   # [confirmed, candidates] at levels 0, 1, 2
"""

from __future__ import annotations

import json
from pathlib import Path

from touch_graph.paths import share_file
from touch_graph.yamlconf import YamlDict, check_keys, load_yaml, loads_yaml, typed

__all__ = ['MAX_LEVEL', 'CandidateConfidence', 'laplace']

#: Evidence levels: 0 touched, 1 matched, 2 matched with more sensors than ``min_active``.
MAX_LEVEL = 2
FORMAT_VERSION = 1


def laplace(confirmed: int, candidates: int) -> float:
    """Rule of succession: ``(confirmed + 1) / (candidates + 2)``, in (0, 1)."""
    return (confirmed + 1) / (candidates + 2)


class CandidateConfidence:
    """Gesture name -> ``[confirmed, candidates]`` per evidence level (module doc).

    Args:
        counts: gesture -> :data:`MAX_LEVEL` + 1 pairs ``(confirmed, candidates)``.
        source: where the counts come from (a file path), for messages.
        data: what the counts were measured on (free text).
    """

    def __init__(self, counts: dict[str, list[tuple[int, int]]] | None = None, source: str | None = None,
                 data: str = '') -> None:
        self.counts = {name: [tuple(pair) for pair in rows] for name, rows in (counts or {}).items()}
        self.source = source
        self.data = data

    def confidence(self, gesture: str, level: int) -> float:
        """Probability that a candidate of ``gesture`` announced at evidence ``level`` is confirmed."""
        rows = self.counts.get(gesture)
        if rows is None:
            return laplace(0, 0)
        return laplace(*rows[min(max(int(level), 0), MAX_LEVEL)])

    @classmethod
    def default(cls) -> CandidateConfidence:
        """The package's ``config/bear_candidates.yaml`` (no counts when a stripped install lacks it)."""
        path = share_file('config', 'bear_candidates.yaml')
        return cls.load(path) if Path(path).is_file() else cls(source='(no config/bear_candidates.yaml)')

    @classmethod
    def load(cls, path: str | Path) -> CandidateConfidence:
        """Read a table file; ConfigError with file:line on any problem."""
        return cls._from_doc(load_yaml(path), str(path))

    @classmethod
    def loads(cls, text: str, source: str = '<string>') -> CandidateConfidence:
        return cls._from_doc(loads_yaml(text, source), source)

    @classmethod
    def _from_doc(cls, doc: YamlDict, source: str) -> CandidateConfidence:
        what = 'candidate confidence table'
        check_keys(doc, required=('gestures',), optional=('format', 'data'), what=what)
        version = typed(doc, 'format', int, what, default=FORMAT_VERSION)
        if version != FORMAT_VERSION:
            raise doc.error(f'{what} format {version} is not supported; this code reads format {FORMAT_VERSION}',
                            'format')
        gestures = doc['gestures']
        if not isinstance(gestures, dict):
            raise doc.error(f'gestures must map a gesture name to {MAX_LEVEL + 1} pairs [confirmed, candidates]',
                            'gestures')
        counts = {}
        for name, rows in gestures.items():
            ok = isinstance(rows, list) and len(rows) == MAX_LEVEL + 1 and all(
                isinstance(r, list) and len(r) == 2 and all(isinstance(v, int) and not isinstance(v, bool)
                                                            for v in r) and 0 <= r[0] <= r[1] for r in rows)
            if not ok:
                raise gestures.error(f"gesture '{name}': expected {MAX_LEVEL + 1} pairs [confirmed, candidates] of "
                                     f'integers with 0 <= confirmed <= candidates; got {rows!r}', name)
            counts[str(name)] = [(int(a), int(b)) for a, b in rows]
        return cls(counts, source, typed(doc, 'data', str, what, default=''))

    def dumps(self) -> str:
        """The table as YAML text (the format :meth:`loads` reads)."""
        lines = [f'format: {FORMAT_VERSION}', f'data: {json.dumps(self.data)}' if self.data else '', 'gestures:']
        for name, rows in self.counts.items():
            lines.append(f'  {name}: [{", ".join(f"[{a}, {b}]" for a, b in rows)}]')
        return '\n'.join(line for line in lines if line) + '\n'
