"""The first line of the paper's rule in front of any subtype classifier: "If (amplitude < 30%) NoTouch".

knight2009 V.D's pseudocode decides "no touch" from the buffer's peak amplitude before anything else.
The trained model (:mod:`.subtype_model`) has no such step and never saw buffers the recogniser only
has right after it starts (or restarts): fewer than ``buffer_len`` cycles, none of them touched. On
those it answers 'tap' for every sensor (a short buffer looks like a touch that has just left it),
and a node would publish a burst of false taps at startup. :class:`NoTouchGate` keeps every sensor
whose buffer never reached the threshold at 'none', whatever the classifier says; a buffer that holds
a touch is left to the classifier.

>>> class AlwaysTap:
...     def predict_codes(self, X):
...         return np.full(len(X), 6, dtype=np.int8), np.full(len(X), 0.4, dtype=np.float32)
>>> X = np.zeros((2, len(FEATURE_NAMES)), dtype=np.float32); X[1, 0] = 0.8   # peak amplitude 0 and 0.8
>>> codes, confidence = NoTouchGate(AlwaysTap()).predict_codes(X)
>>> codes.tolist(), confidence.tolist()
([0, 6], [1.0, 0.4000000059604645])
"""

from __future__ import annotations

import numpy as np

from .features import FEATURE_NAMES
from .sensor_level import ACTIVATION_THRESHOLD
from .subtype import check_feature_table

__all__ = ['NoTouchGate']

_PEAK = FEATURE_NAMES.index('peak_amplitude')


class NoTouchGate:
    """Wrap ``classifier`` (anything with ``predict_codes(X)``): rows with peak amplitude < ``threshold`` are 'none'.

    Args:
        classifier: its ``predict_codes(X)`` returns ((n,) int8 codes, (n,) float32 confidence).
        threshold: activation threshold, level 0..1 (knight2009 V.A / V.D: 0.3).
    """

    def __init__(self, classifier, threshold: float = ACTIVATION_THRESHOLD) -> None:
        if not 0.0 < float(threshold) <= 1.0:
            raise ValueError(f'threshold must be in (0, 1] (a level fraction, the paper uses 0.3); got {threshold!r}')
        self.classifier = classifier
        self.threshold = float(threshold)

    @property
    def classes_(self):
        return self.classifier.classes_

    def predict_codes(self, X) -> tuple[np.ndarray, np.ndarray]:
        """(n,) int8 codes into SUBTYPES and (n,) float32 confidence (1 where the gate decided)."""
        X = check_feature_table(X)
        codes, confidence = self.classifier.predict_codes(X)
        quiet = X[:, _PEAK] < self.threshold
        return (np.where(quiet, 0, codes).astype(np.int8),
                np.where(quiet, np.float32(1.0), confidence).astype(np.float32))
