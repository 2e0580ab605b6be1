"""Every skin recogniser by name, for the CLI, codebook files and the evaluation.

>>> ' '.join(sorted(RECOGNISERS))
'auto centroid cloud dollar1 dtw fused fused_oriented map ndollar oriented pdollar protractor refereed static trace'
>>> make_recogniser('trace', n_points=16).n_points
16
"""

from __future__ import annotations

from typing import Any

from .base import TemplateRecogniser
from .clouds import CloudRecogniser
from .fused import FusedRecogniser
from .ndollar import NDollarRecogniser
from .oriented import OrientedCloudRecogniser, OrientedFusedRecogniser
from .paper import CentroidRecogniser, MapRecogniser, StaticRecogniser
from .peers import DollarOneRecogniser, DTWRecogniser, PointCloudRecogniser, ProtractorRecogniser
from .proposed import TraceRecogniser
from .referee import RefereedRecogniser
from .vocabulary import AutoRecogniser

__all__ = ['DEFAULT_RECOGNISER', 'PAPER', 'PEERS', 'RECOGNISERS', 'make_recogniser']

#: name -> class, in report order: the paper's three, the peers, ours (single-stroke, multi-stroke, $N, the
#: cloud refereed by $N, the cloud and the trace summed, and ``auto``: whichever of the two the vocabulary's
#: codebook needs, :mod:`.vocabulary`).
RECOGNISERS: dict[str, type[TemplateRecogniser]] = {
    cls.name: cls for cls in (StaticRecogniser, MapRecogniser, CentroidRecogniser, DollarOneRecogniser,
                              ProtractorRecogniser, PointCloudRecogniser, DTWRecogniser, TraceRecogniser,
                              CloudRecogniser, NDollarRecogniser, RefereedRecogniser, FusedRecogniser,
                              OrientedCloudRecogniser, OrientedFusedRecogniser, AutoRecogniser)
}
PAPER = ('static', 'map', 'centroid')
PEERS = ('dollar1', 'protractor', 'pdollar', 'dtw')
#: the recogniser chosen by measurement (docs/skin-evaluation.md)
DEFAULT_RECOGNISER = 'trace'


def make_recogniser(name: str, **params: Any) -> TemplateRecogniser:
    """A new, unfitted recogniser ``name`` with ``params``.

    Raises:
        ValueError: unknown name or parameter (with the known ones and a did-you-mean).
    """
    from touch_graph.yamlconf import did_you_mean

    cls = RECOGNISERS.get(name)
    if cls is None:
        raise ValueError(f'unknown recogniser {name!r}; known: {", ".join(RECOGNISERS)}'
                         f'{did_you_mean(name, RECOGNISERS)}')
    known = cls().get_params()
    for key in params:
        if key not in known:
            raise ValueError(f'recogniser {name!r} has no parameter {key!r}; its parameters are: '
                             f'{", ".join(known)}{did_you_mean(key, known)}')
    return cls(**params)
