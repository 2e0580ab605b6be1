"""Textile patch calibration: raw counts -> normalised activation in [k, 1] (sympartner2018 6.1).

The chain, per cell (i, j) of the 16x16 matrix:

1. **Moving average and sub-sampling** (:class:`ScanAverager`), only for firmware that
   streams every 100 Hz scan (frame id 0x51): the mean of the last ``window`` scans,
   output every ``decimation``-th scan, so 100 Hz -> 20 Hz. This gives ``a_t``.
2. **Running minimum**, eq. (1): ``m_t = min{a_t, m_{t-1} + tau (a_t - m_{t-1})}``.
   As printed, this follows the signal *down at once* (when ``a_t < m_{t-1}`` the second
   term is above ``a_t``, so ``m_t = a_t``) and *up slowly*, by the fraction ``tau`` of
   the gap per frame (time constant ``1 / (tau * 20 Hz)``; for the default ``tau = 0.001``
   = 50 s). So the resting state may creep up after a press (sympartner2018 5.3) without
   a press being learned quickly: a push of ``d`` seconds loses the fraction
   ``1 - exp(-d * 20 * tau)`` of its activation (= 0.058 for d = 3 s and the default tau).
   On a stationary signal m settles a few noise standard deviations below the mean and
   stays there (bounded, no drift).
3. **Normalised activation**, eq. (2): ``r_t = min{max{g (a_t - m_t), k}, 1}`` with a
   per-cell gain ``g`` and the floor ``k = 0.08`` that "cancels out noise and crosstalk
   activations". Cells outside the patch outline (config/patch_outline.yaml) read 0.

The paper gives neither tau nor g. The default g = 1/400 per count puts r = 1 at 400 counts
above the resting minimum, about 3.5 N/cm^2 (360 g/cm^2) on the simulated fabric
(touch_sim/patch/device.py), the top of the range the paper calls nearly linear
(below 300-400 g/cm^2); recalibrate it on real hardware.

NaN or out-of-range cells are counted and skipped: their minimum is not updated and they
read k (inside the outline) for that frame.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from touch_driver.patch.panels import PanelCalibrator, PanelState
from touch_driver.patch.protocol import ADC_MAX, GRID
from touch_graph.paths import share_file
from touch_graph.yamlconf import YamlList, check_keys, load_yaml, typed

__all__ = ['PanelCalibrator', 'PanelState', 'PatchActivation', 'PatchCalibrator', 'ScanAverager', 'load_outline']

FORMAT_VERSION = 1


def load_outline(path: str | Path | None = None) -> np.ndarray:
    """(16, 16) bool, True for cells inside the patch outline; default ``config/patch_outline.yaml``.

    Raises:
        ConfigError: with file and line on a malformed file.
    """
    path = share_file('config', 'patch_outline.yaml') if path is None else Path(path)
    doc = load_yaml(path)
    check_keys(doc, required=('outline',), optional=('format', 'grid'), what='patch outline')
    if typed(doc, 'format', int, 'patch outline', default=FORMAT_VERSION) != FORMAT_VERSION:
        raise doc.error(f'patch outline format must be {FORMAT_VERSION}', 'format')
    grid = doc.get('grid', list(GRID))
    if list(grid) != list(GRID):
        raise doc.error(f'grid must be {list(GRID)} (the patch matrix); got {grid!r}', 'grid')
    rows = doc['outline']
    if not isinstance(rows, YamlList) or len(rows) != GRID[0]:
        raise doc.error(f'outline must be a list of {GRID[0]} strings of {GRID[1]} characters', 'outline')
    mask = np.zeros(GRID, dtype=bool)
    for r, row in enumerate(rows):
        if not isinstance(row, str) or len(row) != GRID[1] or set(row) - {'#', '.'}:
            raise rows.error(f"outline row {r} must be {GRID[1]} characters of '#' (inside) and '.' (outside); "
                             f'got {row!r}', r)
        mask[r] = [c == '#' for c in row]
    if not mask.any():
        raise doc.error('the outline has no cell inside: every activation would be masked', 'outline')
    return mask


class ScanAverager:
    """Moving average of the raw 100 Hz scans, sub-sampled to 20 Hz (sympartner2018 6.1).

    Args:
        window: scans averaged (a box filter); default 5, one output period.
        decimation: one output every this many scans; 5 gives 100 Hz -> 20 Hz.
    """

    def __init__(self, window: int = 5, decimation: int = 5, grid: tuple[int, int] = GRID) -> None:
        if window < 1 or decimation < 1:
            raise ValueError(f'window and decimation must be >= 1; got {window}, {decimation}')
        self.window, self.decimation, self.grid = int(window), int(decimation), tuple(grid)
        self.reset()

    def reset(self) -> None:
        self._ring = np.zeros((self.window, *self.grid), dtype=np.float64)  # bounded: window scans
        self._valid = np.ones((self.window, *self.grid), dtype=bool)  # slots not filled yet are never read
        self._invalid_slots: set[int] = set()   # slots holding a scan with a non-finite sample
        self._pushed = 0

    def update(self, scan: np.ndarray) -> np.ndarray | None:
        """Add one (16, 16) scan; return the (16, 16) float32 average when a 20 Hz frame is due, else None.

        Non-finite samples are left out of the average; a cell with none in the window is NaN.
        """
        scan = np.asarray(scan)
        if scan.shape != self.grid:
            raise ValueError(f'a patch scan has shape {self.grid}; got {scan.shape}')
        slot = self._pushed % self.window
        if scan.dtype.kind in 'iub':   # integer counts (the decoder's uint16) are all finite
            self._ring[slot] = scan
            if self._invalid_slots:
                self._valid[slot] = True
                self._invalid_slots.discard(slot)
        else:
            values = scan.astype(np.float64, copy=False)
            valid = np.isfinite(values)
            self._ring[slot] = np.where(valid, values, 0.0)
            self._valid[slot] = valid
            if valid.all():
                self._invalid_slots.discard(slot)
            else:
                self._invalid_slots.add(slot)
        self._pushed += 1
        if self._pushed % self.decimation:
            return None
        filled = min(self._pushed, self.window)
        total = self._ring[:filled].sum(axis=0)
        if not self._invalid_slots:    # every sample of the window counts: the count is ``filled``
            total /= filled
            return total.astype(np.float32)
        count = self._valid[:filled].sum(axis=0)
        with np.errstate(invalid='ignore', divide='ignore'):
            return np.where(count > 0, total / count, np.nan).astype(np.float32)


@dataclass(frozen=True, slots=True)
class PatchActivation:
    """One calibrated 20 Hz frame; arrays are (16, 16), row-major.

    Attributes:
        activation: float32 r of eq. (2), in [k, 1] inside the outline, 0 outside.
        raw: uint16 counts a_t (the averaged frame, rounded; 0 where invalid).
        minimum: float32 m_t of eq. (1), counts.
        in_outline: bool, the cell is part of the patch.
        invalid_cells: cells of this frame that were NaN or outside 0..1023.
    """

    activation: np.ndarray
    raw: np.ndarray
    minimum: np.ndarray
    in_outline: np.ndarray
    invalid_cells: int


class PatchCalibrator:
    """Eq. (1) running minimum and eq. (2) normalised activation per cell (sympartner2018 6.1).

    Args:
        outline: (16, 16) bool mask, or a path to an outline YAML; None reads config/patch_outline.yaml.
        gain: g of eq. (2), level per count: a scalar or (16, 16). Default 1/400 (see module docstring).
        tau: adaptation rate of eq. (1) per 20 Hz frame, in (0, 1]; default 0.001 (time constant 50 s).
        k: floor of eq. (2), 0.08 (sympartner2018 6.1).
        average_window, decimation: of the :class:`ScanAverager` used by :meth:`update_scan`.
        full_scale: counts of the 10-bit converter (1023).
    """

    def __init__(self, outline: np.ndarray | str | Path | None = None, gain: float | np.ndarray = 1.0 / 400.0,
                 tau: float = 0.001, k: float = 0.08, average_window: int = 5, decimation: int = 5,
                 full_scale: int = ADC_MAX) -> None:
        mask = load_outline(outline) if outline is None or isinstance(outline, (str, Path)) else outline
        mask = np.asarray(mask, dtype=bool)
        if mask.shape != GRID:
            raise ValueError(f'outline must be a {GRID} bool mask; got shape {mask.shape}')
        g = np.broadcast_to(np.asarray(gain, dtype=np.float64), GRID).copy()
        if not (np.isfinite(g).all() and (g >= 0).all()):
            raise ValueError('gain must be finite and >= 0 on every cell')
        if not 0.0 < tau <= 1.0:
            raise ValueError(f'tau must be in (0, 1] (a fraction per frame); got {tau}')
        if not 0.0 <= k < 1.0:
            raise ValueError(f'k must be in [0, 1); got {k}')
        self.in_outline = mask.copy()
        self.in_outline.setflags(write=False)  # shared by every PatchActivation
        self.gain, self.tau, self.k, self.full_scale = g, float(tau), float(k), int(full_scale)
        self.averager = ScanAverager(average_window, decimation)
        self.reset()

    def reset(self) -> None:
        """Forget the tracked minima, the scan average and the counters."""
        self.minimum = np.zeros(GRID, dtype=np.float64)
        self._started = np.zeros(GRID, dtype=bool)
        self._all_started = False
        self.averager.reset()
        #: cells rejected as NaN / out of range since the last reset
        self.invalid_cells = 0
        self.frames = 0

    def update(self, frame: np.ndarray) -> PatchActivation:
        """Calibrate one 20 Hz frame a_t: (16, 16) counts (any numeric dtype)."""
        a = np.asarray(frame, dtype=np.float64)
        if a.shape != GRID:
            raise ValueError(f'a patch frame has shape {GRID}; got {a.shape}')
        self.frames += 1
        if self._all_started and np.isfinite(a).all() and a.min() >= 0 and a.max() <= self.full_scale:
            # The common case: every cell valid and started. Eq. (1), in place.
            m = self.minimum
            np.minimum(a, m + self.tau * (a - m), out=m)
            r = self.gain * (a - m)  # eq. (2); a >= m after eq. (1)
            np.clip(r, self.k, 1.0, out=r)
            r *= self.in_outline
            return PatchActivation(activation=r.astype(np.float32), raw=np.rint(a).astype(np.uint16),
                                   minimum=m.astype(np.float32), in_outline=self.in_outline, invalid_cells=0)
        return self._update_general(a)

    def _update_general(self, a: np.ndarray) -> PatchActivation:
        """:meth:`update` with invalid cells, or cells that have not had a valid sample yet."""
        valid = np.isfinite(a) & (a >= 0) & (a <= self.full_scale)
        n_invalid = int(a.size - np.count_nonzero(valid))
        self.invalid_cells += n_invalid
        a = np.where(valid, a, 0.0)
        m = self.minimum
        # Eq. (1); the first valid sample of a cell starts its minimum.
        tracked = np.minimum(a, m + self.tau * (a - m))
        start = valid & ~self._started
        np.copyto(m, np.where(start, a, np.where(valid, tracked, m)))
        self._started |= valid
        self._all_started = bool(self._started.all())
        # Eq. (2): a >= m holds after eq. (1), so g (a - m) >= 0.
        r = np.clip(self.gain * (a - m), self.k, 1.0)
        r[~valid] = self.k
        r[~self.in_outline] = 0.0
        return PatchActivation(activation=r.astype(np.float32), raw=np.rint(a).astype(np.uint16),
                               minimum=m.astype(np.float32), in_outline=self.in_outline, invalid_cells=n_invalid)

    def update_scan(self, scan: np.ndarray) -> PatchActivation | None:
        """Feed one raw 100 Hz scan; a :class:`PatchActivation` every ``decimation`` scans, else None."""
        frame = self.averager.update(scan)
        return None if frame is None else self.update(frame)
