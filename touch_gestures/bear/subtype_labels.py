"""Names of the bear's touch subtypes (knight2009 Table I), shared by classifiers, simulator and evaluation.

>>> SUBTYPES[:4], subtype_index('none'), subtype_index('rub')
(('none', 'pet', 'poke', 'tickle'), 0, 8)
"""

from __future__ import annotations

__all__ = ['NONE', 'RULE_SUBTYPES', 'SUBTYPES', 'TOUCH_SUBTYPES', 'subtype_index']

NONE = 'none'
#: Table I's eight touch subtypes, in the table's order.
TOUCH_SUBTYPES = ('pet', 'poke', 'tickle', 'pat', 'hold', 'tap', 'shake', 'rub')
#: Every label a sensor can carry: 'none' (Table II's "No Touch") then the eight subtypes.
SUBTYPES = (NONE, *TOUCH_SUBTYPES)
#: What the paper's V.D rule can output (the implemented subtypes of Table I, plus no touch).
RULE_SUBTYPES = (NONE, 'poke', 'tickle', 'pet', 'hold')

_INDEX = {name: i for i, name in enumerate(SUBTYPES)}


def subtype_index(name: str) -> int:
    """Index of ``name`` in :data:`SUBTYPES`; ValueError naming the choices otherwise."""
    try:
        return _INDEX[name]
    except KeyError:
        raise ValueError(f'unknown touch subtype {name!r}; expected one of: {", ".join(SUBTYPES)}') from None
