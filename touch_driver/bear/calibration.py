"""Sensate Bear calibration: raw 10-bit counts -> levels 0..1, activation, sensor faults.

knight2009 scales each sensor "to use the full ground to supply voltage range" (V.A) and
marks a sensor active when "the signal is over 30% on" (V.A). Here each fitted channel
has a baseline (the untouched count) and a gain (1 / counts from baseline to full
scale unless configured), so::

    level  = clip((raw - baseline) * gain, 0, 1)          float32, unitless
    active = level >= threshold                           threshold 0.3 (knight2009 V.A)

The baseline comes from configuration or is learned from an untouched start: the
median of each channel's first ``baseline_frames`` valid samples (the median tolerates
a brief touch during start-up). Afterwards it follows slow drift (temperature, humidity
in the fur) with an exponential filter of time constant ``drift_tau_s``, frozen on any
channel whose level is at or above ``drift_freeze_level``, so a touch is never learned.

Sensor faults are detected per channel and reported as a bit mask:

- ``FAULT_DEAD``: stuck at 0 counts (open electrode, broken wire) for ``fault_after_s``;
- ``FAULT_SATURATED``: stuck at full scale (1023) for ``saturated_after_s`` (5 min). A real
  direct touch saturates too (knight2009 IV.D) and, clipped, is as constant as a shorted
  sensor, so only the duration tells them apart: the default is far above the holds of
  knight2009 Table II (4-20 s) but a hug held longer than that would be flagged;
- ``FAULT_STUCK``: no variation at all (peak-to-peak <= ``stuck_tolerance``) elsewhere;
- ``FAULT_INVALID``: this frame's sample was NaN, infinite or outside 0..1023.

With ``mask_faults`` (default) a faulty channel reads level 0 and inactive until it moves
again, so a stuck-high sensor does not look like an endless hold to the recognisers.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from touch_driver.bear.body_map import N_CHANNELS, BodyMap
from touch_driver.bear.protocol import ADC_MAX
from touch_graph.errors import ConfigError
from touch_graph.yamlconf import YamlDict, check_keys, load_yaml, typed

__all__ = ['FAULT_DEAD', 'FAULT_INVALID', 'FAULT_SATURATED', 'FAULT_STUCK', 'BearCalibrator', 'BearLevels']

FAULT_DEAD = 1
FAULT_STUCK = 2
FAULT_SATURATED = 4
FAULT_INVALID = 8


@dataclass(frozen=True, slots=True)
class BearLevels:
    """One calibrated scan; every array is (64,) and indexed by wire channel.

    Attributes:
        raw: uint16 counts as received (0 where the sample was invalid).
        level: float32 in [0, 1]; 0 on unfitted, not yet calibrated or masked faulty channels.
        active: bool, level >= threshold.
        fitted: bool, a sensor is fitted on the channel.
        faults: uint8 bit mask of FAULT_* flags.
        ready: True once every fitted channel has a baseline.
    """

    raw: np.ndarray
    level: np.ndarray
    active: np.ndarray
    fitted: np.ndarray
    faults: np.ndarray
    ready: bool


class BearCalibrator:
    """Per-channel baseline and gain, activation threshold and fault detection.

    Args:
        fitted: (64,) bool of fitted channels, or a :class:`BodyMap`; default the package's body map.
        baseline: (64,) counts, or a scalar; None learns it from the first ``baseline_frames``.
        gain: (64,) or scalar, level per count; None (or NaN entries) gives 1 / (full_scale - baseline).
        threshold: activation level, 0.3 ("over 30% on", knight2009 V.A).
        baseline_frames: valid samples per channel whose median is the learned baseline.
        rate_hz: scan rate, to turn the seconds below into frames (3.4 Hz real, knight2009 VI.B).
        drift_tau_s: time constant of baseline drift tracking in seconds; None or 0 turns it off.
        drift_freeze_level: no tracking on a channel whose level is at or above this.
        fault_after_s: seconds without any variation before a channel is flagged dead or stuck.
        saturated_after_s: seconds at full scale without variation before it is flagged saturated.
        stuck_tolerance: counts of peak-to-peak change still counted as "no variation".
        full_scale: ADC full scale, 1023 for the 10-bit converter (knight2009 III).
        min_span: fewest counts between baseline and full scale that still give a learned gain;
            a channel with less (baseline at the rail) gets gain 0 and FAULT_SATURATED.
        mask_faults: read faulty channels as level 0 / inactive.
    """

    def __init__(self, fitted: np.ndarray | BodyMap | None = None, baseline: np.ndarray | float | None = None,
                 gain: np.ndarray | float | None = None, threshold: float = 0.3, baseline_frames: int = 10,
                 rate_hz: float = 3.4, drift_tau_s: float | None = 120.0, drift_freeze_level: float = 0.05,
                 fault_after_s: float = 60.0, saturated_after_s: float = 300.0, stuck_tolerance: int = 0,
                 full_scale: int = ADC_MAX, min_span: int = 16, mask_faults: bool = True) -> None:
        if fitted is None:
            fitted = BodyMap.default()
        mask = fitted.fitted_mask() if isinstance(fitted, BodyMap) else np.asarray(fitted, dtype=bool)
        if mask.shape != (N_CHANNELS,):
            raise ValueError(f'fitted must be ({N_CHANNELS},) bool or a BodyMap; got shape {mask.shape}')
        if not 0.0 < threshold <= 1.0:
            raise ValueError(f'threshold must be in (0, 1]; got {threshold}')
        if baseline_frames < 1 or rate_hz <= 0 or fault_after_s <= 0 or saturated_after_s <= 0:
            raise ValueError(f'baseline_frames >= 1, rate_hz > 0, fault_after_s > 0 and saturated_after_s > 0 are '
                             f'required; got {baseline_frames}, {rate_hz}, {fault_after_s}, {saturated_after_s}')
        self.fitted = mask.copy()
        self.threshold = float(threshold)
        self.baseline_frames = int(baseline_frames)
        self.rate_hz = float(rate_hz)
        self.drift_tau_s = drift_tau_s
        self.drift_freeze_level = float(drift_freeze_level)
        self.fault_after_s = float(fault_after_s)
        self.saturated_after_s = float(saturated_after_s)
        self.stuck_tolerance = int(stuck_tolerance)
        self.full_scale = int(full_scale)
        self.min_span = int(min_span)
        self.mask_faults = bool(mask_faults)
        self._configured_baseline = None if baseline is None else _per_channel(baseline, 'baseline')
        self._configured_gain = None if gain is None else _per_channel(gain, 'gain', allow_nan=True)
        self._fault_frames = max(1, round(self.fault_after_s * self.rate_hz))
        self._saturated_frames = max(1, round(self.saturated_after_s * self.rate_hz))
        self._alpha = 0.0 if not drift_tau_s else min(1.0, 1.0 / (drift_tau_s * self.rate_hz))
        self.reset()

    @classmethod
    def from_yaml(cls, path: str | Path, body_map: BodyMap | None = None, **overrides) -> BearCalibrator:
        """Build from a YAML file with optional keys ``threshold``, ``baseline_frames``, ``drift_tau_s``,
        ``fault_after_s``, ``saturated_after_s`` and ``baseline`` / ``gain``: a number for every sensor or a
        mapping sensor name -> number. Unknown keys and sensor names raise ConfigError with file and line."""
        body = body_map or BodyMap.default()
        doc = load_yaml(path)
        scalars = ('threshold', 'baseline_frames', 'drift_tau_s', 'fault_after_s', 'saturated_after_s')
        check_keys(doc, optional=(*scalars, 'baseline', 'gain'), what='bear calibration')
        kwargs: dict = {k: typed(doc, k, float if k != 'baseline_frames' else int, 'bear calibration')
                        for k in scalars if k in doc}
        for key in ('baseline', 'gain'):
            if key not in doc:
                continue
            value = doc[key]
            if isinstance(value, YamlDict):
                per = np.full(N_CHANNELS, np.nan)
                for name in value:
                    try:
                        channel = body.by_name(name).channel
                    except ConfigError as err:
                        raise value.error(err.bare_message, name) from None
                    per[channel] = typed(value, name, float, f'{key} of {name}')
                if key == 'baseline' and np.isnan(per[body.fitted_mask()]).any():
                    missing = [s.name for s in body if np.isnan(per[s.channel])]
                    raise value.error(f'baseline must name every fitted sensor; missing: {", ".join(missing)}')
                # Unnamed channels: baseline 0 (unfitted ones are ignored), gain learned from the baseline.
                kwargs[key] = np.nan_to_num(per, nan=0.0) if key == 'baseline' else per
            else:
                kwargs[key] = typed(doc, key, float, 'bear calibration')
        kwargs.update(overrides)
        return cls(fitted=body, **kwargs)

    # ------------------------------------------------------------------ state
    def reset(self) -> None:
        """Forget learned baselines, fault history and counters (configured values are kept)."""
        n = N_CHANNELS
        self.baseline = np.zeros(n) if self._configured_baseline is None else self._configured_baseline.copy()
        self._has_baseline = np.full(n, self._configured_baseline is not None)
        self._learn = np.zeros((self.baseline_frames, n), dtype=np.float32)  # bounded: N x 64
        self._learn_count = np.zeros(n, dtype=np.int64)
        self.gain = np.zeros(n)
        self._update_gain(np.arange(n)[self._has_baseline])
        self._last = np.full(n, np.nan)
        self._flat_run = np.zeros(n, dtype=np.int64)
        #: samples rejected as NaN / infinite / out of 0..full_scale, since the last reset
        self.invalid_samples = 0
        self.frames = 0

    @property
    def ready(self) -> bool:
        """Every fitted channel has a baseline."""
        return bool(self._has_baseline[self.fitted].all())

    def _update_gain(self, channels: np.ndarray) -> None:
        span = self.full_scale - self.baseline[channels]
        gain = np.where(span >= self.min_span, 1.0 / np.maximum(span, 1.0), 0.0)
        if self._configured_gain is not None:  # NaN entries: not configured, use the learned gain
            configured = self._configured_gain[channels]
            gain = np.where(np.isnan(configured), gain, configured)
        self.gain[channels] = gain

    # ------------------------------------------------------------------ update
    def update(self, raw: np.ndarray) -> BearLevels:
        """Calibrate one scan.

        Args:
            raw: (64,) counts (any integer or float dtype); NaN and values outside 0..full_scale are
                counted in :attr:`invalid_samples`, read as level 0 and leave the state untouched.

        Returns:
            :class:`BearLevels` with new arrays.
        """
        values = np.asarray(raw, dtype=np.float64)
        if values.shape != (N_CHANNELS,):
            raise ValueError(f'a bear scan has shape ({N_CHANNELS},); got {values.shape}')
        self.frames += 1
        fitted = self.fitted
        valid = np.isfinite(values) & (values >= 0) & (values <= self.full_scale)
        use = valid & fitted
        self.invalid_samples += int(np.count_nonzero(~valid & fitted))
        clean = np.where(valid, values, 0.0)

        # Learn baselines (median of the first N valid samples of each channel).
        learning = use & ~self._has_baseline
        if learning.any():
            idx = np.flatnonzero(learning)
            self._learn[self._learn_count[idx], idx] = clean[idx]
            self._learn_count[idx] += 1
            done = idx[self._learn_count[idx] >= self.baseline_frames]
            if done.size:
                self.baseline[done] = np.median(self._learn[:, done], axis=0)
                self._has_baseline[done] = True
                self._update_gain(done)

        # Faults: runs of frames without variation, classified by where the channel sits.
        moved = np.abs(clean - self._last) > self.stuck_tolerance  # NaN last -> False
        first = np.isnan(self._last)
        self._flat_run = np.where(use & ~moved & ~first, self._flat_run + 1, np.where(use, 0, self._flat_run))
        self._last = np.where(use, clean, self._last)
        flat = self._flat_run >= self._fault_frames
        at_top = self._last >= self.full_scale
        faults = np.zeros(N_CHANNELS, dtype=np.uint8)
        faults[flat & (self._last <= 0)] = FAULT_DEAD
        faults[(self._flat_run >= self._saturated_frames) & at_top] = FAULT_SATURATED
        faults[flat & (self._last > 0) & ~at_top] = FAULT_STUCK
        calibrated = self._has_baseline & fitted
        faults[calibrated & (self.gain == 0.0)] |= FAULT_SATURATED  # baseline at the rail: cannot measure
        faults[~valid & fitted] |= FAULT_INVALID

        level = np.clip((clean - self.baseline) * self.gain, 0.0, 1.0)
        ok = use & calibrated
        if self.mask_faults:
            ok &= faults == 0
        level = np.where(ok, level, 0.0).astype(np.float32)

        # Follow slow drift on quiet channels only (never learn a touch).
        if self._alpha:
            track = ok & (level < self.drift_freeze_level)
            self.baseline[track] += self._alpha * (clean[track] - self.baseline[track])

        return BearLevels(raw=clean.astype(np.uint16), level=level, active=level >= self.threshold,
                          fitted=fitted.copy(), faults=faults, ready=self.ready)


def _per_channel(value: np.ndarray | float, what: str, allow_nan: bool = False) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0:
        arr = np.full(N_CHANNELS, float(arr))
    if arr.shape != (N_CHANNELS,):
        raise ValueError(f'{what} must be a scalar or ({N_CHANNELS},); got shape {arr.shape}')
    if np.isinf(arr).any() or (not allow_nan and np.isnan(arr).any()):
        raise ValueError(f'{what} must be finite on every channel; use 0 for unfitted channels')
    return arr
