"""Every skin recogniser the lab measures, but ``auto``: the runtime's and those measured against them.

``auto`` (:mod:`.auto`) chooses among these by name; :mod:`touch_lab.skin.recognisers` adds it.
"""

from __future__ import annotations

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.registry import RECOGNISERS as RUNTIME

from .ndollar import NDollarRecogniser
from .oriented import OrientedCloudRecogniser, OrientedFusedRecogniser
from .peers import DollarOneRecogniser, DTWRecogniser, PointCloudRecogniser, ProtractorRecogniser
from .refereed import RefereedRecogniser

__all__ = ['CANDIDATES', 'PEERS']

_LAB = {cls.name: cls for cls in (DollarOneRecogniser, ProtractorRecogniser, PointCloudRecogniser, DTWRecogniser,
                                  CloudRecogniser, NDollarRecogniser, RefereedRecogniser, OrientedCloudRecogniser,
                                  OrientedFusedRecogniser)}
#: name -> class, in report order: the paper's three, the peers, ours (single-stroke, the cloud, $N, the cloud
#: refereed by $N, the cloud and the trace summed, the oriented cloud alone and summed with the trace).
CANDIDATES: dict[str, type[TemplateRecogniser]] = {
    name: ({**RUNTIME, **_LAB})[name]
    for name in ('static', 'map', 'centroid', 'dollar1', 'protractor', 'pdollar', 'dtw', 'trace', 'cloud', 'ndollar',
                 'refereed', 'fused', 'oriented', 'fused_oriented')}
PEERS = ('dollar1', 'protractor', 'pdollar', 'dtw')
