"""The bear's three processing paths (knight2009 Fig. 5) run together, one call per scan cycle.

Sensor level (ring buffer, active set) -> touch subtypes (features + classifier, change events) and
symbolic gestures (locational filters + priority logic, START/END events). The ``bear_gestures`` node
is a thin wrapper around this class; the evaluation and the benchmark call it directly.

>>> from touch_driver.bear.body_map import BodyMap
>>> rec = BearRecogniser(rate_hz=3.4)
>>> levels = np.zeros(64, dtype=np.float32); levels[BodyMap.default().by_name('head2').channel] = 0.9
>>> out = rec.update(0.0, levels)
>>> [s.name for s in out.active_sensors], [(c.sensor, c.subtype) for c in out.subtype_changes]
(['head2'], [('head2', 'poke')])
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from touch_driver.bear.body_map import BodyMap

from .candidates import CandidateConfidence
from .features import MIN_COMPONENT, BufferFeatures, FeatureExtractor
from .sensor_level import ACTIVATION_THRESHOLD, BUFFER_LEN, ActiveSensor, LevelBuffer, active_sensors
from .subtype import PaperRuleClassifier, SubtypeChange, SubtypePredictor, SubtypeTracker
from .subtype_labels import SUBTYPES
from .symbolic import GestureLibrary, SymbolicEvent, SymbolicRecogniser

__all__ = ['BearRecogniser', 'CycleResult', 'NamedSubtypeChange']


@dataclass(frozen=True, slots=True)
class NamedSubtypeChange:
    """A subtype change with the sensor's name (what /touch/subtype publishes)."""

    sensor: str
    change: SubtypeChange

    @property
    def subtype(self) -> str:
        return self.change.subtype


@dataclass
class CycleResult:
    """Everything one cycle produced.

    Attributes:
        t: cycle time, s.
        active: (64,) bool, latest level >= threshold (faulty channels never active).
        features: this cycle's :class:`BufferFeatures` ((64, F) float32 table); None when not classifying.
        codes: (64,) int8 subtype codes into SUBTYPES (0 'none' on unfitted channels); None when not classifying.
        confidence: (64,) float32 classifier confidence (1 for the rule); None when not classifying.
        active_sensors: named active sensors (/touch/sensor_level).
        subtype_changes: sensors whose subtype changed (/touch/subtype).
        symbolic_events: gesture CANDIDATE/WITHDRAWN/START/END events (/touch/symbolic).
    """

    t: float
    active: np.ndarray
    features: BufferFeatures | None
    codes: np.ndarray | None
    confidence: np.ndarray | None
    active_sensors: list[ActiveSensor] = field(default_factory=list)
    subtype_changes: list[NamedSubtypeChange] = field(default_factory=list)
    symbolic_events: list[SymbolicEvent] = field(default_factory=list)

    def subtype_of(self, channel: int) -> str:
        return SUBTYPES[int(self.codes[channel])]


class BearRecogniser:
    """Sensor level + touch subtypes + symbolic gestures for the whole bear.

    Args:
        rate_hz: scan rate, cycles/s (knight2009 VI.B: 3.4 Hz real; 25 Hz ideal).
        buffer_len: cycles per sensor buffer (knight2009 V.A: 20).
        threshold: activation threshold (knight2009 V.A: 0.3).
        classifier: the subtype classifier (default: :class:`PaperRuleClassifier` at ``threshold``).
        library: the symbolic gestures (default: ``config/bear_gestures.yaml``).
        body_map: the body map (default: the package's).
        detrend, min_component: feature options, see :mod:`.features`.
        named_outputs: build the named active-sensor list and named changes (off in benchmarks of the maths).
        subtypes: track each sensor's subtype and report its changes (``/touch/subtype``).
        symbolic: run the symbolic gestures (``/touch/symbolic``).
        classify: compute the features and classify every cycle; by default when ``subtypes`` is on or
            a symbolic gesture needs a subtype ("model only what a scene needs": no features otherwise).
        candidate_confidence: the symbolic CANDIDATE confidences (default: ``config/bear_candidates.yaml``).
    """

    def __init__(self, rate_hz: float = 3.4, buffer_len: int = BUFFER_LEN, threshold: float = ACTIVATION_THRESHOLD,
                 classifier: SubtypePredictor | None = None, library: GestureLibrary | None = None,
                 body_map: BodyMap | None = None, detrend: str = 'constant', min_component: float = MIN_COMPONENT,
                 named_outputs: bool = True, subtypes: bool = True, symbolic: bool = True,
                 classify: bool | None = None, candidate_confidence: CandidateConfidence | None = None) -> None:
        body_map = body_map if body_map is not None else BodyMap.default()
        self.body_map = body_map
        self.rate_hz = float(rate_hz)
        self.threshold = float(threshold)
        self.buffer = LevelBuffer(buffer_len, threshold=threshold)
        self.extractor = FeatureExtractor(rate_hz, threshold=threshold, min_component=min_component, detrend=detrend)
        self.extractor.assume_finite = True   # the LevelBuffer has already replaced NaN / inf by 0
        self.classifier = classifier if classifier is not None else PaperRuleClassifier(amplitude_threshold=threshold)
        self.fitted = np.asarray(body_map.fitted_mask(), dtype=bool)
        self._fitted_rows = np.flatnonzero(self.fitted)
        self.tracker = SubtypeTracker(self.fitted)
        if library is None:
            library = GestureLibrary.default(body_map) if symbolic else GestureLibrary([], source='(symbolic off)')
        self.symbolic = SymbolicRecogniser(library, body_map, confidence=candidate_confidence)
        self.track_subtypes = subtypes
        self.run_symbolic = symbolic
        self.classifies = classify if classify is not None else \
            subtypes or (symbolic and any(g.subtypes for g in library.detectable))
        if subtypes and not self.classifies:
            raise ValueError('tracking subtypes needs the features and the classifier: classify=False with '
                             'subtypes=True')
        self.named_outputs = named_outputs
        self._names = {s.channel: s.name for s in body_map.sensors}

    def reset(self) -> None:
        """Forget all history (after a reconnect)."""
        self.buffer.reset()
        self.extractor.reset()
        self.tracker.reset()
        self.symbolic.reset()

    def classify(self, table: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(64,) int8 codes and (64,) float32 confidence for a (64, F) feature table (fitted rows only)."""
        codes = np.zeros(table.shape[0], dtype=np.int8)
        confidence = np.zeros(table.shape[0], dtype=np.float32)
        codes[self._fitted_rows], confidence[self._fitted_rows] = self.classifier.predict_codes(
            table[self._fitted_rows])
        return codes, confidence

    def update(self, t: float, levels: np.ndarray, faulty: np.ndarray | None = None) -> CycleResult:
        """Process one scan: what is configured of the three paths.

        Args:
            t: scan time, s.
            levels: (64,) calibrated levels in [0, 1] (NaN is counted and read as 0).
            faulty: optional (64,) bool from the calibrator (dead / stuck channels read as untouched).
        """
        self.buffer.update(levels, faulty)
        features = codes = confidence = None
        if self.classifies:
            features = self.extractor.update(self.buffer.window())
            codes, confidence = self.classify(features.table)
        active = self.buffer.active() & self.fitted
        changes = self.tracker.update(t, codes, confidence, features.table) if self.track_subtypes else []
        events = self.symbolic.update(t, active, codes) if self.run_symbolic else []
        result = CycleResult(t, active, features, codes, confidence, symbolic_events=events)
        if self.named_outputs:
            result.active_sensors = active_sensors(self.buffer.latest(), self.body_map, self.threshold)
            result.subtype_changes = [NamedSubtypeChange(self._names[c.channel], c) for c in changes]
        return result
