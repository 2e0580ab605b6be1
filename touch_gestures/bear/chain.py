"""Sensor chains: from a stimulus to calibrated levels, one scan cycle at a time.

:class:`DriverChain` is the real sensor chain without the graph: stimulus -> ``touch_sim.bear.device.
BearDevice`` (wire bytes, with the device's sensor model: noise, drift, per-channel scan timing)
-> ``touch_driver.bear.protocol.BearDecoder`` (framing + payload decode, counts bad bytes) ->
``touch_driver.bear.calibration.BearCalibrator`` (levels 0..1, fault flags). :class:`LevelModelChain`
is a stand-in for unit tests of the recognisers: the stimulus sampled at the scan time plus Gaussian
noise, no bytes. :class:`~.graph_chain.GraphChain` (the evaluation's default) runs the same device and
calibrator through the ``bear_driver`` node of a simulated-time graph.

All yield :class:`Cycle` objects: the scan time, (64,) float32 levels and (64,) bool fault flags.

>>> from touch_sim.scenes import BearScript, BearTouch
>>> chain = LevelModelChain(BearScript([BearTouch(channels=(3,), start=0.0, duration=5.0, level=0.8)]),
...                         rate_hz=2.0, noise=0.0)
>>> [(c.t, round(float(c.levels[3]), 2)) for c in chain.cycles(1.5)]
[(0.0, 0.0), (0.5, 0.8), (1.0, 0.8)]
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

__all__ = ['REAL_RATE_HZ', 'Cycle', 'DriverChain', 'LevelModelChain']

#: The real bear's scan rate: 58 channels x 5 ms = 0.29 s, "3.4 Hz" (knight2009 VI.B).
REAL_RATE_HZ = 3.4
N_CHANNELS = 64


@dataclass(frozen=True, slots=True)
class Cycle:
    """One calibrated scan: time (s), (64,) float32 levels in [0, 1], (64,) bool faulty channels."""

    t: float
    levels: np.ndarray
    faulty: np.ndarray


class LevelModelChain:
    """Stimulus sampled at scan times plus Gaussian noise: a byte-free stand-in for tests.

    Args:
        stimulus: a ``BearStimulus`` (``proximity(t) -> (64,) float32``).
        rate_hz: scan rate, cycles/s.
        noise: standard deviation of additive level noise (level units).
        seed: noise seed.
    """

    def __init__(self, stimulus, rate_hz: float = REAL_RATE_HZ, noise: float = 0.005, seed: int = 0) -> None:
        if rate_hz <= 0:
            raise ValueError(f'rate_hz must be > 0; got {rate_hz}')
        self.stimulus = stimulus
        self.rate_hz = float(rate_hz)
        self.noise = float(noise)
        self._rng = np.random.default_rng(seed)

    def cycles(self, duration_s: float) -> Iterator[Cycle]:
        """Scans from t = 0 up to (excluding) ``duration_s``."""
        faulty = np.zeros(N_CHANNELS, dtype=bool)
        for i in range(int(np.ceil(duration_s * self.rate_hz - 1e-9))):
            t = i / self.rate_hz
            levels = np.asarray(self.stimulus.proximity(t), dtype=np.float32)
            if self.noise:
                levels = np.clip(levels + self._rng.normal(0.0, self.noise, N_CHANNELS), 0.0, 1.0).astype(np.float32)
            yield Cycle(t, levels, faulty)


class DriverChain:
    """The real sensor chain: virtual device bytes -> decoder -> calibrator.

    Args:
        stimulus: a ``BearStimulus``.
        rate_hz: the device's scan rate (3.4 Hz real, 25 Hz ideal).
        seed: the device's noise seed.
        device_options: extra keyword arguments for ``BearDevice`` (noise, faults, ...).
        calibrator_options: extra keyword arguments for ``BearCalibrator``.

    Attributes:
        decoder: the ``BearDecoder`` (its ``stats`` count dropped bytes, checksum errors, gaps).
        calibrator: the ``BearCalibrator``.
    """

    def __init__(self, stimulus, rate_hz: float = REAL_RATE_HZ, seed: int = 0, device_options: dict | None = None,
                 calibrator_options: dict | None = None) -> None:
        from touch_driver.bear.calibration import BearCalibrator
        from touch_driver.bear.protocol import BearDecoder
        from touch_sim.bear.device import BearDevice

        self.rate_hz = float(rate_hz)
        self.device = BearDevice(stimulus, rate_hz=rate_hz, seed=seed, **(device_options or {}))
        self.decoder = BearDecoder()
        self.calibrator = BearCalibrator(rate_hz=rate_hz, **(calibrator_options or {}))
        self.frame_period = float(self.device.frame_period)

    def cycles(self, duration_s: float) -> Iterator[Cycle]:
        """Calibrated scans from t = 0 up to (excluding) ``duration_s``; frames lost on the wire are skipped."""
        period = self.frame_period
        for index in range(int(np.ceil(duration_s / period - 1e-9))):
            t = index * period
            for scan in self.decoder.feed(self.device.frame_bytes(index, t)):
                out = self.calibrator.update(scan.raw)
                yield Cycle(t, out.level, out.faults != 0)
