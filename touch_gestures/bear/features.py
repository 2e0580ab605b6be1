"""Per-sensor buffer features for touch subtypes (knight2009 V.D, Table II), all channels at once.

:func:`spectral_features` computes them for a whole (n, 64) buffer with one ``rfft``. For one
channel's buffer ``x`` of ``n`` samples at ``rate_hz``:

- ``peak_amplitude``: ``max(x)``, level 0..1;
- ``base_frequency_hz``: frequency of the largest non-DC bin of ``|rfft(x - mean(x))|``, Hz (the
  *dominant* one, msg/TouchSubtype.msg); 0 when its amplitude ``2|X_k|/n`` is below ``min_component``;
- ``spectral_spread_hz`` (the paper's "noise level"): standard deviation of frequency under the
  non-DC power spectrum, Hz;
- ``duration_s``: kept by :class:`FeatureExtractor`: cycles in a row with the peak >= the activation
  threshold, over ``rate_hz`` (may exceed the buffer span).

Three more are relative to the touch's own peak ``p`` (the largest level of the current touch's samples,
see ``touch_cycles``), so they describe the shape of a touch rather than how hard this person presses:

- ``relative_onset_rate_hz``: up-crossings of ``p / 2`` per second of touch (the touch's first rise
  counts), Hz;
- ``trough_over_peak``: the touch's lowest level over ``p`` (1 for a steady hold, 0 when the hand lifts);
- ``dip_fraction``: share of the touch's samples below ``0.8 p``.

All three are 0 where there is no touch.

One more is for periodic touches that keep contact (a squeezing shake, a rub; knight2009 Table I):

- ``band_share``: share of the touch's non-DC power at frequencies from :data:`BAND_HZ` [0] to [1] Hz
  (at 3.4 Hz only 1 Hz to the scan's Nyquist of 1.7 Hz is seen; faster motion folds below it); 0 for a
  touch without a frequency component (same test as ``base_frequency_hz``).

Never NaN nor an exception: an empty buffer gives zeros, a constant signal 0 Hz; NaN or inf read as 0.

>>> ext = FeatureExtractor(rate_hz=10.0, n_channels=2, window='buffer')
>>> t = np.arange(20) / 10.0
>>> window = np.stack([0.5 + 0.4 * np.sin(2 * np.pi * 2.0 * t), np.full(20, 0.9)], axis=1).astype(np.float32)
>>> f = ext.update(window)
>>> f.base_frequency_hz.tolist(), f.spectral_spread_hz.tolist(), f.duration_s.tolist()
([2.0, 0.0], [0.0, 0.0], [0.10000000149011612, 0.10000000149011612])
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .sensor_level import ACTIVATION_THRESHOLD

__all__ = ['BAND_HZ', 'FEATURE_NAMES', 'MIN_COMPONENT', 'PAPER_FEATURES', 'PERIODIC_CONTACT', 'RELATIVE_SHAPE',
           'BufferFeatures', 'FeatureExtractor',
           'spectral_features']

#: The four features of knight2009 V.D / Table II, the rule classifier's inputs.
PAPER_FEATURES = ('peak_amplitude', 'base_frequency_hz', 'spectral_spread_hz', 'duration_s')
#: Features relative to the touch's own peak (module doc), the last columns of the table.
RELATIVE_SHAPE = ('relative_onset_rate_hz', 'trough_over_peak', 'dip_fraction')
#: Features of periodic touches in contact (module doc), after :data:`RELATIVE_SHAPE`.
PERIODIC_CONTACT = ('band_share',)
#: Every feature, column order of :attr:`BufferFeatures.table`. The last eight feed the trainable
#: classifier only: mean and standard deviation of the level; fraction of the buffer at or above the
#: threshold; latest level; threshold up-crossings per second (pats, taps); share of the non-DC power
#: in the dominant bin (a clean periodic touch vs noise); mean absolute change per second (level/s);
#: seconds since the level was last at or above the threshold (buffer span if never).
#: Then the three relative to the touch's own peak and ``band_share`` (module doc).
FEATURE_NAMES = (*PAPER_FEATURES, 'mean_level', 'std_level', 'active_fraction', 'latest_level', 'onset_rate_hz',
                 'spectral_peakiness', 'roughness_per_s', 'since_active_s', *RELATIVE_SHAPE, *PERIODIC_CONTACT)
#: Smallest sinusoid amplitude (level units, 0..1) that counts as a frequency component. Not from the
#: paper: 0.02 of full scale, about 20 ADC counts of the 10-bit bear, above sensor noise.
MIN_COMPONENT = 0.02
#: Level (over the touch's peak) a touch rises through to count as an onset, and below which a sample dips.
HALF_PEAK, DIP_LEVEL = 0.5, 0.8
#: Band of ``band_share``, Hz: pats, rubs and squeezes of knight2009 Table I (1-3 Hz), above a pet's strokes.
BAND_HZ = (1.0, 3.0)


@dataclass(frozen=True, slots=True)
class BufferFeatures:
    """Features of every channel for one cycle.

    Attributes:
        table: (n_channels, len(FEATURE_NAMES)) float32, columns in :data:`FEATURE_NAMES` order.
    """

    table: np.ndarray

    @property
    def peak_amplitude(self) -> np.ndarray:
        """(n_channels,) max level in the buffer, 0..1."""
        return self.table[:, 0]

    @property
    def base_frequency_hz(self) -> np.ndarray:
        """(n_channels,) dominant non-DC frequency, Hz (0 for a constant signal)."""
        return self.table[:, 1]

    @property
    def spectral_spread_hz(self) -> np.ndarray:
        """(n_channels,) spread of the non-DC spectrum around its centroid, Hz (the paper's noise level)."""
        return self.table[:, 2]

    @property
    def duration_s(self) -> np.ndarray:
        """(n_channels,) time the buffer's peak has stayed >= threshold, s."""
        return self.table[:, 3]


#: Buffers up to this many cycles use a precomputed DFT matrix (one small matrix product, faster than
#: ``rfft``'s call overhead at these sizes); longer ones use ``numpy.fft.rfft``. Same transform either way.
_DFT_MAX_N = 64


class _Grid:
    """Precomputed per-length constants: frequency grid, DFT matrix, detrending ramp."""

    def __init__(self, n: int, rate_hz: float) -> None:
        m = n // 2
        k = np.arange(1, m + 1)
        self.n = n
        self.freqs = (k * (rate_hz / n)).astype(np.float32)   # non-DC bins, Hz
        self.freqs_sq = self.freqs * self.freqs
        self.in_band = ((self.freqs >= BAND_HZ[0]) & (self.freqs <= BAND_HZ[1])).astype(np.float32)
        ramp = np.arange(n, dtype=np.float32) - (n - 1) / 2.0
        denom = float(ramp @ ramp)
        self.ramp = ramp
        self.ramp_unit = ramp / denom if denom > 0 else ramp * 0.0
        # Real and imaginary DFT rows of the non-DC bins, stacked: (2m, n). Each row sums to zero over the
        # buffer, so the DC (mean) need not be removed first.
        angle = 2 * np.pi * np.outer(k, np.arange(n)) / max(n, 1)
        self.dft = np.concatenate([np.cos(angle), np.sin(angle)]).astype(np.float32) if n <= _DFT_MAX_N else None
        self.ones = np.ones(n, dtype=np.float32)
        self.age = np.arange(n)[::-1].copy()     # cycles since each sample of the window was taken


def spectral_features(window: np.ndarray, rate_hz: float, threshold: float = ACTIVATION_THRESHOLD,
                      min_component: float = MIN_COMPONENT, detrend: str = 'constant',
                      touch_cycles: np.ndarray | None = None, _grid: _Grid | None = None,
                      _finite: bool = False) -> np.ndarray:
    """Window features of every channel except ``duration_s`` (left 0; it needs state).

    Args:
        window: (n, n_channels) levels in [0, 1], oldest first; n may be 0.
        rate_hz: scan rate, cycles per second (knight2009 VI.B: 3.4 Hz real).
        threshold: activation threshold for the activity features (knight2009 V.A: 0.3).
        min_component: smallest sinusoid amplitude that counts as a frequency component (level units).
        detrend: ``'constant'`` removes the mean before the FFT; ``'linear'`` also removes a straight
            line, so a slow approach or release does not read as the lowest frequency.
        touch_cycles: optional (n_channels,) int, cycles the current touch has lasted. When given, the
            spectral features (base frequency, spread, peakiness) see only the touch: older samples are
            replaced by the touch's mean, so the step from no touch to a steady hold is not read as a
            low frequency. 0 (no touch) gives 0 Hz.

    Returns:
        (n_channels, len(FEATURE_NAMES)) float32 table (a transposed view of a feature-major array).
    """
    if not rate_hz > 0 or not np.isfinite(rate_hz):
        raise ValueError(f'rate_hz must be a positive number of cycles per second; got {rate_hz!r}')
    if detrend not in ('constant', 'linear'):
        raise ValueError(f"detrend must be 'constant' or 'linear'; got {detrend!r}")
    x = np.asarray(window, dtype=np.float32)
    if x.ndim != 2:
        raise ValueError(f'window must be 2-D (cycles, channels); got shape {x.shape}')
    n, channels = x.shape
    rows = np.zeros((len(FEATURE_NAMES), channels), dtype=np.float32)   # feature-major: contiguous writes
    if n == 0:
        return rows.T
    if not _finite and not np.isfinite(x).all():
        x = np.nan_to_num(x, nan=0.0, posinf=0.0, neginf=0.0)
    grid = _grid if _grid is not None and _grid.n == n else _Grid(n, rate_hz)
    inv_n = 1.0 / n
    # Sums over the buffer axis as products with a ones vector: one BLAS call beats a ufunc reduce here.
    ones = grid.ones
    mean = (ones @ x) * inv_n
    ac = x - mean
    active = (x >= threshold).astype(np.float32)
    rows[0] = x.max(axis=0)
    rows[4] = mean
    rows[5] = np.sqrt((ones @ (ac * ac)) * inv_n)
    rows[6] = (ones @ active) * inv_n
    rows[7] = x[-1]
    if n > 1:
        ones_1 = ones[1:]
        rows[8] = (ones_1 @ np.maximum(active[1:] - active[:-1], 0.0)) * (rate_hz * inv_n)
        rows[10] = (ones_1 @ np.abs(x[1:] - x[:-1])) * (rate_hz / (n - 1))
    # Seconds since the last active sample: argmax on the reversed mask finds the newest one
    # (n, the whole buffer span, when the sensor was never active in it).
    newest = active[::-1].argmax(axis=0)
    rows[11] = np.where(rows[6] > 0, newest, n) * (1.0 / rate_hz)

    keep = None
    if touch_cycles is not None:
        keep = grid.age[:, None] < np.asarray(touch_cycles)[None, :]       # (n, channels): inside the touch
    _relative_shape(x, keep, touch_cycles, rate_hz, rows[12:15])

    m = n // 2
    if m == 0:       # one sample: no non-DC bin, so base frequency, spread and peakiness stay 0
        return rows.T
    if keep is not None:
        kept = ones @ keep.astype(np.float32)
        touch_mean = (ones @ np.where(keep, x, 0.0)) / np.maximum(kept, 1.0)
        ac = np.where(keep, x - touch_mean, 0.0).astype(np.float32)
    if detrend == 'linear':
        ac -= grid.ramp[:, None] * (grid.ramp_unit @ ac)[None, :]
    if grid.dft is not None:
        parts = grid.dft @ ac                                 # (2m, channels): real, imaginary
        parts *= parts
        power = parts[:m] + parts[m:]                         # |X_k|^2, k = 1..m
    else:
        spec = np.fft.rfft(ac, axis=0)[1:]
        power = (spec.real ** 2 + spec.imag ** 2).astype(np.float32)
    total = grid.ones[:m] @ power
    dominant = power.argmax(axis=0)
    peak_power = power.max(axis=0)
    # Sinusoid amplitude of the dominant bin: 2 |X_k| / n.
    periodic = (peak_power >= (min_component * n * 0.5) ** 2) & (total > 0)
    safe_total = np.where(periodic, total, 1.0)
    inv_total = 1.0 / safe_total
    centroid = (grid.freqs @ power) * inv_total
    variance = (grid.freqs_sq @ power) * inv_total - centroid * centroid
    rows[1] = np.where(periodic, grid.freqs[dominant], 0.0)
    rows[2] = np.where(periodic, np.sqrt(np.maximum(variance, 0.0)), 0.0)
    rows[9] = np.where(periodic, peak_power * inv_total, 0.0)
    rows[15] = np.where(periodic, (grid.in_band @ power) * inv_total, 0.0)
    return rows.T


def _relative_shape(x: np.ndarray, keep: np.ndarray | None, touch_cycles: np.ndarray | None, rate_hz: float,
                    out: np.ndarray) -> None:
    """Write the three features of :data:`RELATIVE_SHAPE` into ``out`` ((3, channels)).

    ``x``: (n, channels) finite levels; ``keep``: (n, channels) bool, the samples of the current touch,
    which has lasted ``touch_cycles`` ((channels,) int) cycles (both None: the whole buffer is the touch,
    when it reached the activation threshold at all).
    """
    n = x.shape[0]
    if keep is None:
        keep = np.broadcast_to(x.max(axis=0) >= ACTIVATION_THRESHOLD, x.shape)
        began_inside = True
    else:     # a touch older than the buffer was already up at its first sample: that is no onset
        began_inside = np.asarray(touch_cycles) <= n
    inside = np.where(keep, x, 0.0)
    kept = keep.sum(axis=0)
    peak = inside.max(axis=0)
    touched = (kept > 0) & (peak > 0)
    scale = np.where(touched, 1.0 / np.where(touched, peak, 1.0), 0.0).astype(np.float32)
    rel = inside * scale                                           # (n, channels): 0 outside the touch
    high = (rel >= HALF_PEAK).astype(np.int8)
    onsets = high[0] * began_inside + (np.diff(high, axis=0) > 0).sum(axis=0)
    span_s = np.maximum(kept, 1) / rate_hz
    out[0] = np.where(touched, onsets / span_s, 0.0)
    out[1] = np.where(touched, np.where(keep, rel, np.inf).min(axis=0), 0.0)
    out[2] = np.where(touched, (keep & (rel < DIP_LEVEL)).sum(axis=0) / np.maximum(kept, 1), 0.0)


class FeatureExtractor:
    """Stateful feature computation: the window features plus the duration counter of knight2009 V.D.

    Call :meth:`update` exactly once per scan cycle with the current buffer window.

    Args:
        rate_hz: scan rate in cycles per second (knight2009 VI.B: 3.4 Hz on the real bear).
        threshold: activation threshold (knight2009 V.A: 0.3). Duration counts cycles in a row with
            buffer peak >= threshold, as the V.D pseudocode increments it while amplitude >= 30 %.
        min_component: see :func:`spectral_features`.
        detrend: see :func:`spectral_features`.
        n_channels: channels per cycle.
        window: ``'touch'`` (default): spectral features see only the current touch (see ``touch_cycles`` in
            :func:`spectral_features`); ``'buffer'``: the whole buffer, as the paper's text reads. With
            'buffer' the step from no touch to a hold reads as a low frequency, so the rule calls every hold a
            pet until that step has left the buffer (``buffer_len / rate_hz`` seconds).
    """

    def __init__(self, rate_hz: float, threshold: float = ACTIVATION_THRESHOLD, min_component: float = MIN_COMPONENT,
                 detrend: str = 'constant', n_channels: int = 64, window: str = 'touch') -> None:
        if window not in ('touch', 'buffer'):
            raise ValueError(f"window must be 'touch' or 'buffer'; got {window!r}")
        if detrend not in ('constant', 'linear'):
            raise ValueError(f"detrend must be 'constant' or 'linear'; got {detrend!r}")
        self.window = window
        if not (isinstance(rate_hz, (int, float)) and np.isfinite(rate_hz) and rate_hz > 0):
            raise ValueError(f'rate_hz must be a positive number of cycles per second; got {rate_hz!r}')
        self.rate_hz = float(rate_hz)
        self.threshold = float(threshold)
        self.min_component = float(min_component)
        self.detrend = detrend
        self.n_channels = int(n_channels)
        self.touch_cycles = np.zeros(self.n_channels, dtype=np.int64)
        self._grids: dict[int, _Grid] = {}
        #: skip the NaN scan (set by callers whose windows come from a LevelBuffer, which sanitises them)
        self.assume_finite = False

    def reset(self) -> None:
        self.touch_cycles.fill(0)

    def update(self, window: np.ndarray) -> BufferFeatures:
        """Features of this cycle; (n, n_channels) window in, :class:`BufferFeatures` out.

        The returned table is a fresh array each call (safe to keep).
        """
        shape = np.shape(window)
        if len(shape) != 2 or shape[1] != self.n_channels:
            raise ValueError(f'window must have shape (cycles, {self.n_channels}); got {shape}')
        n = int(shape[0])
        grid = self._grids.get(n)
        if grid is None:
            grid = self._grids[n] = _Grid(max(n, 1), self.rate_hz)
        if n:
            touching = np.asarray(window).max(axis=0) >= self.threshold
            self.touch_cycles = np.where(touching, self.touch_cycles + 1, 0)
        else:
            self.touch_cycles = np.zeros_like(self.touch_cycles)
        table = spectral_features(window, self.rate_hz, self.threshold, self.min_component, self.detrend,
                                  touch_cycles=self.touch_cycles if self.window == 'touch' else None,
                                  _grid=grid, _finite=self.assume_finite)
        table[:, 3] = self.touch_cycles * (1.0 / self.rate_hz)
        return BufferFeatures(table)
