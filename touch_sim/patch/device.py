"""Virtual textile patch and capacitive panels: a stimulus in, the firmware's bytes out (synthetic).

:class:`PatchDevice` implements :class:`~touch_sim.virtual_port.DeviceModel`. By default it streams
every raw 100 Hz scan (frame id 0x51); ``mode='averaged'`` sends the paper firmware's 20 Hz frames
(id 0x50, the mean of the last 5 scans). ``serial.serial_for_url('patchsim://NAME?scene=...')``
wraps it in a port.

Sensor model (every constant a parameter; sympartner2018 section in brackets):

- **transfer** [5.3]: ``counts = rest + span * s * tanh(p / p_sat)``, p in N/cm^2,
  span = 1023 - rest, per-cell sensitivity s ~ 1 +- ``sensitivity_spread``;
- **resting state** [5.3]: ``rest`` uniform in ``rest_range``, a slow sinusoidal drift of
  ``drift_counts``, and creep: ``creep`` x the cell's recent signal decaying with ``creep_tau_s``;
- **cross-talk** [5.1, 5.3]: ``crosstalk`` of the strongest signal in the cell's row and column;
- **noise**: Gaussian, ``noise`` counts; 10-bit saturation; cells outside the outline read noise
  near 0;
- **faults**: per cell ``'dead'`` (0), ``'saturated'`` (1023) or ``'stuck'`` (rest, no noise);
  ``dead_panels`` read 0.

Panels [4]: ``counts = quiescent + drift + span * level + noise``, quiescent uniform in
``panel_quiescent_range``, span in ``panel_span_range``.

Noise is seeded by ``(seed, scan index)``. Creep is the only state carried between frames, so
frames must be generated in time order.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from typing import Any, ClassVar

import numpy as np

from touch_driver.patch.calibration import load_outline
from touch_driver.patch.protocol import ADC_MAX, GRID, N_PANELS, encode_scan
from touch_graph.yamlconf import did_you_mean
from touch_sim.scenes import PatchStimulus

__all__ = ['FAULT_KINDS', 'MODES', 'PatchDevice']

FAULT_KINDS = ('dead', 'saturated', 'stuck')
MODES = ('raw', 'averaged')


class PatchDevice:
    """Simulated patch electronics (ATMEGA328P reading the matrix and the AT42QT1111).

    Args:
        stimulus: ``pressure(t) -> (16, 16) N/cm^2`` and ``panels(t) -> (11,) in [0, 1]``.
        mode: ``'raw'`` (every 100 Hz scan, id 0x51) or ``'averaged'`` (20 Hz frames, id 0x50).
        seed: seeds the per-cell constants and the noise.
        scan_rate_hz: internal scan rate, 100 Hz (sympartner2018 6.1).
        decimation: scans per averaged frame, 5 (100 Hz -> 20 Hz).
        noise, rest_range, drift_counts, drift_period_s, saturation_pressure, sensitivity_spread,
        crosstalk, creep, creep_tau_s: the matrix model above (counts, N/cm^2, seconds).
        panel_quiescent_range, panel_span_range, panel_noise, panel_drift: the panel model (counts).
        faults: (row, col) -> ``'dead'``, ``'saturated'`` or ``'stuck'``.
        dead_panels: panel numbers that read 0.
        outline: (16, 16) bool mask of cells with fabric; default config/patch_outline.yaml.
    """

    def __init__(self, stimulus: PatchStimulus, mode: str = 'raw', seed: int = 0, scan_rate_hz: float = 100.0,
                 decimation: int = 5, noise: float = 2.0, rest_range: tuple[float, float] = (30.0, 60.0),
                 drift_counts: float = 8.0, drift_period_s: float = 300.0, saturation_pressure: float = 8.0,
                 sensitivity_spread: float = 0.1, crosstalk: float = 0.03, creep: float = 0.05,
                 creep_tau_s: float = 2.0, panel_quiescent_range: tuple[float, float] = (400.0, 600.0),
                 panel_span_range: tuple[float, float] = (120.0, 200.0), panel_noise: float = 1.5,
                 panel_drift: float = 5.0, faults: Mapping[tuple[int, int], str] | None = None,
                 dead_panels: Iterable[int] = (), outline: np.ndarray | None = None) -> None:
        if not (callable(getattr(stimulus, 'pressure', None)) and callable(getattr(stimulus, 'panels', None))):
            raise TypeError(f'stimulus must have pressure(t) and panels(t); got {type(stimulus).__name__}')
        if mode not in MODES:
            raise ValueError(f'mode must be one of {", ".join(MODES)}{did_you_mean(mode, MODES)}; got {mode!r}')
        if not (scan_rate_hz > 0 and math.isfinite(scan_rate_hz)) or decimation < 1:
            raise ValueError(f'scan_rate_hz must be > 0 and decimation >= 1; got {scan_rate_hz}, {decimation}')
        if min(noise, drift_counts, crosstalk, creep, panel_noise, panel_drift) < 0 or saturation_pressure <= 0:
            raise ValueError('noise, drift, crosstalk and creep must be >= 0 and saturation_pressure > 0')
        self.stimulus, self.mode, self.seed = stimulus, mode, int(seed)
        self.scan_rate_hz, self.decimation = float(scan_rate_hz), int(decimation)
        self.frame_period = (1.0 if mode == 'raw' else self.decimation) / self.scan_rate_hz
        self.noise, self.crosstalk, self.creep = float(noise), float(crosstalk), float(creep)
        self.creep_tau_s, self.saturation_pressure = float(creep_tau_s), float(saturation_pressure)
        self.drift_counts, self.panel_noise, self.panel_drift = float(drift_counts), float(panel_noise), panel_drift
        self.outline = load_outline() if outline is None else np.asarray(outline, dtype=bool)
        if self.outline.shape != GRID:
            raise ValueError(f'outline must be a {GRID} bool mask; got {self.outline.shape}')

        consts = np.random.default_rng((self.seed, 0x9A7C))
        self.rest = consts.uniform(*rest_range, GRID)
        self.span = (ADC_MAX - self.rest) * consts.uniform(1 - sensitivity_spread, 1 + sensitivity_spread, GRID)
        self._omega = 2 * np.pi / (drift_period_s * consts.uniform(0.5, 1.5, GRID))
        self._phase = consts.uniform(0, 2 * np.pi, GRID)
        self.panel_quiescent = consts.uniform(*panel_quiescent_range, N_PANELS)
        self.panel_span = consts.uniform(*panel_span_range, N_PANELS)
        self._panel_omega = 2 * np.pi / (400.0 * consts.uniform(0.5, 1.5, N_PANELS))
        self._panel_phase = consts.uniform(0, 2 * np.pi, N_PANELS)

        self.faults = {}
        for cell, kind in (faults or {}).items():
            row, col = (int(v) for v in cell)
            if not (0 <= row < GRID[0] and 0 <= col < GRID[1]):
                raise ValueError(f'fault cell {cell} is outside the {GRID[0]}x{GRID[1]} matrix')
            if kind not in FAULT_KINDS:
                raise ValueError(f'fault {kind!r} at {cell} is not one of {", ".join(FAULT_KINDS)}'
                                 f'{did_you_mean(kind, FAULT_KINDS)}')
            self.faults[row, col] = kind
        self._masks = {kind: np.zeros(GRID, dtype=bool) for kind in FAULT_KINDS}
        for cell, kind in self.faults.items():
            self._masks[kind][cell] = True
        self.dead_panels = np.zeros(N_PANELS, dtype=bool)
        for p in dead_panels:
            if not 0 <= int(p) < N_PANELS:
                raise ValueError(f'dead panel {p} is outside 0..{N_PANELS - 1}')
            self.dead_panels[int(p)] = True
        self._creep_state = np.zeros(GRID)
        self._last_scan_t = -math.inf

    # ------------------------------------------------------------------ model
    def _pressure(self, t: float) -> np.ndarray:
        p = np.asarray(self.stimulus.pressure(t), dtype=np.float64)
        if p.shape != GRID:
            raise ValueError(f'{type(self.stimulus).__name__}.pressure(t) must return {GRID}; got shape {p.shape}')
        return np.clip(np.nan_to_num(p, nan=0.0, posinf=0.0), 0.0, None)  # a stimulus bug must not break the stream

    def scan_counts(self, scan_index: int, t: float) -> np.ndarray:
        """(16, 16) float64 counts of one 100 Hz scan at time ``t`` (before rounding)."""
        signal = self.span * np.tanh(self._pressure(t) / self.saturation_pressure) * self.outline
        if self.crosstalk:
            phantom = self.crosstalk * (signal.max(axis=1, keepdims=True) + signal.max(axis=0, keepdims=True))
            signal = signal + phantom * self.outline
        if self.creep:
            if t < self._last_scan_t:  # time went back (a new run): forget the fabric's memory
                self._creep_state[:] = 0.0
            decay = math.exp(-(t - self._last_scan_t) / self.creep_tau_s) if self._last_scan_t > -math.inf else 0.0
            self._creep_state = np.maximum(self._creep_state * decay, self.creep * signal)
            self._last_scan_t = t
            signal = signal + self._creep_state
        drift = self.drift_counts * np.sin(self._omega * t + self._phase)
        rng = np.random.default_rng((self.seed, int(scan_index)))
        counts = np.where(self.outline, self.rest + drift + signal, 0.0) + rng.normal(0.0, self.noise, GRID)
        counts[self._masks['stuck']] = self.rest[self._masks['stuck']]
        counts[self._masks['dead']] = 0.0
        counts[self._masks['saturated']] = ADC_MAX
        return np.clip(counts, 0.0, ADC_MAX)

    def panel_counts(self, index: int, t: float) -> np.ndarray:
        """(11,) uint16 panel signals at time ``t``."""
        level = np.clip(np.nan_to_num(np.asarray(self.stimulus.panels(t), dtype=np.float64)), 0.0, 1.0)
        if level.shape != (N_PANELS,):
            raise ValueError(f'{type(self.stimulus).__name__}.panels(t) must return ({N_PANELS},); got {level.shape}')
        rng = np.random.default_rng((self.seed, int(index), 0x9A))
        drift = self.panel_drift * np.sin(self._panel_omega * t + self._panel_phase)
        counts = self.panel_quiescent + drift + self.panel_span * level + rng.normal(0.0, self.panel_noise, N_PANELS)
        counts[self.dead_panels] = 0.0
        return np.clip(np.rint(counts), 0, 0xFFFF).astype(np.uint16)

    # ------------------------------------------------------------------ DeviceModel
    def frame_bytes(self, index: int, t: float) -> bytes:
        """Wire frame ``index`` at device time ``t``: one raw scan, or the average of the last 5 scans."""
        if self.mode == 'raw':
            cells = self.scan_counts(index, t)
        else:
            d, dt = self.decimation, 1.0 / self.scan_rate_hz
            cells = np.mean([self.scan_counts(index * d + j, t - (d - 1 - j) * dt) for j in range(d)], axis=0)
        return encode_scan(index & 0xFFFF, np.rint(cells).astype(np.uint16), self.panel_counts(index, t),
                           raw_scan=self.mode == 'raw')

    def command(self, data: bytes) -> None:
        """The firmware takes no commands; bytes written are ignored."""

    # ------------------------------------------------------------------ URL options
    URL_OPTIONS: ClassVar[dict[str, tuple[type, str]]] = {
        'mode': (str, 'mode'), 'noise': (float, 'noise'), 'drift': (float, 'drift_counts'),
        'crosstalk': (float, 'crosstalk'), 'creep': (float, 'creep'), 'scan_rate': (float, 'scan_rate_hz'),
    }

    @classmethod
    def from_options(cls, stimulus: PatchStimulus, options: Mapping[str, str], seed: int = 0) -> PatchDevice:
        """Build from URL query options (``mode``, ``noise``, ``drift``, ``crosstalk``, ``creep``,
        ``scan_rate``; cell faults ``dead``/``saturated``/``stuck`` = comma-separated ``row:col``;
        ``dead_panels`` = comma-separated panel numbers). ValueError naming the option on bad input."""
        kwargs: dict[str, Any] = {'seed': seed}
        faults: dict[tuple[int, int], str] = {}
        for key, text in options.items():
            if key in FAULT_KINDS:
                for item in filter(None, (s.strip() for s in text.split(','))):
                    try:
                        row, col = (int(v) for v in item.split(':'))
                    except ValueError:
                        raise ValueError(f'option {key}: cells are row:col, e.g. {key}=3:4,5:6; got {item!r}') from None
                    faults[row, col] = key
            elif key == 'dead_panels':
                try:
                    kwargs['dead_panels'] = [int(p) for p in text.split(',') if p.strip()]
                except ValueError:
                    raise ValueError(f'option dead_panels must be panel numbers, e.g. 0,3; got {text!r}') from None
            elif key in cls.URL_OPTIONS:
                kind, keyword = cls.URL_OPTIONS[key]
                try:
                    kwargs[keyword] = kind(text)
                except ValueError:
                    raise ValueError(f'option {key}={text!r} must be a {kind.__name__}') from None
            else:
                known = (*cls.URL_OPTIONS, *FAULT_KINDS, 'dead_panels', 'scene')
                raise ValueError(f'unknown patchsim option {key!r}{did_you_mean(key, known)}; options are: '
                                 f'{", ".join(known)}, and the port faults garbage, corrupt, drop, unplug_at, '
                                 'replug_at, buffer_s, seed')
        return cls(stimulus, faults=faults, **kwargs)
