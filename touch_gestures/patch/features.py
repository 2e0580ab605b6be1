"""The twelve sliding-window features of the textile patch (sympartner2018 6.2).

Per frame the activation map ``r`` (eq. 2, in [k, 1]; cells outside the outline 0) gives ``f1`` max
activation, ``f2`` sum of activations, ``f3`` number of active cells and ``(f4, f5)`` the centre of
activation (row, column, cell units). Over the last ``window`` frames the twelve features are, in
order (:data:`FEATURE_NAMES`): max, mean and variance of f1, f2 and f3; the frames with an active
cell (duration); the distance between consecutive centres (movement); the variance of the 2-D
centre (spread).

Choices the paper leaves open (the incremental and batch code agree):

- **active** means ``r > k + 1e-6`` (a float32 copy of ``k`` may round above it);
- the **centre** is weighted by ``r`` over the active cells only; a frame with none has no centre,
  is left out of the spread, and a step into or out of it adds no distance;
- **spread** is ``var(row) + var(col)`` of the active frames' centres (0 with fewer than two);
  variances are population variances;
- **partial windows** (after a reset) are summarised over the frames seen so far;
- **non-finite cells** are treated as 0 and counted in :attr:`WindowFeatures.nonfinite_cells`.

>>> wf = WindowFeatures(window=3, grid=(2, 2))
>>> wf.update([[0.08, 0.08], [0.08, 0.08]])[[0, 9, 11]]  # an idle frame: floor only
array([0.08, 0.  , 0.  ])
>>> f = wf.update([[1.0, 0.08], [0.08, 0.08]])
>>> f[FEATURE_NAMES.index('active_frames')], f[FEATURE_NAMES.index('active_cells_max')]
(np.float64(1.0), np.float64(1.0))
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

__all__ = ['FEATURE_NAMES', 'WindowFeatures', 'basic_features', 'window_features']

#: Names of the twelve window features, in the order of the feature vector (sympartner2018 6.2).
FEATURE_NAMES: tuple[str, ...] = (
    'max_activation_max', 'max_activation_mean', 'max_activation_var',
    'sum_activation_max', 'sum_activation_mean', 'sum_activation_var',
    'active_cells_max', 'active_cells_mean', 'active_cells_var',
    'active_frames', 'centre_path', 'centre_var',
)
N_FEATURES = len(FEATURE_NAMES)

#: Margin above ``k`` for a cell to count as active (float32 rounding of the floor).
ACTIVE_MARGIN = 1e-6


def _centre_weights(grid: tuple[int, int]) -> np.ndarray:
    """(R*C, 3) float64 columns [1, row, col] for row-major cells: ``x @ W`` gives the moments."""
    rows, cols = np.indices(grid, dtype=np.float64)
    return np.stack([np.ones(rows.size), rows.ravel(), cols.ravel()], axis=1)


def basic_features(activations: np.ndarray, k: float = 0.08) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame basic features of a stack of activation maps.

    Args:
        activations: (T, R, C) activation maps, unitless, nominally in [k, 1].
        k: activation floor of eq. (2) (sympartner2018 6.1, k = 0.08).

    Returns:
        ``(basic, nonfinite)``: basic is (T, 5) float64 ``[f1, f2, f3, row, col]`` with
        NaN centre where the frame has no active cell; nonfinite is (T,) int64, the
        non-finite cells of each frame (treated as 0).
    """
    a = np.asarray(activations, dtype=np.float64)
    if a.ndim != 3:
        raise ValueError(f'activations must be (T, R, C); got shape {a.shape}')
    n_frames, n_rows, n_cols = a.shape
    flat = a.reshape(n_frames, n_rows * n_cols)
    bad = ~np.isfinite(flat)
    nonfinite = bad.sum(axis=1)
    if nonfinite.any():
        flat = np.where(bad, 0.0, flat)
    out = np.full((n_frames, 5), np.nan)
    if n_frames == 0:
        return out, nonfinite
    if flat.shape[1] == 0:
        out[:, :3] = 0.0
        return out, nonfinite
    active = flat > k + ACTIVE_MARGIN
    out[:, 0] = flat.max(axis=1)
    out[:, 1] = flat.sum(axis=1)
    out[:, 2] = active.sum(axis=1)
    moments = np.where(active, flat, 0.0) @ _centre_weights((n_rows, n_cols))
    has = out[:, 2] > 0
    out[has, 3] = moments[has, 1] / moments[has, 0]
    out[has, 4] = moments[has, 2] / moments[has, 0]
    return out, nonfinite


class WindowFeatures:
    """Incremental sliding-window features, one update per frame.

    Args:
        window: window length in frames (sympartner2018 6.2: 3 s at 20 Hz = 60).
        k: activation floor of eq. (2) (sympartner2018 6.1: 0.08); cells above it are active.
        grid: (rows, cols) of the activation map (the patch: 16 x 16; CoST: 8 x 8).
        recompute_every: frames between exact recomputations of the running sums.

    Cost and accuracy: the per-frame basic features take a few vectorised numpy calls; the
    window statistics are kept as running sums of *shifted* values (``q - K``) over a ring
    buffer, and the maxima in monotonic deques, so an update is O(1) amortised in the window
    length. The shift ``K`` starts at the first frame's values (a constant signal then has
    exactly zero variance); every ``recompute_every`` frames (default: the window length)
    the sums are recomputed exactly (``math.fsum``) from the ring buffer and ``K`` moved to
    the current mean. This bounds the rounding error that add/subtract accumulates on long
    runs, and keeps ``S2 - S1**2 / n`` free of catastrophic cancellation (``S1`` stays near
    0), even for a large, nearly constant ``f2``; variances are clamped at 0. A frame without
    an active cell costs three numpy reductions. State is bounded by the window.
    """

    def __init__(self, window: int = 60, k: float = 0.08, grid: tuple[int, int] = (16, 16),
                 recompute_every: int | None = None) -> None:
        if int(window) != window or window < 1:
            raise ValueError(f'window must be a positive number of frames; got {window!r}')
        if len(grid) != 2 or min(grid) < 1:
            raise ValueError(f'grid must be (rows, cols) with both >= 1; got {grid!r}')
        if not math.isfinite(k):
            raise ValueError(f'k must be a finite activation floor (paper: 0.08); got {k!r}')
        self.window = int(window)
        self.k = float(k)
        self.grid = (int(grid[0]), int(grid[1]))
        self.recompute_every = int(recompute_every or self.window)
        self._n_cells = self.grid[0] * self.grid[1]
        self._weights = _centre_weights(self.grid)
        self._threshold = self.k + ACTIVE_MARGIN
        # Centres are shifted by the grid middle, so their squares stay small.
        self._mid = ((self.grid[0] - 1) / 2.0, (self.grid[1] - 1) / 2.0)
        self.reset()

    def reset(self) -> None:
        """Forget the window (a new session); keep the counters."""
        w = self.window
        self._t = 0                      # frames since reset
        self._ring_q = [[0.0, 0.0, 0.0] for _ in range(w)]   # f1, f2, f3 per slot
        self._ring_c: list[tuple[float, float] | None] = [None] * w  # shifted centre or None
        self._ring_d = [0.0] * w         # distance to the previous frame's centre
        self._shift = [0.0, 0.0, 0.0]
        self._s1 = [0.0, 0.0, 0.0]
        self._s2 = [0.0, 0.0, 0.0]
        self._maxq: list[deque] = [deque(), deque(), deque()]  # (t, value), values decreasing
        self._active_t: deque[int] = deque()  # frame numbers of active frames in the window
        self._cn = 0
        self._cs = [0.0, 0.0, 0.0, 0.0]  # sum row, sum col, sum row^2, sum col^2 (shifted)
        self._dsum = 0.0
        self._prev_centre: tuple[float, float] | None = None
        self._since_recompute = 0
        if not hasattr(self, 'nonfinite_cells'):
            self.nonfinite_cells = 0     # non-finite cells seen (treated as 0)
            self.frames = 0              # frames seen

    @property
    def filled(self) -> int:
        """Frames in the window now (< window only just after a reset)."""
        return min(self._t, self.window)

    @property
    def onset_age(self) -> int | None:
        """Frames from the oldest active frame in the window to the newest frame, or None."""
        if not self._active_t:
            return None
        return self._t - 1 - self._active_t[0]

    # ------------------------------------------------------------------ per frame
    def _frame_basic(self, frame: np.ndarray) -> tuple[float, float, int, tuple[float, float] | None]:
        x = np.asarray(frame, dtype=np.float64).reshape(-1)
        if x.shape[0] != self._n_cells:
            raise ValueError(f'activation frame has {x.shape[0]} cells; expected {self._n_cells} for a '
                             f'{self.grid[0]}x{self.grid[1]} grid (set grid= to the sensor layout)')
        with np.errstate(invalid='ignore', over='ignore'):  # inf + -inf: detected just below
            f2 = float(x.sum())
        if not math.isfinite(f2):  # a non-finite cell makes the sum non-finite: slow path only then
            bad = ~np.isfinite(x)
            self.nonfinite_cells += int(bad.sum())
            x = np.where(bad, 0.0, x)
            f2 = float(x.sum())
        f1 = float(x.max())
        if f1 <= self._threshold:  # no active cell (most frames): nothing more to compute
            return f1, f2, 0, None
        active = x > self._threshold
        f3 = int(np.count_nonzero(active))
        s, sr, sc = (x * active) @ self._weights
        return f1, f2, f3, (sr / s - self._mid[0], sc / s - self._mid[1])

    def update(self, activation: np.ndarray) -> np.ndarray:
        """Add one frame and return the window's features.

        Args:
            activation: (R, C) or (R*C,) activation map, row-major, unitless in [k, 1].

        Returns:
            (12,) float64 features in the order of :data:`FEATURE_NAMES`.

        Raises:
            ValueError: when the frame does not have R*C cells.
        """
        f1, f2, f3, centre = self._frame_basic(activation)
        self.frames += 1
        w, t = self.window, self._t
        slot = t % w
        full = t >= w
        q_new = (f1, f2, float(f3))
        ring_q = self._ring_q[slot]
        shift, s1, s2 = self._shift, self._s1, self._s2
        if t == 0:  # shift by the first values: a constant signal then sums exact zeros
            shift[:] = q_new
        for i in range(3):
            new = q_new[i] - shift[i]
            if full:
                old = ring_q[i] - shift[i]
                s1[i] += new - old
                s2[i] += new * new - old * old
            else:
                s1[i] += new
                s2[i] += new * new
            ring_q[i] = q_new[i]
            dq = self._maxq[i]
            while dq and dq[-1][1] <= q_new[i]:
                dq.pop()
            dq.append((t, q_new[i]))
            if dq[0][0] <= t - w:
                dq.popleft()
        # centre statistics over active frames
        if full:
            old_c = self._ring_c[slot]
            if old_c is not None:
                self._remove_centre(old_c)
            self._dsum -= self._ring_d[slot]
            if self._active_t and self._active_t[0] <= t - w:
                self._active_t.popleft()
        d = 0.0
        if centre is not None:
            self._add_centre(centre)
            self._active_t.append(t)
            prev = self._prev_centre
            if prev is not None:
                d = math.hypot(centre[0] - prev[0], centre[1] - prev[1])
        self._ring_c[slot] = centre
        self._ring_d[slot] = d
        self._dsum += d
        self._prev_centre = centre
        self._t = t + 1
        self._since_recompute += 1
        if self._since_recompute >= self.recompute_every:
            self._recompute()
        return self._features()

    def _add_centre(self, c: tuple[float, float]) -> None:
        cs = self._cs
        self._cn += 1
        cs[0] += c[0]
        cs[1] += c[1]
        cs[2] += c[0] * c[0]
        cs[3] += c[1] * c[1]

    def _remove_centre(self, c: tuple[float, float]) -> None:
        cs = self._cs
        self._cn -= 1
        cs[0] -= c[0]
        cs[1] -= c[1]
        cs[2] -= c[0] * c[0]
        cs[3] -= c[1] * c[1]

    def _slots(self) -> list[int]:
        """Ring slots of the frames in the window, oldest first."""
        n, t, w = self.filled, self._t, self.window
        return [(t - n + i) % w for i in range(n)]

    def _recompute(self) -> None:
        """Exact sums from the ring buffer, shifted by the current means."""
        self._since_recompute = 0
        slots = self._slots()
        n = len(slots)
        for i in range(3):
            vals = [self._ring_q[s][i] for s in slots]
            shift = math.fsum(vals) / n
            self._shift[i] = shift
            self._s1[i] = math.fsum(v - shift for v in vals)
            self._s2[i] = math.fsum((v - shift) ** 2 for v in vals)
        centres = [self._ring_c[s] for s in slots if self._ring_c[s] is not None]
        self._cn = len(centres)
        self._cs = [math.fsum(c[0] for c in centres), math.fsum(c[1] for c in centres),
                    math.fsum(c[0] * c[0] for c in centres), math.fsum(c[1] * c[1] for c in centres)]
        self._dsum = math.fsum(self._ring_d[s] for s in slots)

    def _features(self) -> np.ndarray:
        n = self.filled
        out = [0.0] * N_FEATURES
        for i in range(3):
            mean_dev = self._s1[i] / n
            out[3 * i] = self._maxq[i][0][1]
            out[3 * i + 1] = self._shift[i] + mean_dev
            out[3 * i + 2] = max(self._s2[i] / n - mean_dev * mean_dev, 0.0)
        out[9] = float(self._cn)
        # The oldest frame's step leads from a frame outside the window: not counted.
        oldest = (self._t - n) % self.window
        out[10] = max(self._dsum - self._ring_d[oldest], 0.0) if n > 1 else 0.0
        cn = self._cn
        if cn > 1:
            cs = self._cs
            mr, mc = cs[0] / cn, cs[1] / cn
            out[11] = max(cs[2] / cn - mr * mr, 0.0) + max(cs[3] / cn - mc * mc, 0.0)
        return np.array(out, dtype=np.float64)


def window_features(activations: np.ndarray, window: int = 60, k: float = 0.08,
                    chunk: int = 8192) -> np.ndarray:
    """Window features of every frame of a session at once (for training and evaluation).

    Gives the same values as feeding the frames one by one to a fresh
    :class:`WindowFeatures` (up to rounding), vectorised.

    Args:
        activations: (T, R, C) activation maps of one continuous session, unitless in [k, 1].
        window: window length in frames (paper: 60).
        k: activation floor (paper: 0.08).
        chunk: frames processed at a time (bounds memory to about chunk * window * 8 bytes).

    Returns:
        (T, 12) float64, row t = features of the window ending at frame t.
    """
    if int(window) != window or window < 1:
        raise ValueError(f'window must be a positive number of frames; got {window!r}')
    window = int(window)
    a = np.asarray(activations)
    if a.ndim != 3:
        raise ValueError(f'activations must be (T, R, C); got shape {a.shape}')
    n_frames = a.shape[0]
    out = np.zeros((n_frames, N_FEATURES))
    if n_frames == 0:
        return out
    basic = np.concatenate([basic_features(a[i:i + chunk], k)[0] for i in range(0, n_frames, chunk)])
    has = ~np.isnan(basic[:, 3])
    step = np.zeros(n_frames)
    both = has[1:] & has[:-1]
    step[1:][both] = np.hypot(np.diff(basic[:, 3])[both], np.diff(basic[:, 4])[both])
    for start in range(0, n_frames, chunk):
        stop = min(start + chunk, n_frames)
        lo = max(0, start - window + 1)
        pad = window - 1 - (start - lo)  # missing history before frame 0
        seg = slice(lo, stop)

        def win(values: np.ndarray, fill: float = np.nan, _pad: int = pad) -> np.ndarray:
            v = np.concatenate([np.full(_pad, fill), values])
            return sliding_window_view(v, window)

        for i in range(3):
            view = win(basic[seg, i])
            out[start:stop, 3 * i] = np.nanmax(view, axis=1)
            out[start:stop, 3 * i + 1] = np.nanmean(view, axis=1)
            out[start:stop, 3 * i + 2] = np.nanvar(view, axis=1)
        out[start:stop, 9] = win(has[seg].astype(np.float64), 0.0).sum(axis=1)
        steps = win(step[seg], 0.0)
        out[start:stop, 10] = steps[:, 1:].sum(axis=1)
        rows, cols = win(basic[seg, 3]), win(basic[seg, 4])
        counts = out[start:stop, 9]
        spread = np.zeros(stop - start)
        many = counts > 1
        if many.any():
            spread[many] = np.nanvar(rows[many], axis=1) + np.nanvar(cols[many], axis=1)
        out[start:stop, 11] = spread
    return out
