"""Touch subtypes on one sensor (knight2009 V.D, Tables I and II): the paper's rule and change events.

:class:`PaperRuleClassifier` is the V.D pseudocode, the baseline the trainable model
(:mod:`.subtype_model`) has to beat::

    If (amplitude < 30%) NoTouch
    Else { Increment duration;
           If (duration < 3 sec) Poke
           Else { ref_var = Alpha x baseFreq + Beta x noiseLevel
                  If (ref_var > tickle_cutoff) Tickle  else if (ref_var > pet_cutoff) Pet  else Hold } }

Both classifiers take rows of the feature table of :mod:`.features` (``X``: (n_samples,
len(FEATURE_NAMES)) float) and their ``predict_codes(X)`` returns ``(codes, confidence)``: (n_samples,)
int8 subtype codes, indices into :data:`~.subtype_labels.SUBTYPES`, and (n_samples,) float32
confidence in [0, 1] (1 for the rule, which is always sure). :class:`SubtypeTracker` keeps one
subtype per sensor and turns the per-cycle codes into change events (msg/TouchSubtype.msg: published
when a sensor's subtype changes, including back to 'none').

>>> rule = PaperRuleClassifier()
>>> X = np.zeros((4, len(FEATURE_NAMES)), dtype=np.float32)
>>> X[:, 0] = [0.1, 0.9, 0.9, 0.9]                       # peak amplitude
>>> X[:, 3] = [0.0, 1.0, 5.0, 5.0]                       # duration, s
>>> X[:, 1] = [0.0, 0.0, 7.0, 0.0]                       # base frequency, Hz
>>> codes, confidence = rule.predict_codes(X)
>>> [SUBTYPES[c] for c in codes], confidence.tolist()
(['none', 'poke', 'tickle', 'hold'], [1.0, 1.0, 1.0, 1.0])
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .features import FEATURE_NAMES
from .subtype_labels import RULE_SUBTYPES, SUBTYPES, subtype_index

__all__ = ['PaperRuleClassifier', 'SubtypeChange', 'SubtypePredictor', 'SubtypeTracker', 'check_feature_table']

_NONE, _POKE, _TICKLE, _PET, _HOLD = (subtype_index(s) for s in ('none', 'poke', 'tickle', 'pet', 'hold'))


def check_feature_table(X, what: str = 'X') -> np.ndarray:
    """``X`` as a 2-D float array with one column per feature of :data:`FEATURE_NAMES`.

    NaN and inf become 0 (no touch), so bad rows give 'none' rather than an exception.
    """
    arr = np.asarray(X, dtype=np.float32)
    if arr.ndim != 2 or arr.shape[1] != len(FEATURE_NAMES):
        raise ValueError(f'{what} must have shape (n_samples, {len(FEATURE_NAMES)}) with columns '
                         f'{", ".join(FEATURE_NAMES)}; got shape {arr.shape}')
    if not np.isfinite(arr).all():
        arr = np.nan_to_num(arr, nan=0.0, posinf=0.0, neginf=0.0)
    return arr


class SubtypePredictor(Protocol):
    """What classifies subtypes: :class:`PaperRuleClassifier`, ``SubtypeModel``, ``NoTouchGate``."""

    def predict_codes(self, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n_samples, n_features) feature rows -> ((n,) int8 codes into SUBTYPES, (n,) float32 confidence)."""


class PaperRuleClassifier:
    """The touch-subtype rule of knight2009 V.D, with every constant a parameter.

    Defaults, from the paper and its Table II:

    - ``amplitude_threshold = 0.3``: "If (amplitude < 30%) NoTouch" (V.D; also V.A's activation).
    - ``poke_max_s = 3.0``: "If (duration < 3 sec) Poke" (V.D); Table II's poke lasts 1 s (σ 0.2 s).
    - ``alpha = 1.0`` (per Hz of base frequency) and ``beta = 1.0`` (per Hz of spectral spread): the paper
      gives no values; with both 1, ``ref`` is in Hz and Table II's two separating features count equally.
    - ``pet_cutoff = 0.25`` Hz: between hold's base frequency (0 Hz, σ 0) and the lowest pet (0.5 Hz of
      "0.5-2 Hz"); half of 0.5 Hz.
    - ``tickle_cutoff = 3.5`` Hz: midway between the highest pet (2 Hz) and the lowest tickle (5 Hz of
      "5-10 Hz"), Table II.

    ``fit(X, y)`` is optional: with ``tune_cutoffs=True`` it grid-searches the two cutoffs on labelled
    rows (those whose label the rule can output) and stores them as ``tickle_cutoff_`` and
    ``pet_cutoff_``; otherwise the defaults above are used as they are.
    """

    classes_ = np.array(RULE_SUBTYPES)

    def __init__(self, amplitude_threshold: float = 0.3, poke_max_s: float = 3.0, alpha: float = 1.0,
                 beta: float = 1.0, tickle_cutoff: float = 3.5, pet_cutoff: float = 0.25,
                 tune_cutoffs: bool = False) -> None:
        self.amplitude_threshold = amplitude_threshold
        self.poke_max_s = poke_max_s
        self.alpha = alpha
        self.beta = beta
        self.tickle_cutoff = tickle_cutoff
        self.pet_cutoff = pet_cutoff
        self.tune_cutoffs = tune_cutoffs

    def get_params(self, deep: bool = True) -> dict:
        return {k: getattr(self, k) for k in ('amplitude_threshold', 'poke_max_s', 'alpha', 'beta', 'tickle_cutoff',
                                             'pet_cutoff', 'tune_cutoffs')}

    def set_params(self, **params) -> PaperRuleClassifier:
        for key, value in params.items():
            if key not in self.get_params():
                raise ValueError(f'invalid parameter {key!r} for PaperRuleClassifier')
            setattr(self, key, value)
        return self

    def _cutoffs(self) -> tuple[float, float]:
        return (getattr(self, 'tickle_cutoff_', self.tickle_cutoff), getattr(self, 'pet_cutoff_', self.pet_cutoff))

    def reference(self, X) -> np.ndarray:
        """(n_samples,) ``ref_var = alpha * baseFreq + beta * noiseLevel`` in Hz (with the defaults)."""
        X = check_feature_table(X)
        return self.alpha * X[:, 1] + self.beta * X[:, 2]

    def predict_codes(self, X) -> tuple[np.ndarray, np.ndarray]:
        """(n_samples,) int8 codes into SUBTYPES (none, poke, tickle, pet or hold) and (n_samples,) float32
        confidence, 1 everywhere (a rule has no doubt)."""
        codes = self._rule_codes(check_feature_table(X))
        return codes, np.ones(codes.shape, dtype=np.float32)

    def _rule_codes(self, X: np.ndarray) -> np.ndarray:
        tickle_cut, pet_cut = self._cutoffs()
        ref = self.alpha * X[:, 1] + self.beta * X[:, 2]
        long_touch = np.where(ref > tickle_cut, _TICKLE, np.where(ref > pet_cut, _PET, _HOLD))
        touched = np.where(X[:, 3] < self.poke_max_s, _POKE, long_touch)
        return np.where(X[:, 0] < self.amplitude_threshold, _NONE, touched).astype(np.int8)

    def predict(self, X) -> np.ndarray:
        """(n_samples,) subtype names."""
        return np.asarray(SUBTYPES, dtype=object)[self.predict_codes(X)[0]]

    def fit(self, X, y) -> PaperRuleClassifier:
        """Optionally tune the two cutoffs (``tune_cutoffs=True``) by grid search on rows with a rule label."""
        X = check_feature_table(X)
        y = np.asarray(y)
        if y.shape != (X.shape[0],):
            raise ValueError(f'y must have shape ({X.shape[0]},); got {y.shape}')
        if not self.tune_cutoffs:
            return self
        codes = np.array([subtype_index(v) if isinstance(v, str) else int(v) for v in y])
        keep = np.isin(codes, [subtype_index(s) for s in RULE_SUBTYPES])
        long_rows = keep & (X[:, 0] >= self.amplitude_threshold) & (X[:, 3] >= self.poke_max_s)
        if not long_rows.any():
            raise ValueError('no labelled row is a long touch (amplitude >= threshold and duration >= poke_max_s); '
                             'cannot tune the cutoffs')
        ref = self.alpha * X[long_rows, 1] + self.beta * X[long_rows, 2]
        truth = codes[long_rows]
        grid = np.unique(np.concatenate([np.quantile(ref, np.linspace(0, 1, 41)), [0.0]]))
        best = (-1.0, self.tickle_cutoff, self.pet_cutoff)
        for pet_cut in grid:
            for tickle_cut in grid[grid >= pet_cut]:
                pred = np.where(ref > tickle_cut, _TICKLE, np.where(ref > pet_cut, _PET, _HOLD))
                # balanced accuracy over the long-touch classes present, so hold cannot swamp the rest
                score = np.mean([np.mean(pred[truth == c] == c) for c in (_TICKLE, _PET, _HOLD) if (truth == c).any()])
                if score > best[0]:
                    best = (score, float(tickle_cut), float(pet_cut))
        self.tickle_cutoff_, self.pet_cutoff_ = best[1], best[2]
        return self


@dataclass(frozen=True, slots=True)
class SubtypeChange:
    """A sensor's subtype changed (msg/TouchSubtype.msg).

    ``features`` is that sensor's (len(FEATURE_NAMES),) float32 row; ``t`` the cycle time, s.
    """

    t: float
    channel: int
    subtype: str
    previous: str
    confidence: float
    features: np.ndarray


class SubtypeTracker:
    """One subtype per sensor ("only one subtype can be active on each single sensor board", knight2009
    V.A), reporting changes.

    Args:
        fitted: (64,) bool, channels to report (unfitted channels never produce events).
    """

    def __init__(self, fitted: np.ndarray) -> None:
        self.fitted = np.asarray(fitted, dtype=bool).copy()
        self.current = np.zeros(self.fitted.shape[0], dtype=np.int8)   # all 'none'

    def reset(self) -> None:
        self.current.fill(0)

    def update(self, t: float, codes: np.ndarray, confidence: np.ndarray | None = None,
               features: np.ndarray | None = None) -> list[SubtypeChange]:
        """Record this cycle's (64,) codes; return the changes, in channel order."""
        codes = np.asarray(codes, dtype=np.int8)
        changed = np.flatnonzero((codes != self.current) & self.fitted)
        out = []
        for ch in changed:
            out.append(SubtypeChange(
                t, int(ch), SUBTYPES[codes[ch]], SUBTYPES[self.current[ch]],
                1.0 if confidence is None else float(confidence[ch]),
                np.zeros(len(FEATURE_NAMES), np.float32) if features is None else features[ch].copy()))
        self.current = np.where(self.fitted, codes, 0).astype(np.int8)
        return out

    def labels(self) -> dict[int, str]:
        """Channel -> current subtype, for channels that are not 'none'."""
        return {int(ch): SUBTYPES[self.current[ch]] for ch in np.flatnonzero(self.current != 0)}


