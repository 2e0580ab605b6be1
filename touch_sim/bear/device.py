"""Virtual Sensate Bear: a stimulus in, the bytes the Somatic board would send out (synthetic).

:class:`BearDevice` implements :class:`~touch_sim.virtual_port.DeviceModel`: at frame time it samples
a :class:`~touch_sim.scenes.BearStimulus` (proximity 0..1 per channel), applies the sensor model and
encodes a scan frame (id 0x42). ``serial.serial_for_url('bearsim://NAME?scene=...')`` wraps it.

Sensor model (every constant a parameter; knight2009 section in brackets):

- **scan timing** [IV.D, VI.B]: one channel every ``channel_dt_s``; ``scan='sequential'`` reads the
  fitted channels one after the other (the real bear), ``'parallel'`` input k of all eight
  Midplanes together. Each channel samples the stimulus at its own time, squeezed into the frame
  period if the slots do not fit.
- **counts** [III, IV.D, V.A]: ``baseline + drift(t) + span * proximity + noise``, clipped to
  0..1023; baseline uniform in ``baseline_range``, ``span = (1023 - baseline) * overdrive`` with
  overdrive in ``overdrive_range`` >= 1, so full contact saturates.
- **drift**: a slow sinusoid per channel (``drift_counts``, ``drift_period_s``); **noise**: Gaussian.
- **cross-talk** [IV.D]: ``crosstalk`` of the neighbouring inputs' signal on the same Midplane.
- **faults**: ``'dead'`` (0), ``'saturated'`` (1023), ``'stuck'`` (baseline, no noise); unfitted
  channels read 0.

Noise is seeded by ``(seed, frame index)``, so a frame's bytes do not depend on earlier reads.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, ClassVar

import numpy as np

from touch_driver.bear.body_map import INPUTS_PER_MIDPLANE, N_CHANNELS, BodyMap
from touch_driver.bear.protocol import ADC_MAX, encode_scan
from touch_graph.yamlconf import did_you_mean
from touch_sim.scenes import BearStimulus

__all__ = ['FAULT_KINDS', 'BearDevice']

FAULT_KINDS = ('dead', 'saturated', 'stuck')


class BearDevice:
    """Simulated Somatic board (a :class:`~touch_sim.virtual_port.DeviceModel`).

    Args:
        stimulus: what touches the bear (``proximity(t) -> (64,) float32 in [0, 1]``).
        rate_hz: scans per second (3.4 real, knight2009 VI.B; 25 ideal, IV.D).
        seed: seeds the per-channel constants and the noise.
        noise: Gaussian noise, counts (standard deviation).
        baseline_range: untouched counts, (low, high), drawn uniformly per channel.
        overdrive_range: span / (1023 - baseline), (low, high); >= 1 saturates on full contact.
        drift_counts: amplitude of the slow baseline drift, counts.
        drift_period_s: typical period of that drift, seconds (each channel within +-50 %).
        crosstalk: fraction of a neighbouring input's touch signal seen on a channel.
        channel_dt_s: time between two channel reads, 5 ms (knight2009 IV.D).
        scan: ``'sequential'`` (real bear) or ``'parallel'`` (Midplanes read together).
        faults: channel number or sensor name -> ``'dead'``, ``'saturated'`` or ``'stuck'``.
        body_map: which channels are fitted (default: the package's body map).
    """

    def __init__(self, stimulus: BearStimulus, rate_hz: float = 3.4, seed: int = 0, noise: float = 2.0,
                 baseline_range: tuple[float, float] = (80.0, 160.0),
                 overdrive_range: tuple[float, float] = (1.0, 1.15), drift_counts: float = 6.0,
                 drift_period_s: float = 600.0, crosstalk: float = 0.02, channel_dt_s: float = 0.005,
                 scan: str = 'sequential', faults: Mapping[int | str, str] | None = None,
                 body_map: BodyMap | None = None) -> None:
        if not callable(getattr(stimulus, 'proximity', None)):
            raise TypeError(f'stimulus must have proximity(t) -> (64,) array; got {type(stimulus).__name__}')
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise ValueError(f'rate_hz must be a positive number of scans per second; got {rate_hz}')
        if noise < 0 or drift_counts < 0 or not 0 <= crosstalk < 0.5 or channel_dt_s < 0:
            raise ValueError('noise, drift_counts and channel_dt_s must be >= 0 and crosstalk in [0, 0.5)')
        if scan not in ('sequential', 'parallel'):
            raise ValueError(f"scan must be 'sequential' or 'parallel'; got {scan!r}")
        self.stimulus = stimulus
        self.body_map = body_map or BodyMap.default()
        self.rate_hz = float(rate_hz)
        self.frame_period = 1.0 / self.rate_hz
        self.seed = int(seed)
        self.noise = float(noise)
        self.crosstalk = float(crosstalk)
        self.drift_counts = float(drift_counts)
        self.fitted = self.body_map.fitted_mask().copy()

        consts = np.random.default_rng((self.seed, 0xBEA4))
        self.baseline = consts.uniform(*baseline_range, N_CHANNELS)
        self.span = (ADC_MAX - self.baseline) * consts.uniform(*overdrive_range, N_CHANNELS)
        self._drift_omega = 2 * np.pi / (drift_period_s * consts.uniform(0.5, 1.5, N_CHANNELS))
        self._drift_phase = consts.uniform(0, 2 * np.pi, N_CHANNELS)

        self.faults = self._resolve_faults(faults or {})
        self._dead = np.array([self.faults.get(c) == 'dead' for c in range(N_CHANNELS)])
        self._sat = np.array([self.faults.get(c) == 'saturated' for c in range(N_CHANNELS)])
        self._stuck = np.array([self.faults.get(c) == 'stuck' for c in range(N_CHANNELS)])

        # Scan slots: the time offset of each channel's read within a scan.
        channels = np.flatnonzero(self.fitted)
        slots = np.zeros(N_CHANNELS, dtype=np.int64)
        if scan == 'sequential':
            slots[channels] = np.arange(channels.size)
        else:
            slots[channels] = channels % INPUTS_PER_MIDPLANE
        n_slots = int(slots.max()) + 1
        self.channel_dt_s = min(float(channel_dt_s), self.frame_period / n_slots)
        self.scan = scan
        self.slot_offsets = slots * self.channel_dt_s  # (64,) seconds after frame time
        self._slot_groups = [(k * self.channel_dt_s, channels[slots[channels] == k]) for k in range(n_slots)]

    def _resolve_faults(self, faults: Mapping[int | str, str]) -> dict[int, str]:
        out = {}
        for key, kind in faults.items():
            if kind not in FAULT_KINDS:
                raise ValueError(f'fault {kind!r} for {key!r} is not one of {", ".join(FAULT_KINDS)}'
                                 f'{did_you_mean(kind, FAULT_KINDS)}')
            if isinstance(key, str) and not key.isdigit():
                channel = self.body_map.by_name(key).channel  # ConfigError (a ValueError) on a typo
            else:
                channel = int(key)
                if not 0 <= channel < N_CHANNELS:
                    raise ValueError(f'fault channel {channel} is outside 0..{N_CHANNELS - 1}')
            out[channel] = kind
        return out

    # ------------------------------------------------------------------ model
    def proximity_at(self, t: float) -> np.ndarray:
        """(64,) float64 proximity each channel sees in the scan starting at ``t`` (its own read time)."""
        out = np.zeros(N_CHANNELS)
        for offset, channels in self._slot_groups:
            values = np.asarray(self.stimulus.proximity(t + offset), dtype=np.float64)
            if values.shape != (N_CHANNELS,):
                raise ValueError(f'{type(self.stimulus).__name__}.proximity(t) must return ({N_CHANNELS},); '
                                 f'got shape {values.shape}')
            out[channels] = values[channels]
        # A stimulus bug (NaN) or overshoot must not break the byte stream: clamp to [0, 1].
        return np.clip(np.nan_to_num(out, nan=0.0), 0.0, 1.0)

    def counts(self, index: int, t: float) -> np.ndarray:
        """(64,) uint16 counts of scan ``index`` starting at device time ``t`` seconds."""
        signal = self.span * self.proximity_at(t)
        if self.crosstalk:
            grid = signal.reshape(-1, INPUTS_PER_MIDPLANE)
            neighbours = np.zeros_like(grid)
            neighbours[:, 1:] += grid[:, :-1]
            neighbours[:, :-1] += grid[:, 1:]
            signal = signal + self.crosstalk * neighbours.ravel()
        times = t + self.slot_offsets
        drift = self.drift_counts * np.sin(self._drift_omega * times + self._drift_phase)
        rng = np.random.default_rng((self.seed, int(index)))
        values = self.baseline + drift + signal + rng.normal(0.0, self.noise, N_CHANNELS)
        values[self._stuck] = self.baseline[self._stuck]
        values[self._dead] = 0.0
        values[self._sat] = ADC_MAX
        values[~self.fitted] = 0.0
        return np.clip(np.rint(values), 0, ADC_MAX).astype(np.uint16)

    # ------------------------------------------------------------------ DeviceModel
    def frame_bytes(self, index: int, t: float) -> bytes:
        """Wire frame of scan ``index`` (sequence counter ``index mod 65536``) at device time ``t``."""
        return encode_scan(index & 0xFFFF, self.counts(index, t))

    def command(self, data: bytes) -> None:
        """The Somatic board takes no commands; bytes written are ignored."""

    # ------------------------------------------------------------------ URL options
    #: URL option -> (type, BearDevice keyword)
    URL_OPTIONS: ClassVar[dict[str, tuple[type, str]]] = {
        'rate': (float, 'rate_hz'), 'noise': (float, 'noise'), 'drift': (float, 'drift_counts'),
        'crosstalk': (float, 'crosstalk'), 'scan': (str, 'scan'), 'channel_dt': (float, 'channel_dt_s'),
    }

    @classmethod
    def from_options(cls, stimulus: BearStimulus, options: Mapping[str, str], seed: int = 0) -> BearDevice:
        """Build from URL query options (``rate``, ``noise``, ``drift``, ``crosstalk``, ``scan``,
        ``channel_dt`` and fault lists ``dead``/``saturated``/``stuck`` = comma-separated sensor names
        or channels). Raises ValueError naming the option on anything unknown or malformed."""
        kwargs: dict[str, Any] = {'seed': seed}
        faults: dict[int | str, str] = {}
        for key, text in options.items():
            if key in FAULT_KINDS:
                faults.update({name.strip(): key for name in text.split(',') if name.strip()})
            elif key in cls.URL_OPTIONS:
                kind, keyword = cls.URL_OPTIONS[key]
                try:
                    kwargs[keyword] = kind(text)
                except ValueError:
                    raise ValueError(f'option {key}={text!r} must be a {kind.__name__}') from None
            else:
                known = (*cls.URL_OPTIONS, *FAULT_KINDS, 'scene')
                raise ValueError(f'unknown bearsim option {key!r}{did_you_mean(key, known)}; options are: '
                                 f'{", ".join(known)}, and the port faults garbage, corrupt, drop, unplug_at, '
                                 'replug_at, buffer_s, seed')
        return cls(stimulus, faults=faults, **kwargs)
