"""The protocol of a recording session: which gestures, in which variants, how often, in what order.

As in the papers' data sets (sympartner2018 6.3: every person performs every class; CoST: gentle,
normal and rough variants of every gesture), a session asks one person for every gesture in every
variant ``repetitions`` times, shuffled so that no class always follows another. The order is
drawn from the seed, so a session can be repeated exactly.

>>> p = Protocol(('stroke', 'slap'), variants=('gentle', 'rough'), repetitions=2, seed=1)
>>> len(p.trials()), sorted({(t.gesture, t.variant) for t in p.trials()})[:2]
(8, [('slap', 'gentle'), ('slap', 'rough')])
>>> p.trials() == p.trials()
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ['DEFAULT_GESTURES', 'SENSORS', 'VARIANT_SCALES', 'Protocol', 'Trial']

#: The sensors a session records.
SENSORS = ('bear', 'patch', 'skin')

#: What each sensor's recogniser learns from a session, by default.
DEFAULT_GESTURES: dict[str, tuple[str, ...]] = {
    'bear': ('poke', 'pat', 'tickle', 'pet', 'hold', 'tap', 'shake', 'rub'),   # knight2009 Table I
    'patch': ('stroke', 'tickle', 'push', 'slap'),                              # sympartner2018 6.3
    # cirillo2017 Fig. 7-8: the gestures of config/skin_commands.yaml (the node wants a template of each)
    'skin': ('diagonal_down', 'diagonal_up', 'line_right', 'line_left', 'one', 'two', 'line_down', 'line_up'),
}

#: How hard a variant is performed by the simulated people, times their usual force (CoST's variants).
VARIANT_SCALES: dict[str, float] = {'gentle': 0.6, 'normal': 1.0, 'rough': 1.4}


@dataclass(frozen=True)
class Trial:
    """One prompt of the protocol: perform ``gesture`` the ``variant`` way (``repetition`` counts from 1)."""

    gesture: str
    variant: str
    repetition: int

    @property
    def prompt(self) -> str:
        """What the operator reads out, e.g. ``'stroke (gentle)'``."""
        return f'{self.gesture} ({self.variant})' if self.variant else self.gesture


@dataclass(frozen=True)
class Protocol:
    """Gestures x variants x repetitions, shuffled.

    Args:
        gestures: the classes to perform (at least two: a recogniser tells classes apart).
        variants: ways of performing each (``('normal',)`` for none).
        repetitions: trials per gesture and variant (>= 1).
        pause_s: seconds between trials (the operator's pause; the simulation draws around it).
        seed: the order's randomness.

    Raises:
        ValueError: fewer than two gestures, a repeated name, no variant, repetitions < 1, a bad pause.
    """

    gestures: tuple[str, ...]
    variants: tuple[str, ...] = ('normal',)
    repetitions: int = 3
    pause_s: float = 4.0
    seed: int = 0

    def __post_init__(self) -> None:
        if len(self.gestures) < 2 or len(set(self.gestures)) != len(self.gestures):
            raise ValueError(f'a protocol needs at least two different gestures; got {list(self.gestures)}')
        if not self.variants or len(set(self.variants)) != len(self.variants):
            raise ValueError(f'variants must be different names, at least one; got {list(self.variants)}')
        if int(self.repetitions) != self.repetitions or self.repetitions < 1:
            raise ValueError(f'repetitions must be an integer >= 1; got {self.repetitions}')
        if not (math.isfinite(self.pause_s) and self.pause_s >= 0):
            raise ValueError(f'pause_s must be >= 0 s; got {self.pause_s}')

    def trials(self) -> list[Trial]:
        """Every trial, shuffled (the same order for the same seed)."""
        todo = [Trial(g, v, r + 1) for g in self.gestures for v in self.variants for r in range(self.repetitions)]
        order = np.random.default_rng((self.seed, 0xC011)).permutation(len(todo))
        return [todo[i] for i in order]

    def scale(self, variant: str) -> float:
        """The force (or amplitude) factor of ``variant`` for simulated people (1 for unknown names)."""
        return VARIANT_SCALES.get(variant, 1.0)
