"""The skin recognisers the lab measures ours against, and the lab's registry of every recogniser.

The runtime registry (:mod:`touch_gestures.skin.registry`) holds what a codebook deploys; here are the
others: the peers (:mod:`.peers`), $N (:mod:`.ndollar`), the cloud alone, the cloud refereed by $N
(:mod:`.refereed`), the oriented cloud (:mod:`.oriented`) and ``auto`` (:mod:`.auto`).
:data:`RECOGNISERS` extends the runtime's registry; :func:`make_recogniser`, :func:`load_codebook` and
:func:`save_codebook` are the runtime's over it. A codebook made with a lab recogniser loads here, not
on the robot.

>>> ' '.join(RECOGNISERS)
'static map centroid dollar1 protractor pdollar dtw trace cloud ndollar refereed fused oriented fused_oriented auto'
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from touch_gestures.skin import codebook
from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.registry import DEFAULT_RECOGNISER, MULTISTROKE_RECOGNISER, PAPER, recogniser_from

from .auto import AutoRecogniser
from .registry import CANDIDATES, PEERS

__all__ = ['DEFAULT_RECOGNISER', 'MULTISTROKE_RECOGNISER', 'PAPER', 'PEERS', 'RECOGNISERS', 'AutoRecogniser',
           'load_codebook', 'make_recogniser', 'save_codebook']

#: name -> class, in report order: :data:`.registry.CANDIDATES`, then ``auto``.
RECOGNISERS: dict[str, type[TemplateRecogniser]] = {**CANDIDATES, AutoRecogniser.name: AutoRecogniser}


def make_recogniser(name: str, **params: Any) -> TemplateRecogniser:
    """A new, unfitted recogniser ``name`` (one of :data:`RECOGNISERS`) with ``params``.

    Raises:
        ValueError: unknown name or parameter (with the known ones and a did-you-mean).
    """
    return recogniser_from(RECOGNISERS, name, params)


def load_codebook(path: str | Path, recogniser: str | None = None) -> TemplateRecogniser:
    """:func:`touch_gestures.skin.codebook.load_codebook` of a file made by any recogniser of :data:`RECOGNISERS`."""
    return codebook.load_codebook(path, recogniser, RECOGNISERS)


def save_codebook(path: str | Path, recogniser: TemplateRecogniser, description: str | None = None,
                  vocabulary: str = 'commands', gap_s: float | None = None) -> Path:
    """:func:`touch_gestures.skin.codebook.save_codebook` of any recogniser of :data:`RECOGNISERS`; of ``auto``,
    the recogniser it chose (the file names that one)."""
    if isinstance(recogniser, AutoRecogniser):
        recogniser = recogniser.chosen_
    return codebook.save_codebook(path, recogniser, description, vocabulary, gap_s, RECOGNISERS)
