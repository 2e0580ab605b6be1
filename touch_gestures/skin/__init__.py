"""Haptic commands traced on the optoelectronic skin (cirillo2017 3).

- :mod:`.segmentation`: :class:`GestureSegmenter`, calibrated frames -> :class:`TouchGesture`.
- Recognisers, all :class:`~.base.TemplateRecogniser` (``fit(gestures, labels)``,
  ``predict(gesture) -> Match``), named in :mod:`.registry`: the paper's three (:mod:`.paper`),
  :mod:`.proposed` (:class:`TraceRecogniser`, single-stroke vocabularies) and :mod:`.fused`
  (:class:`FusedRecogniser`: :mod:`.clouds` and the trace, multi-stroke ones).
- :mod:`.codebook`: codebook files and the recorder; :mod:`.commands`: the gesture -> command map.
- On the graph: :mod:`.node` (``haptic_commands``), with :mod:`.frames` and :mod:`.screening`; not
  imported here, so importing the package stays free of graph code.

Simulated people and rendering are in :mod:`touch_sim.skin`; evaluation, benchmarks, reports and
the recognisers ours are measured against in :mod:`touch_lab.skin`.
"""

from .base import Match, TemplateRecogniser
from .codebook import CodebookRecorder, load_codebook, save_codebook
from .commands import COMMAND_TOPIC, CommandMap, haptic_command, load_command_map
from .fused import FusedRecogniser
from .gesture import TouchGesture
from .paper import CentroidRecogniser, MapRecogniser, StaticRecogniser
from .proposed import TraceRecogniser
from .registry import DEFAULT_RECOGNISER, RECOGNISERS, make_recogniser
from .segmentation import GestureSegmenter, SegmenterStats

__all__ = [
    'COMMAND_TOPIC', 'DEFAULT_RECOGNISER', 'RECOGNISERS', 'CentroidRecogniser', 'CodebookRecorder', 'CommandMap',
    'FusedRecogniser', 'GestureSegmenter', 'MapRecogniser', 'Match', 'SegmenterStats', 'StaticRecogniser',
    'TemplateRecogniser', 'TouchGesture', 'TraceRecogniser', 'haptic_command', 'load_codebook', 'load_command_map',
    'make_recogniser', 'save_codebook',
]
