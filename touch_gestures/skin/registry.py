"""The skin recognisers a codebook can deploy, by name: the CLI, codebook files and the node.

The paper's three (cirillo2017: the specification) and ours that ship as defaults: ``trace``
for single-stroke vocabularies and ``fused`` for multi-stroke ones. The recognisers they are
measured against (the peers, $N, the oriented cloud...) and ``auto``, which picks between
``trace`` and ``fused`` while a codebook is made, are the lab's
(:mod:`touch_lab.skin.recognisers`, whose registry extends this one).

>>> ' '.join(RECOGNISERS)
'static map centroid trace fused'
>>> make_recogniser('trace', n_points=16).n_points
16
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from touch_graph.yamlconf import did_you_mean

from .base import TemplateRecogniser
from .fused import FusedRecogniser
from .paper import CentroidRecogniser, MapRecogniser, StaticRecogniser
from .proposed import TraceRecogniser

__all__ = ['DEFAULT_RECOGNISER', 'MULTISTROKE_RECOGNISER', 'PAPER', 'RECOGNISERS', 'make_recogniser',
           'recogniser_from']

#: name -> class, in report order: the paper's three, then ours (single-stroke, multi-stroke).
RECOGNISERS: dict[str, type[TemplateRecogniser]] = {
    cls.name: cls for cls in (StaticRecogniser, MapRecogniser, CentroidRecogniser, TraceRecogniser, FusedRecogniser)
}
PAPER = ('static', 'map', 'centroid')
#: the recogniser of a single-stroke vocabulary, chosen by measurement (docs/skin-evaluation.md)
DEFAULT_RECOGNISER = 'trace'
#: the recogniser of a multi-stroke vocabulary (docs/skin-multistroke.md)
MULTISTROKE_RECOGNISER = 'fused'
#: What to tell someone who names a recogniser this registry does not hold.
_LAB_HINT = ('the recognisers measured against these (the peers, $N, refereed, oriented, fused_oriented, auto...) '
             'are the lab\'s: touch_lab.skin.recognisers')


def recogniser_from(registry: Mapping[str, type[TemplateRecogniser]], name: str,
                    params: Mapping[str, Any]) -> TemplateRecogniser:
    """A new, unfitted recogniser ``name`` of ``registry`` with ``params``.

    Raises:
        ValueError: unknown name or parameter (with the known ones and a did-you-mean).
    """
    cls = registry.get(name)
    if cls is None:
        hint = f' ({_LAB_HINT})' if registry is RECOGNISERS else ''
        raise ValueError(f'unknown recogniser {name!r}; known: {", ".join(registry)}'
                         f'{did_you_mean(name, registry)}{hint}')
    known = cls().get_params()
    for key in params:
        if key not in known:
            raise ValueError(f'recogniser {name!r} has no parameter {key!r}; its parameters are: '
                             f'{", ".join(known)}{did_you_mean(key, known)}')
    return cls(**params)


def make_recogniser(name: str, **params: Any) -> TemplateRecogniser:
    """A new, unfitted recogniser ``name`` (one of :data:`RECOGNISERS`) with ``params``.

    Raises:
        ValueError: unknown name or parameter (with the known ones and a did-you-mean).
    """
    return recogniser_from(RECOGNISERS, name, params)
