"""Haptic commands traced on the optoelectronic skin (cirillo2017 3): pure parts and evaluation.

- :mod:`.segmentation`: :class:`GestureSegmenter`, calibrated frames -> :class:`TouchGesture`.
- :mod:`.paper`: the paper's three recognisers (static eq. 2, map-based Algorithm 1,
  centroid-based Algorithm 2); :mod:`.peers`: $1, Protractor, $P, DTW; :mod:`.proposed`:
  :class:`TraceRecogniser`, chosen by measurement (docs/skin-evaluation.md). All share
  :class:`~.base.TemplateRecogniser` (``fit(gestures, labels)``, ``predict(gesture) -> Match``).
- :mod:`.codebook`: codebook files (.npz, no pickle) and the recorder; :mod:`.commands`: the
  gesture -> command map and the HapticCommand message.
- On the graph: :mod:`.node` (``haptic_commands``: /skin/frame -> /touch/haptic_command), with
  :mod:`.frames` (SkinFrame messages -> gestures) and :mod:`.screening` (touches that are no
  gesture). These are not imported here: importing the package stays free of graph code.

Synthetic traces, simulated people and rendering through the virtual skin are in
:mod:`touch_sim.skin`; the evaluation, the benchmark, the reports and the codebook recorder CLI in
:mod:`touch_lab.skin`.
"""

from .base import Match, TemplateRecogniser
from .codebook import CodebookRecorder, load_codebook, save_codebook
from .commands import COMMAND_TOPIC, CommandMap, haptic_command, load_command_map
from .gesture import TouchGesture
from .paper import CentroidRecogniser, MapRecogniser, StaticRecogniser
from .peers import DollarOneRecogniser, DTWRecogniser, PointCloudRecogniser, ProtractorRecogniser
from .proposed import TraceRecogniser
from .registry import DEFAULT_RECOGNISER, RECOGNISERS, make_recogniser
from .segmentation import GestureSegmenter, SegmenterStats

__all__ = [
    'COMMAND_TOPIC', 'DEFAULT_RECOGNISER', 'RECOGNISERS', 'CentroidRecogniser', 'CodebookRecorder', 'CommandMap',
    'DTWRecogniser', 'DollarOneRecogniser', 'GestureSegmenter', 'MapRecogniser', 'Match', 'PointCloudRecogniser',
    'ProtractorRecogniser', 'SegmenterStats', 'StaticRecogniser', 'TemplateRecogniser', 'TouchGesture',
    'TraceRecogniser', 'haptic_command', 'load_codebook', 'load_command_map', 'make_recogniser', 'save_codebook',
]
