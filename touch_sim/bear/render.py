"""A bear stimulus as the robot perceives it: virtual bear -> ``bear_driver`` node -> ``/bear/frame`` (synthetic).

:class:`BearCycles` plays a stimulus (e.g. a :class:`~touch_sim.bear.people.BearScene`) on a
virtual bear read by the real ``bear_driver`` node in the :class:`~touch_sim.harness.Harness`
(simulated time, as fast as the work allows, deterministic), and turns every ``BearFrame`` into a
:class:`Cycle`: the frame's stamp relative to the driver's start, its calibrated levels and its
fault flags. The driver decodes and calibrates exactly as on the robot; a cycle's time is its
scan time plus 0 to one poll period (the driver polls at twice the scan rate): the latency the
robot has too.

>>> from touch_sim.scenes import BearScript, BearTouch
>>> script = BearScript([BearTouch(channels=(1,), start=6.0, duration=2.0)])
>>> cycles = list(BearCycles(script, rate_hz=2.0, seed=1).cycles(9.0))
>>> len(cycles), [(c.t, bool(c.levels[1] > 0.5)) for c in cycles][11:17]
(18, [(5.5, False), (6.0, False), (6.5, True), (7.0, True), (7.5, True), (8.0, False)])
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from touch_driver.bear.protocol import REAL_RATE_HZ
from touch_sim.harness import DeviceRun, wire_frames_before

__all__ = ['DEVICE_URL_OPTIONS', 'DRIVER_PARAMETERS', 'BearCycles', 'Cycle', 'url_options']

#: ``BearDevice`` keyword -> ``bearsim://`` URL option (the sensor model settable through a URL).
DEVICE_URL_OPTIONS = {'rate_hz': 'rate', 'noise': 'noise', 'drift_counts': 'drift', 'crosstalk': 'crosstalk',
                      'scan': 'scan', 'channel_dt_s': 'channel_dt'}
#: ``BearCalibrator`` keywords that are ``bear_driver`` parameters of the same name.
DRIVER_PARAMETERS = ('threshold', 'baseline_frames', 'drift_tau_s', 'fault_after_s', 'saturated_after_s')


@dataclass(frozen=True, slots=True)
class Cycle:
    """One calibrated scan: time (s), (64,) float32 levels in [0, 1], (64,) bool faulty channels."""

    t: float
    levels: np.ndarray
    faulty: np.ndarray


def url_options(rate_hz: float, device_options: dict | None = None) -> dict[str, str]:
    """The ``bearsim://`` options of a virtual bear at ``rate_hz`` with ``BearDevice`` keywords.

    >>> url_options(3.4, {'scan': 'sequential', 'faults': {'head2': 'dead'}})
    {'rate': '3.4', 'scan': 'sequential', 'dead': 'head2'}
    """
    options = dict(device_options or {})
    query = {'rate': repr(float(rate_hz))}
    faults: dict[str, list[str]] = {}
    for channel, kind in dict(options.pop('faults', None) or {}).items():
        faults.setdefault(str(kind), []).append(str(channel))
    for keyword, value in options.items():
        if keyword not in DEVICE_URL_OPTIONS or keyword == 'rate_hz':
            raise ValueError(f'device option {keyword!r} cannot be set through a bearsim URL; settable: '
                             f'{", ".join(k for k in DEVICE_URL_OPTIONS if k != "rate_hz")} and faults')
        query[DEVICE_URL_OPTIONS[keyword]] = str(value)
    query.update({kind: ','.join(names) for kind, names in faults.items()})
    return query


class BearCycles:
    """Virtual bear -> ``bear_driver`` node -> ``/bear/frame``, in simulated time, as :class:`Cycle` objects.

    Args:
        stimulus: a ``BearStimulus`` (``proximity(t) -> (64,) float32``), e.g. a ``BearScene``.
        rate_hz: the device's scan rate and the driver's expected rate (3.4 Hz real, 25 Hz ideal).
        seed: the device's noise seed (the URL's ``seed``).
        device_options: ``BearDevice`` keywords a URL can carry (:data:`DEVICE_URL_OPTIONS` and
            ``faults``), else ValueError.
        calibrator_options: ``BearCalibrator`` keywords; only the driver parameters in :data:`DRIVER_PARAMETERS`.
        poll_rate_hz: the driver's poll rate (default: the driver's own, twice the scan rate).
        port_options: faults of the virtual port (``drop``, ``garbage``, ``corrupt``: touch_sim.virtual_port).

    Attributes:
        counters: after :meth:`cycles` has run: the driver's frames, dropped bytes, checksum errors,
            sequence gaps, corrupt frames and reconnects, and the graph's callback errors.
    """

    def __init__(self, stimulus: Any, rate_hz: float = REAL_RATE_HZ, seed: int = 0,
                 device_options: dict | None = None, calibrator_options: dict | None = None,
                 poll_rate_hz: float | None = None, port_options: dict | None = None) -> None:
        if not (rate_hz > 0 and math.isfinite(rate_hz)):
            raise ValueError(f'rate_hz must be a positive number of scans per second; got {rate_hz}')
        if poll_rate_hz is not None and not (poll_rate_hz > 0 and math.isfinite(poll_rate_hz)):
            raise ValueError(f'poll_rate_hz must be a positive number; got {poll_rate_hz}')
        unknown = sorted(set(calibrator_options or {}) - set(DRIVER_PARAMETERS))
        if unknown:
            raise ValueError(f'calibrator options {unknown} are not bear_driver parameters; settable: '
                             f'{", ".join(DRIVER_PARAMETERS)}')
        self.stimulus = stimulus
        self.rate_hz = float(rate_hz)
        self.seed = int(seed)
        self.frame_period = 1.0 / self.rate_hz
        self.url_options = url_options(rate_hz, device_options)   # ValueError now, not when iterating
        self.url_options.update({k: str(v) for k, v in (port_options or {}).items()})
        self.parameters: dict[str, Any] = {'expected_rate_hz': self.rate_hz, **(calibrator_options or {})}
        if poll_rate_hz is not None:
            self.parameters['poll_rate_hz'] = float(poll_rate_hz)
        self.counters: dict[str, int] = {}

    def cycles(self, duration_s: float) -> Iterator[Cycle]:
        """Calibrated scans of device time [0, ``duration_s``): frame ``i`` (scan time ``i / rate``) comes when
        ``i / rate < duration_s``; frames lost on the (virtual) wire are missing, not padded."""
        run = DeviceRun('bear', self.stimulus, seed=self.seed, url_options=self.url_options,
                        driver_parameters=self.parameters)
        for _, msg, t in run.messages(wire_frames_before(duration_s), [('/bear/frame', 'BearFrame')]):
            yield Cycle(t, msg.level, msg.faults != 0)
        self.counters = run.counters
