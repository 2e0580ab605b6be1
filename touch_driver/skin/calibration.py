"""Calibration of the optoelectronic skin: raw counts -> pressure map, contact point, module forces.

:class:`SkinCalibrator` is a pure, stateful object with bounded state (a few (144,) arrays):
feed it the (144,) uint16 frames of :func:`~touch_driver.skin.protocol.decode_payload` in order and
it returns a :class:`SkinState` per frame.

What it does per frame, in order (the constants are fields of :class:`SkinCalibrationConfig`):

1. **Faults.** A taxel is *dead* for this frame when it reads ``<= dead_counts`` (an LED or
   phototransistor that gives no light: pressing only ever raises the counts), when its value
   did not change during the last whole window of ``stuck_s`` (real ADC noise always moves it),
   or when it sat saturated for such a window while none of its 8 neighbours is pressed (a
   finger cannot load one taxel alone through the silicone). Taxels that rested at or below
   ``dead_counts`` or at saturation during the tare stay dead until :meth:`SkinCalibrator.retare`.
   Dead taxels read pressure 0 and are left out of the contact point, the contact test, the forces
   and drift tracking; :attr:`SkinState.dead` flags them. A taxel at ``>= saturation_counts``
   under a real press is kept (it is the most pressed one; its pressure is a lower bound) and
   flagged in :attr:`SkinState.saturated`.
2. **Tare.** The first ``tare_s`` seconds set the per-taxel baseline (mean counts); outputs are
   zero and ``tared`` is False until then.
3. **Pressure** = ``(counts - baseline) / full_scale_counts``, clipped at 0 (unitless; 1 is the
   configured full scale, larger values are allowed).
4. **Contact** with hysteresis: on when any taxel exceeds ``contact_on``, off when all are below
   ``contact_off``. The contact point is the centroid of ``max(pressure - centroid_floor, 0)``
   over taxel centres, in mm; NaN without contact or when the weights sum to zero. Two fingers
   at once give a point between them, weighted by their pressures: the recogniser handles that.
5. **Force** per module: a 3x4 matrix (config) times the four tared, normalised taxel signals
   (not clipped, so a taxel relieved by shear counts negatively), giving (fx, fy, fz) in N. Only
   taxels within one taxel of a taxel above ``centroid_floor`` count, and forces are zero without
   contact: over 144 taxels the noise and drift residue of the untouched skin would otherwise add
   up to a phantom force of a few tenths of a newton.
6. **Drift tracking** (``drift_update_hz`` times a second). Only *quiet* taxels teach the
   baseline: ``|pressure| < drift_gate`` and not within ``guard_taxels`` of a taxel above the
   gate. Their mean offset is the common mode (temperature moves every LED/PT pair of the patch);
   it is tracked with ``common_tau_s`` and applied to *every* taxel, pressed ones included. Each
   quiet taxel's own remainder (LED ageing) is tracked with ``drift_tau_s``. A pressed taxel is
   otherwise frozen, so a press of any length keeps its pressure (skins that fade a long hug to
   zero adapt every taxel; this one does not). A taxel that reads clearly *below* its baseline
   (``<= -drift_gate``, never a press) re-tares with ``recover_tau_s``, which undoes a finger
   resting on the skin during the tare.

Known limits: a true step in one taxel's baseline (silicone permanently dented) is
indistinguishable from a press and is kept as one until :meth:`SkinCalibrator.retare`; a press
that builds up slower than ``drift_gate`` per ``drift_tau_s`` (about 0.02 N/s of finger force at
the model's gain) is taken for drift; a hug that covers every taxel leaves no quiet taxel, and
drift tracking pauses until it ends.
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from .calibration_config import SkinCalibrationConfig, load_skin_calibration
from .protocol import MODULE_TAXELS, N_COLS, N_MODULES, N_ROWS, N_TAXELS, TAXEL_XY_MM

__all__ = ['CalibratedFrames', 'SkinCalibrationConfig', 'SkinCalibrator', 'SkinState', 'calibrate_frames',
           'load_skin_calibration']


class SkinState(NamedTuple):
    """One calibrated skin frame (arrays are new each frame; the caller may keep them)."""

    #: (12, 12) float32, row-major, unitless >= 0: tared pressure, 1 = full scale.
    pressure: np.ndarray
    #: any taxel above the contact threshold (with hysteresis).
    contact: bool
    #: (2,) float32, mm (x along columns, y along rows, from the outer corner of taxel 0); NaN without contact.
    contact_xy_mm: np.ndarray
    #: (36, 3) float32, N: (fx, fy, fz) per module, module-major.
    force: np.ndarray
    #: sum of the modules' fz, N.
    total_force: float
    #: (144,) bool: taxels excluded this frame (dead, stuck, isolated saturation).
    dead: np.ndarray
    #: (144,) bool: taxels at the ADC's full scale this frame.
    saturated: np.ndarray
    #: False while the tare is still being collected (outputs are zero then).
    tared: bool


_XY = np.ascontiguousarray(TAXEL_XY_MM.T)  # (2, 144) for one matrix-vector product
_NAN_XY = np.array([np.nan, np.nan], dtype=np.float32)
_NAN_XY.setflags(write=False)
_ZERO_FORCE = np.zeros(N_MODULES * 3)
_ZERO_FORCE.setflags(write=False)
# The ufunc reductions without ndarray.max/sum's Python wrappers (a third of their cost on 144 values).
_max = np.maximum.reduce
_sum = np.add.reduce


def _dilate(mask: np.ndarray, radius: int) -> np.ndarray:
    """(144,) bool -> (144,) bool grown by ``radius`` taxels in the 12x12 grid (Chebyshev distance)."""
    grid = mask.reshape(N_ROWS, N_COLS)
    for _ in range(radius):
        grown = grid.copy()
        grown[1:] |= grid[:-1]
        grown[:-1] |= grid[1:]
        grid = grown.copy()
        grid[:, 1:] |= grown[:, :-1]
        grid[:, :-1] |= grown[:, 1:]
    return grid.reshape(N_TAXELS)


class SkinCalibrator:
    """Per-taxel tare, drift tracking, contact, contact point and module forces (see the module doc).

    Args:
        config: the constants; :func:`load_skin_calibration` reads them from YAML.

    >>> cal = SkinCalibrator(SkinCalibrationConfig(tare_s=1 / 150, stuck_s=0))
    >>> rest = np.full(144, 40000, dtype=np.uint16)
    >>> cal.update(rest).tared
    False
    >>> pressed = rest.copy(); pressed[5 * 12 + 7] += 8000                  # half full scale on row 5, col 7
    >>> s = cal.update(pressed)
    >>> s.contact, float(s.pressure[5, 7]), [round(float(v), 2) for v in s.contact_xy_mm], round(s.total_force, 3)
    (True, 0.5, [29.38, 21.54], 1.0)
    """

    def __init__(self, config: SkinCalibrationConfig | None = None) -> None:
        self.config = config if config is not None else SkinCalibrationConfig()
        c = self.config
        self._scale = 1.0 / c.full_scale_counts
        self._tare_frames = c.frames(c.tare_s)
        self._stuck_frames = c.frames(c.stuck_s)
        # Drift is slow: track it every few frames, with the per-step gain of that interval.
        self._drift_every = max(1, round(c.rate_hz / c.drift_update_hz))
        self._alpha = -math.expm1(-self._drift_every / (c.drift_tau_s * c.rate_hz))
        self._alpha_common = -math.expm1(-self._drift_every / (c.common_tau_s * c.rate_hz))
        self._alpha_recover = -math.expm1(-self._drift_every / (c.recover_tau_s * c.rate_hz))
        # Block-diagonal (108, 144) matrix: all 36 module products in one matrix-vector product.
        force = np.zeros((N_MODULES * 3, N_TAXELS), dtype=np.float64)
        rows = np.arange(N_MODULES)[:, None, None] * 3 + np.arange(3)[None, :, None]
        force[rows, MODULE_TAXELS[:, None, :]] = c.force_matrices
        self._force = force
        self.invalid_values = 0  # non-finite or out-of-range inputs seen (counted, treated as dead)
        self.retare()

    # ------------------------------------------------------------------ state
    def retare(self) -> None:
        """Forget the baseline and the fault history; the next ``tare_s`` of frames tare again."""
        self._tare_sum = np.zeros(N_TAXELS, dtype=np.float64)
        self._tare_count = np.zeros(N_TAXELS, dtype=np.int64)
        self._tare_seen = 0
        self._baseline = np.zeros(N_TAXELS, dtype=np.float64)
        self._dead_at_tare = np.zeros(N_TAXELS, dtype=bool)
        # Stuck detection: min and max of each taxel over a window of stuck_s; equal = stuck.
        self._win_min = np.full(N_TAXELS, 0xFFFF, dtype=np.uint16)
        self._win_max = np.zeros(N_TAXELS, dtype=np.uint16)
        self._win_frames = 0
        self._stuck = np.zeros(N_TAXELS, dtype=bool)
        self._n_stuck = 0
        self._contact = False
        self.frames = 0

    @property
    def tared(self) -> bool:
        return self._tare_seen >= self._tare_frames

    @property
    def baseline(self) -> np.ndarray:
        """(144,) float64 counts, row-major: the current per-taxel zero (a copy)."""
        return self._baseline.copy()

    # ------------------------------------------------------------------ per frame
    def _as_counts(self, raw: Any) -> tuple[np.ndarray, np.ndarray | None]:
        """Validate one frame -> ((144,) uint16, bad-value mask or None)."""
        arr = np.asarray(raw)
        if arr.shape != (N_TAXELS,):
            if arr.shape != (N_ROWS, N_COLS):
                raise ValueError(f'expected one skin frame of 144 counts, shape (144,) or (12, 12); got {arr.shape}')
            arr = arr.reshape(N_TAXELS)
        if arr.dtype == np.uint16:
            return arr, None
        if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise ValueError(f'expected uint16 ADC counts; got dtype {arr.dtype}')
        with np.errstate(invalid='ignore'):
            bad = (arr < 0) | (arr > 0xFFFF)
            if arr.dtype.kind == 'f':
                bad |= ~np.isfinite(arr)
        if bad.any():
            self.invalid_values += int(bad.sum())
            arr = np.where(bad, 0, arr)
        return np.rint(arr).astype(np.uint16), (bad if bad.any() else None)

    def update(self, raw: np.ndarray) -> SkinState:
        """Calibrate one frame: ``raw`` is (144,) uint16 counts, row-major (a (12, 12) array is accepted).

        Non-finite or out-of-range values (only possible with a float or wide integer input) are
        counted in :attr:`invalid_values` and treated as dead taxels for this frame.
        """
        c = self.config
        counts, bad = self._as_counts(raw)
        if c.invert:
            counts = 0xFFFF - counts
        self.frames += 1

        # 1. faults
        saturated = counts >= c.saturation_counts
        dead = counts <= c.dead_counts
        dead |= self._dead_at_tare
        if bad is not None:
            dead |= bad
        stuck_sat = None
        if self._stuck_frames:
            self._watch_stuck(counts)
            if self._n_stuck:
                dead |= self._stuck & ~saturated
                stuck_sat = self._stuck & saturated
        # 2. tare
        if not self.tared:
            return self._collect_tare(counts.astype(np.float64), dead, saturated)

        # 3. pressure
        resid = np.subtract(counts, self._baseline)   # float64 (uint16 counts convert exactly)
        q = resid * self._scale
        np.copyto(q, 0.0, where=dead)
        if stuck_sat is not None and np.count_nonzero(stuck_sat):
            # Saturated for stuck_s: real only if a neighbour is pressed too.
            pressed = (q > c.drift_gate) & ~stuck_sat
            lonely = stuck_sat & ~_dilate(pressed, 1)
            dead |= lonely
            q[lonely] = 0.0
        pressure = np.maximum(q, 0.0)
        peak = float(_max(pressure))

        # 4. contact and contact point
        self._contact = peak >= (c.contact_off if self._contact else c.contact_on)
        xy = _NAN_XY.copy()
        if self._contact:
            weights = pressure - c.centroid_floor
            np.maximum(weights, 0.0, out=weights)
            total = _sum(weights)
            if total > 0.0:
                xy[:] = (_XY @ weights) / total

        # 5. forces, from the taxels around the pressed ones only: summed over 144 taxels, noise
        # and drift residue of the untouched skin would add up to a sizeable phantom force.
        if self._contact:
            near = _dilate(pressure > c.centroid_floor, 1)
            force = self._force @ (q * near)
            total_force = float(_sum(force[2::3]))
        else:
            force = _ZERO_FORCE
            total_force = 0.0

        # 6. drift, every few frames
        if self.frames % self._drift_every == 0:
            self._track_drift(resid, q, peak, dead)

        return SkinState(pressure.astype(np.float32).reshape(N_ROWS, N_COLS), self._contact, xy,
                         force.astype(np.float32).reshape(N_MODULES, 3), total_force, dead, saturated, True)

    def _collect_tare(self, sig: np.ndarray, dead: np.ndarray, saturated: np.ndarray) -> SkinState:
        ok = ~dead
        self._tare_sum += np.where(ok, sig, 0.0)
        self._tare_count += ok
        self._tare_seen += 1
        if self.tared:
            count = self._tare_count
            self._baseline = np.where(count > 0, self._tare_sum / np.maximum(count, 1), sig)
            c = self.config
            self._dead_at_tare = ((count == 0) | (self._baseline <= c.dead_counts)
                                  | (self._baseline >= c.saturation_counts))
        return SkinState(np.zeros((N_ROWS, N_COLS), dtype=np.float32), False, _NAN_XY.copy(),
                         np.zeros((N_MODULES, 3), dtype=np.float32), 0.0, dead, saturated, False)

    def _track_drift(self, resid: np.ndarray, q: np.ndarray, peak: float, dead: np.ndarray) -> None:
        """Move the baseline of quiet taxels towards their counts; see the module doc, step 6."""
        c = self.config
        live = ~dead
        if peak > c.drift_gate:
            live &= ~_dilate(q > c.drift_gate, c.guard_taxels)
        quiet = live & (np.abs(q) < c.drift_gate)
        n_quiet = np.count_nonzero(quiet)
        if n_quiet:
            # Common mode (temperature moves every LED/PT pair of the patch): the quiet taxels' mean
            # offset, applied to all taxels, pressed ones included. Then each quiet taxel's own part.
            common = _sum(resid[quiet]) / n_quiet
            self._baseline += self._alpha_common * common
            self._baseline += (quiet * self._alpha) * (resid - common)
        below = live & (q <= -c.drift_gate)
        if np.count_nonzero(below):
            self._baseline += (below * self._alpha_recover) * resid

    def _watch_stuck(self, counts: np.ndarray) -> None:
        """Update the window min/max; at the end of each ``stuck_s`` window, taxels that never moved are stuck."""
        np.minimum(self._win_min, counts, out=self._win_min)
        np.maximum(self._win_max, counts, out=self._win_max)
        self._win_frames += 1
        if self._win_frames >= self._stuck_frames:
            self._stuck = self._win_min == self._win_max
            self._n_stuck = int(np.count_nonzero(self._stuck))
            self._win_min[:] = 0xFFFF
            self._win_max[:] = 0
            self._win_frames = 0


class CalibratedFrames(NamedTuple):
    """:func:`calibrate_frames` output for n frames; fields as in :class:`SkinState`, stacked."""

    pressure: np.ndarray       # (n, 12, 12) float32
    contact: np.ndarray        # (n,) bool
    contact_xy_mm: np.ndarray  # (n, 2) float32, NaN without contact
    force: np.ndarray          # (n, 36, 3) float32, N
    total_force: np.ndarray    # (n,) float32, N
    tared: np.ndarray          # (n,) bool


def calibrate_frames(frames: np.ndarray, config: SkinCalibrationConfig | None = None) -> CalibratedFrames:
    """Run a fresh :class:`SkinCalibrator` over (n, 144) uint16 frames (e.g. from ``render_frames``)."""
    frames = np.asarray(frames)
    if frames.ndim != 2 or frames.shape[1] != N_TAXELS:
        raise ValueError(f'expected frames of shape (n, 144); got {frames.shape}')
    cal = SkinCalibrator(config)
    n = len(frames)
    out = CalibratedFrames(np.zeros((n, N_ROWS, N_COLS), np.float32), np.zeros(n, bool),
                           np.full((n, 2), np.nan, np.float32), np.zeros((n, N_MODULES, 3), np.float32),
                           np.zeros(n, np.float32), np.zeros(n, bool))
    for i, raw in enumerate(frames):
        s = cal.update(raw)
        out.pressure[i], out.contact[i], out.contact_xy_mm[i] = s.pressure, s.contact, s.contact_xy_mm
        out.force[i], out.total_force[i], out.tared[i] = s.force, s.total_force, s.tared
    return out
