"""Haptic commands traced on the optoelectronic skin (cirillo2017 3): pure parts and evaluation.

- :mod:`.segmentation`: :class:`GestureSegmenter`, calibrated frames -> :class:`TouchGesture`.
- :mod:`.paper`: the paper's three recognisers (static eq. 2, map-based Algorithm 1,
  centroid-based Algorithm 2); ours: :mod:`.proposed` (:class:`TraceRecogniser`, single-stroke
  vocabularies) and :mod:`.fused` (:class:`FusedRecogniser`: :mod:`.clouds` and the trace, multi-stroke
  ones), chosen by measurement (docs/skin-evaluation.md, docs/skin-multistroke.md); :mod:`.registry`
  names them. All share :class:`~.base.TemplateRecogniser` (``fit(gestures, labels)``,
  ``predict(gesture) -> Match``).
- :mod:`.codebook`: codebook files (.npz, no pickle) and the recorder; :mod:`.commands`: the
  gesture -> command map and the HapticCommand message.
- On the graph: :mod:`.node` (``haptic_commands``: /skin/frame -> /touch/haptic_command), with
  :mod:`.frames` (SkinFrame messages -> gestures) and :mod:`.screening` (touches that are no
  gesture). These are not imported here: importing the package stays free of graph code.

Synthetic traces, simulated people and rendering through the virtual skin are in
:mod:`touch_sim.skin`; the evaluation, the benchmark, the reports, the codebook recorder CLI and the
recognisers ours are measured against (:mod:`touch_lab.skin.recognisers`) in :mod:`touch_lab.skin`.
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
