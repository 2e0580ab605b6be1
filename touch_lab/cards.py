"""What the training commands write into a model card's ``data`` (:mod:`touch_gestures.model_card`)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Iterable

__all__ = ['session_data']


def session_data(labels: Iterable[tuple[str, str]], *, synthetic: bool, bags: list[str] | None = None,
                 source: str = '') -> dict:
    """A card's ``data`` from ``(person, class)`` of every training trial.

    >>> session_data([('p1', 'poke'), ('p2', 'poke'), ('p2', 'hold')], synthetic=True)['trials_per_class']
    {'hold': 1, 'poke': 2}
    """
    rows = list(labels)
    data = {'synthetic': bool(synthetic),
            'source': source or ('session bags from simulated people (social-touch collect --simulate)' if synthetic
                                 else 'recorded session bags (social-touch collect)'),
            'people': len({p for p, _ in rows}), 'trials': len(rows),
            'trials_per_class': dict(sorted(Counter(c for _, c in rows).items()))}
    if bags:
        data['bags'] = [str(b) for b in bags]
    return data
