"""Virtual optoelectronic skin: a stimulus in, the bytes the hardware would send out (synthetic).

:class:`SkinDevice` implements :class:`touch_sim.virtual_port.DeviceModel` for the ``skinsim://`` URL
handler, and :func:`render_frames` runs the same model without a port. Per frame it turns the
stimulus's contacts into taxel signals (:class:`~touch_sim.skin.contact.FingerContactModel`) and
adds the electronics:

- **baseline** per taxel: ``baseline_counts`` + N(0, ``baseline_spread_counts``);
- **drift**: common-mode ``drift_counts * sin(2 pi t / drift_period_s + phi)`` plus per-taxel terms
  of amplitude U(0, ``taxel_drift_counts``) and periods U(300, 1200) s;
- **noise**: Gaussian, ``noise_counts``; counts rounded and clipped to 0..65535;
- **faults** (row-major taxel indices): ``dead`` read 0..63, ``stuck`` hold their rest value,
  ``saturated`` read 65535.

All randomness comes from one generator seeded with ``seed``, so frames asked for in order are
deterministic.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Iterable
from typing import Any

import numpy as np

from touch_driver.skin.protocol import FRAME_RATE_HZ, N_TAXELS, encode_skin_frame
from touch_sim.skin.contact import FingerContactModel, HysteresisPlay, SkinStimulus
from touch_sim.skin.stimuli import NoTouch

__all__ = ['SkinDevice', 'forget_stimuli', 'register_stimulus', 'registered_stimulus', 'render_frames',
           'unregister_stimulus']

_stimuli: dict[str, SkinStimulus] = {}
_stimuli_lock = threading.Lock()


def register_stimulus(name: str, stimulus: SkinStimulus) -> None:
    """Make ``stimulus`` available to ``skinsim://...?scene=NAME`` (replaces an earlier one of that name)."""
    if not isinstance(name, str) or not name or '&' in name or '=' in name:
        raise ValueError(f'a stimulus name must be a non-empty string without & or =; got {name!r}')
    if not callable(getattr(stimulus, 'contacts', None)):
        raise ValueError(f'a skin stimulus needs a contacts(t) method; got {type(stimulus).__name__}')
    with _stimuli_lock:
        _stimuli[name] = stimulus


def unregister_stimulus(name: str) -> None:
    """Forget the stimulus registered as ``name``, if any."""
    with _stimuli_lock:
        _stimuli.pop(name, None)


def registered_stimulus(name: str) -> SkinStimulus:
    """The stimulus registered as ``name``; KeyError listing the known names otherwise."""
    with _stimuli_lock:
        if name not in _stimuli:
            raise KeyError(f'no skin stimulus registered as {name!r}; registered: {sorted(_stimuli) or "none"}')
        return _stimuli[name]


def forget_stimuli() -> None:
    """Drop every registered stimulus (tests call this between cases)."""
    with _stimuli_lock:
        _stimuli.clear()


def _indices(name: str, values: Iterable[int]) -> np.ndarray:
    out = np.array(sorted(set(int(v) for v in values)), dtype=np.intp)
    if out.size and (out[0] < 0 or out[-1] >= N_TAXELS):
        raise ValueError(f'{name} taxels must be row-major indices 0..143; got {out.tolist()}')
    return out


class SkinDevice:
    """The simulated skin hardware (see the module doc). Satisfies ``virtual_port.DeviceModel``.

    Args:
        stimulus: who touches where and when; default: nobody.
        seed: seeds baselines, drift phases, noise, repeatability and dead-taxel readings.
        rate_hz: frames per second (cirillo2017 2.2: 150).
        noise_counts, baseline_counts, baseline_spread_counts, drift_counts, drift_period_s,
        taxel_drift_counts: electronics, in ADC counts and seconds (module doc).
        dead, stuck, saturated: faulty taxels, row-major indices.
        contact_model: the finger mechanics; default :class:`FingerContactModel()`.
    """

    def __init__(self, stimulus: SkinStimulus | None = None, *, seed: int = 0, rate_hz: float = FRAME_RATE_HZ,
                 noise_counts: float = 25.0, baseline_counts: float = 45000.0, baseline_spread_counts: float = 2500.0,
                 drift_counts: float = 600.0, drift_period_s: float = 600.0, taxel_drift_counts: float = 100.0,
                 dead: Iterable[int] = (), stuck: Iterable[int] = (), saturated: Iterable[int] = (),
                 contact_model: FingerContactModel | None = None) -> None:
        for name, value in (('noise_counts', noise_counts), ('baseline_spread_counts', baseline_spread_counts),
                            ('drift_counts', drift_counts), ('taxel_drift_counts', taxel_drift_counts)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f'{name} must be a finite number >= 0, got {value}')
        if not (math.isfinite(rate_hz) and rate_hz > 0 and math.isfinite(drift_period_s) and drift_period_s > 0):
            raise ValueError(f'rate_hz and drift_period_s must be > 0; got {rate_hz}, {drift_period_s}')
        if not 0 <= baseline_counts <= 65535:
            raise ValueError(f'baseline_counts must be in 0..65535, got {baseline_counts}')
        if stimulus is not None and not callable(getattr(stimulus, 'contacts', None)):
            raise ValueError(f'stimulus needs a contacts(t) method; got {type(stimulus).__name__}')
        self.stimulus: SkinStimulus = stimulus if stimulus is not None else NoTouch()
        self.model = contact_model if contact_model is not None else FingerContactModel()
        self.frame_period = 1.0 / rate_hz
        self.noise_counts = float(noise_counts)
        self._rng = np.random.default_rng(seed)
        rng = self._rng
        self._base = baseline_counts + baseline_spread_counts * rng.standard_normal(N_TAXELS)
        self._drift_counts = float(drift_counts)
        self._drift_omega = 2 * math.pi / drift_period_s
        self._drift_phase = float(rng.uniform(0, 2 * math.pi))
        self._taxel_amp = rng.uniform(0, taxel_drift_counts, N_TAXELS)
        self._taxel_omega = 2 * math.pi / rng.uniform(300.0, 1200.0, N_TAXELS)
        self._taxel_phase = rng.uniform(0, 2 * math.pi, N_TAXELS)
        self.dead = _indices('dead', dead)
        self.stuck = _indices('stuck', stuck)
        self.saturated = _indices('saturated', saturated)
        self._stuck_values = np.clip(np.rint(self.baseline(0.0)[self.stuck]), 0, 65535)
        self._hysteresis = HysteresisPlay(self.model.hysteresis)
        self._touching = False
        self._gain = 1.0
        self._loaded = False  # hysteresis state non-zero

    def baseline(self, t: float) -> np.ndarray:
        """(144,) float64: rest counts of every taxel at device time ``t`` s (noise-free)."""
        common = self._drift_counts * math.sin(self._drift_omega * t + self._drift_phase)
        return self._base + common + self._taxel_amp * np.sin(self._taxel_omega * t + self._taxel_phase)

    def signal(self, t: float) -> np.ndarray:
        """(144,) float64: counts added by touch at ``t`` s (advances hysteresis and repeatability state)."""
        contacts = self.stimulus.contacts(t)
        if contacts and not self._touching:
            r = self.model.repeatability
            self._gain = float(self._rng.uniform(1 - r / 2, 1 + r / 2))
        self._touching = bool(contacts)
        if not contacts and not self._loaded:
            return np.zeros(N_TAXELS)
        m = self.model
        deformation = self._hysteresis.update(m.taxel_load(contacts) / m.full_scale_n)
        self._loaded = bool(deformation.any())
        return m.mix_crosstalk(deformation) * (m.counts_per_unit * self._gain)

    def raw_frame(self, t: float) -> np.ndarray:
        """(144,) uint16: the counts the hardware reports at device time ``t`` s, row-major."""
        counts = self.baseline(t) + self.signal(t)
        if self.noise_counts:
            counts += self.noise_counts * self._rng.standard_normal(N_TAXELS)
        if self.dead.size:
            counts[self.dead] = self._rng.integers(0, 64, self.dead.size)
        if self.stuck.size:
            counts[self.stuck] = self._stuck_values
        if self.saturated.size:
            counts[self.saturated] = 65535
        np.rint(counts, out=counts)
        np.clip(counts, 0, 65535, out=counts)
        return counts.astype(np.uint16)

    # ------------------------------------------------------------------ DeviceModel
    def frame_bytes(self, index: int, t: float) -> bytes:
        """Wire frame ``index`` (sequence ``index mod 65536``) sampled at device time ``t`` s."""
        return encode_skin_frame(index, self.raw_frame(t))

    def command(self, data: bytes) -> None:
        """The skin firmware takes no commands; bytes written to the port are ignored."""


def render_frames(stimulus: SkinStimulus | None, duration_s: float | None = None, rate_hz: float = FRAME_RATE_HZ,
                  seed: int = 0, **device_options: Any) -> np.ndarray:
    """Simulate the skin under ``stimulus``: (n, 144) uint16 raw frames, row-major, frame i at t = i / rate_hz.

    ``duration_s`` defaults to the stimulus's ``duration_s``; ``device_options`` go to :class:`SkinDevice`
    (noise_counts, drift_counts, dead, ...). Synthetic data.
    """
    if duration_s is None:
        duration_s = getattr(stimulus, 'duration_s', None)
        if duration_s is None:
            raise ValueError('pass duration_s: this stimulus has no duration_s of its own')
    if not (math.isfinite(duration_s) and duration_s >= 0):
        raise ValueError(f'duration_s must be a finite number >= 0, got {duration_s}')
    device = SkinDevice(stimulus, seed=seed, rate_hz=rate_hz, **device_options)
    n = math.floor(duration_s * rate_hz + 1e-9) + 1
    out = np.empty((n, N_TAXELS), dtype=np.uint16)
    for i in range(n):
        out[i] = device.raw_frame(i * device.frame_period)
    return out
