"""Contact on the robot's 11 capacitive panels (sympartner2018 4).

"In software, there is a continuously working calibration implemented. This allows to find
the individual quiescent values for each of the panels by means of a moving average filter
[...] For recognizing a touch event, we introduced a simple threshold for the difference of
the actual signal and the average." Per panel p::

    delta_p   = polarity * (signal_p - quiescent_p)        counts
    contact_p = delta_p > threshold_p   (held until delta_p <= release_fraction * threshold_p)

``quiescent_p`` is a box moving average: the mean of a ring of ``window_s * rate_hz`` slots,
one per sample. A sample taken while the panel is touched (delta above ``freeze_fraction *
threshold``) does not overwrite its slot, which keeps the value it had one window ago: a hand
resting on the shell for minutes would otherwise become the new quiescent value and the
robot would stop noticing it is held. The first sample fills the whole ring. After ``max_freeze_s`` of
continuous freezing learning resumes, so a lasting change of the surroundings (parked
against a couch) is absorbed instead of reading as contact for ever.

>>> cal = PanelCalibrator(n_panels=2, threshold=40.0, rate_hz=20.0, window_s=1.0)
>>> for _ in range(20):
...     state = cal.update([500, 700])
>>> state = cal.update([560, 705])
>>> state.contact.tolist(), state.any_contact, state.delta.tolist()
([True, False], True, [60.0, 5.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from touch_driver.patch.protocol import N_PANELS
from touch_graph.paths import share_file
from touch_graph.yamlconf import YamlDict, YamlList, check_keys, load_yaml, typed

#: Allowed ranges of the file's scalars: (low, high], as shown in the error.
_SCALAR_RANGES = {'threshold': (0.0, math.inf, '(0, inf) counts (positive)'), 'release_fraction': (0.0, 1.0, '(0, 1]'),
                  'freeze_fraction': (0.0, 1.0, '(0, 1]'), 'window_s': (0.0, 3600.0, '(0, 3600] s'),
                  'max_freeze_s': (0.0, math.inf, '(0, inf) s (positive)')}

__all__ = ['PanelCalibrator', 'PanelState']


@dataclass(frozen=True, slots=True)
class PanelState:
    """Panel contact after one sample; arrays are (n_panels,).

    Attributes:
        delta: float32 counts, polarity * (signal - quiescent); 0 where the sample was invalid.
        contact: bool, per panel.
        any_contact: someone is handling the robot (stop driving).
        quiescent: float32 counts, the moving-average quiescent value.
    """

    delta: np.ndarray
    contact: np.ndarray
    any_contact: bool
    quiescent: np.ndarray


class PanelCalibrator:
    """Moving-average quiescent value and contact threshold per panel.

    Args:
        n_panels: 11 on the paper's robot.
        threshold: contact threshold in counts, scalar or (n_panels,). The paper gives no number
            ("high enough to avoid false detections"); 40 suits the simulator.
        rate_hz: samples per second (20 for averaged frames, 100 for raw scans).
        window_s: length of the moving average, seconds.
        release_fraction: contact ends when delta falls to this fraction of the threshold (hysteresis).
        freeze_fraction: samples with delta above this fraction of the threshold are not averaged in.
        max_freeze_s: after this long frozen, learning resumes; None never resumes.
        polarity: +1 when touch raises the signal, -1 when it lowers it.
        names: optional panel names (from config/panels.yaml).
    """

    def __init__(self, n_panels: int = N_PANELS, threshold: float | np.ndarray = 40.0, rate_hz: float = 20.0,
                 window_s: float = 10.0, release_fraction: float = 0.7, freeze_fraction: float = 0.5,
                 max_freeze_s: float | None = 120.0, polarity: int = 1,
                 names: tuple[str, ...] | None = None) -> None:
        thr = np.broadcast_to(np.asarray(threshold, dtype=np.float64), (n_panels,)).copy()
        if n_panels < 1 or not (np.isfinite(thr).all() and (thr > 0).all()):
            raise ValueError(f'n_panels >= 1 and positive finite thresholds are required; got {n_panels}, {threshold}')
        if rate_hz <= 0 or window_s <= 0 or not 0 < release_fraction <= 1 or not 0 < freeze_fraction <= 1:
            raise ValueError('rate_hz, window_s > 0 and release_fraction, freeze_fraction in (0, 1] are required')
        if polarity not in (1, -1):
            raise ValueError(f'polarity must be +1 or -1; got {polarity}')
        if names is not None and len(names) != n_panels:
            raise ValueError(f'{len(names)} names for {n_panels} panels')
        self.n_panels, self.threshold, self.polarity = int(n_panels), thr, int(polarity)
        self.rate_hz, self.release_fraction, self.freeze_fraction = float(rate_hz), release_fraction, freeze_fraction
        self.window = max(1, round(window_s * rate_hz))
        self.max_freeze = None if max_freeze_s is None else max(1, round(max_freeze_s * rate_hz))
        self.names = names
        self._release = self.release_fraction * thr
        self._freeze = self.freeze_fraction * thr
        self.reset()

    @classmethod
    def from_yaml(cls, path: str | Path | None = None, rate_hz: float = 20.0, n_panels: int | None = None,
                  **overrides) -> PanelCalibrator:
        """Build from ``config/panels.yaml`` (default) or another file of that layout; ``n_panels``, when
        given, is the number of panel signals the sensor sends, which the file must list."""
        path = share_file('config', 'panels.yaml') if path is None else Path(path)
        doc = load_yaml(path)
        scalars = ('threshold', 'release_fraction', 'freeze_fraction', 'window_s', 'max_freeze_s')
        check_keys(doc, required=('panels',), optional=('format', *scalars, 'polarity'), what='panel config')
        kwargs: dict = {k: typed(doc, k, float, 'panel config') for k in scalars if k in doc}
        for key, (low, high, shown) in _SCALAR_RANGES.items():
            if key in kwargs and not low < kwargs[key] <= high:
                raise doc.error(f'{key} must be in {shown}; got {kwargs[key]!r}', key)
        if 'polarity' in doc:
            kwargs['polarity'] = typed(doc, 'polarity', int, 'panel config')
        panels = doc['panels']
        if not isinstance(panels, YamlList) or not panels:
            raise doc.error('panels must be a non-empty list of {name, threshold (optional)}', 'panels')
        names, thresholds = [], []
        for i, item in enumerate(panels):
            if not isinstance(item, YamlDict):
                raise panels.error(f'panel #{i + 1} must be a mapping {{name: ..., threshold: ...}}', i)
            check_keys(item, required=('name',), optional=('threshold',), what=f'panel #{i + 1}')
            names.append(typed(item, 'name', str, f'panel #{i + 1}'))
            thresholds.append(typed(item, 'threshold', float, f'panel #{i + 1}', default=kwargs.get('threshold', 40.0)))
            if not 0 < thresholds[-1] < math.inf:
                raise item.error(f'threshold of panel #{i + 1} must be in (0, inf) counts (positive); '
                                 f'got {thresholds[-1]!r}', 'threshold' if 'threshold' in item else None)
        if len(set(names)) != len(names):
            raise panels.error('panel names must be unique')
        if n_panels is not None and len(names) != n_panels:
            raise doc.error(f'the sensor sends {n_panels} panel signals; panels lists {len(names)}', 'panels')
        kwargs.update(threshold=np.array(thresholds), names=tuple(names), rate_hz=rate_hz)
        kwargs.update(overrides)
        try:
            return cls(n_panels=len(names), **kwargs)
        except ValueError as err:
            raise doc.error(str(err)) from err

    def reset(self) -> None:
        """Forget the averages, contact states and counters."""
        n = self.n_panels
        self._ring = np.zeros((self.window, n), dtype=np.float64)  # bounded: one slot per frame of the window
        self._pos = 0
        self._sum = np.zeros(n, dtype=np.float64)
        self._started = np.zeros(n, dtype=bool)
        self._all_started = False
        self._frozen_for = np.zeros(n, dtype=np.int64)
        self._frames = 0
        self.contact = np.zeros(n, dtype=bool)
        #: samples rejected as NaN / infinite since the last reset
        self.invalid_samples = 0

    @property
    def quiescent(self) -> np.ndarray:
        """(n_panels,) float64 moving average; NaN for a panel with no sample yet."""
        return np.where(self._started, self._sum / self.window, np.nan)

    def update(self, signal: np.ndarray) -> PanelState:
        """One sample of every panel: (n_panels,) counts (any numeric dtype)."""
        x = np.asarray(signal)
        finite = x.dtype.kind in 'iub'   # integer counts (the decoder's uint16) need no check
        x = x.astype(np.float64, copy=False)
        if x.shape != (self.n_panels,):
            raise ValueError(f'expected ({self.n_panels},) panel signals; got shape {x.shape}')
        if not (self._all_started and (finite or np.isfinite(x).all())):
            return self._update_general(x)
        q = self._sum / self.window
        delta = x - q if self.polarity == 1 else q - x
        self.contact = (delta > self.threshold) | (self.contact & (delta > self._release))
        # Learn only calm samples; a long freeze eventually gives way (see the module docstring).
        calm = delta <= self._freeze
        self._frozen_for = (self._frozen_for + 1) * ~calm
        learn = calm if self.max_freeze is None else calm | (self._frozen_for > self.max_freeze)
        self._advance(x if learn.all() else np.where(learn, x, self._ring[self._pos]))
        return PanelState(delta=delta.astype(np.float32), contact=self.contact.copy(),
                          any_contact=bool(self.contact.any()), quiescent=q.astype(np.float32))

    def _update_general(self, x: np.ndarray) -> PanelState:
        """:meth:`update` with invalid samples or panels that have not had a sample yet."""
        valid = np.isfinite(x)
        self.invalid_samples += int(self.n_panels - np.count_nonzero(valid))
        first = valid & ~self._started
        if first.any():  # the first sample fills the window: it is the quiescent value to start with
            self._ring[:, first] = x[first]
            self._sum[first] = self.window * x[first]
            self._started |= first
            self._all_started = bool(self._started.all())
        q = np.where(self._started, self._sum / self.window, np.nan)
        use = valid & ~first
        delta = np.where(use, self.polarity * (np.where(use, x, 0.0) - np.where(use, q, 0.0)), 0.0)
        contact = (delta > self.threshold) | (self.contact & (delta > self._release))
        self.contact = np.where(valid, contact, self.contact)  # no news keeps the last state
        calm = delta <= self._freeze
        self._frozen_for = np.where(use, (self._frozen_for + 1) * ~calm, self._frozen_for)
        learn = calm if self.max_freeze is None else calm | (self._frozen_for > self.max_freeze)
        self._advance(np.where(learn & use, x, self._ring[self._pos]))
        return PanelState(delta=delta.astype(np.float32), contact=self.contact.copy(),
                          any_contact=bool(self.contact.any()), quiescent=q.astype(np.float32))

    def _advance(self, new: np.ndarray) -> None:
        """Write this frame's slot: the sample where learned, the slot's old value where frozen."""
        slot = self._ring[self._pos]
        self._sum += new - slot
        slot[...] = new
        self._pos = (self._pos + 1) % self.window
        self._frames += 1
        if self._frames % (16 * self.window) == 0:  # re-sum now and then: no rounding creep on long runs
            self._sum = self._ring.sum(axis=0)
