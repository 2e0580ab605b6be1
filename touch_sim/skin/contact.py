"""Finger contact model of the optoelectronic skin simulator: contacts -> per-taxel signal.

A stimulus (``contacts(t) -> list[Contact]``) says where fingers touch at time ``t``;
:class:`FingerContactModel` turns one frame's contacts into each taxel's signal and
:class:`~touch_sim.skin.device.SkinDevice` adds the electronics and the wire format. Every constant
is a parameter. Per frame:

1. **Load spreading**: a normal force ``F`` spreads over the taxels with a Gaussian kernel of width
   ``sigma = hypot(spread_mm, radius_mm / 2)``; taxel ``i`` carries
   ``F * pitch^2 / (2 pi sigma^2) * exp(-d_i^2 / (2 sigma^2))`` (an infinite grid sums to ``F``).
2. **Shear**: a finger sliding faster than ``min_slide_mm_s`` drags the skin with ``mu * F`` along
   its velocity; each module's share tilts its dome: ``delta_t = (shear_counts_per_n /
   gain_counts_per_n) * share_m * (Ft . e_t)`` N-equivalent, ``e_t`` = (+-1, +-1) from the module
   centre to taxel ``t``.
3. **Hysteresis** (cirillo2017 2.3) per taxel on ``u = load / full_scale_n``: a play operator with
   band ``b(u) = 2 H u (1 - u)`` on 0 <= u <= 1: ``x = clip(x_prev, u - b, u + b)``.
4. **Repeatability** (cirillo2017 2.3): each touch-down draws a gain ``g ~ U[1 - R/2, 1 + R/2]``.
5. **Cross-talk** inside a module (assumed): ``s'_t = (1 - 4c/3) s_t + (c/3) sum(s)``.
6. **Transduction**: counts = ``gain_counts_per_n * full_scale_n * g * x``.

Not modelled: the scanning skew inside a frame, the response time, creep.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import numpy as np

from touch_driver.skin.protocol import MODULE_TAXELS, N_TAXELS, TAXEL_PITCH_MM, TAXEL_XY_MM

__all__ = ['Contact', 'FingerContactModel', 'HysteresisPlay', 'SkinStimulus']

#: (4, 2): unit directions from a module's centre to its taxels TL, TR, BL, BR (x along cols, y along rows).
TAXEL_DIRECTIONS = np.array([[-1.0, -1.0], [1.0, -1.0], [-1.0, 1.0], [1.0, 1.0]])


@dataclass(frozen=True, slots=True)
class Contact:
    """One finger on the skin at one instant.

    Attributes:
        x_mm, y_mm: contact centre, mm from the outer corner of taxel (0, 0); x along columns, y along rows.
        force_n: normal force, N (>= 0).
        radius_mm: contact radius, mm (a fingertip pad: about 4 mm).
        vx_mm_s, vy_mm_s: finger velocity, mm/s; sliding gives shear.
    """

    x_mm: float
    y_mm: float
    force_n: float
    radius_mm: float = 4.0
    vx_mm_s: float = 0.0
    vy_mm_s: float = 0.0


@runtime_checkable
class SkinStimulus(Protocol):
    """Who touches the skin where and when. May also have ``duration_s`` (seconds the scene lasts)."""

    def contacts(self, t: float) -> list[Contact]:
        """The contacts at time ``t`` (seconds from the start of the scene); empty when untouched."""
        ...


@dataclass(frozen=True)
class FingerContactModel:
    """Mechanics and optics of a finger on the skin (see the module doc for the equations)."""

    #: kernel width of the silicone's load spreading for a point load, mm (assumed, about 2/3 pitch).
    spread_mm: float = 2.5
    #: Coulomb friction coefficient finger/silicone (assumed; skin on silicone is about 0.5-1).
    friction: float = 0.5
    #: speed below which a finger is sticking, not sliding, mm/s.
    min_slide_mm_s: float = 2.0
    #: counts per N of load on one taxel (assumed; sets 0.2 N -> >= 260 counts, cirillo2017 2.3 sensitivity).
    gain_counts_per_n: float = 8000.0
    #: counts per N of tangential force on one side of a dome (assumed, half the normal gain).
    shear_counts_per_n: float = 4000.0
    #: load on one taxel that the hysteresis curve spans, N (the calibration's full scale).
    full_scale_n: float = 2.0
    #: hysteresis error, fraction of full scale (cirillo2017 2.3: 10.27 %).
    hysteresis: float = 0.1027
    #: repeatability error, fraction of reading (cirillo2017 2.3: 6.77 %).
    repeatability: float = 0.0677
    #: fraction of a cell's signal leaking to the other three cells of its module (assumed).
    crosstalk: float = 0.04

    def __post_init__(self) -> None:
        for name in ('spread_mm', 'gain_counts_per_n', 'full_scale_n'):
            if not getattr(self, name) > 0:
                raise ValueError(f'{name} must be > 0, got {getattr(self, name)}')
        for name in ('friction', 'min_slide_mm_s', 'shear_counts_per_n'):
            if not getattr(self, name) >= 0:
                raise ValueError(f'{name} must be >= 0, got {getattr(self, name)}')
        if not 0 <= self.hysteresis < 0.5:
            raise ValueError(f'hysteresis must be a fraction in [0, 0.5), got {self.hysteresis}')
        if not 0 <= self.repeatability < 1:
            raise ValueError(f'repeatability must be a fraction in [0, 1), got {self.repeatability}')
        if not 0 <= self.crosstalk < 0.75:
            raise ValueError(f'crosstalk must be in [0, 0.75), got {self.crosstalk}')

    @property
    def counts_per_unit(self) -> float:
        """Counts of a hysteresis output of 1.0 (full-scale load on one taxel)."""
        return self.gain_counts_per_n * self.full_scale_n

    def kernel(self, x_mm: float, y_mm: float, radius_mm: float) -> np.ndarray:
        """(144,) float64: fraction of a normal load at (x, y) carried by each taxel, row-major.

        >>> model = FingerContactModel()
        >>> w = model.kernel(23.5, 23.5, 4.0)         # the centre of the skin
        >>> round(float(w.sum()), 3), int(w.argmax()) in (65, 66, 77, 78)
        (1.0, True)
        """
        sigma2 = self.spread_mm ** 2 + (0.5 * max(radius_mm, 0.0)) ** 2
        d2 = (TAXEL_XY_MM[:, 0] - x_mm) ** 2 + (TAXEL_XY_MM[:, 1] - y_mm) ** 2
        return (TAXEL_PITCH_MM ** 2 / (2.0 * math.pi * sigma2)) * np.exp(d2 * (-0.5 / sigma2))

    def taxel_load(self, contacts: list[Contact]) -> np.ndarray:
        """(144,) float64: N-equivalent load per taxel (normal load plus shear tilt), row-major.

        Contacts with a non-finite field or a negative force are skipped.
        """
        load = np.zeros(N_TAXELS, dtype=np.float64)
        shear_ratio = self.shear_counts_per_n / self.gain_counts_per_n
        for c in contacts:
            if not (math.isfinite(c.x_mm) and math.isfinite(c.y_mm) and math.isfinite(c.force_n)
                    and math.isfinite(c.radius_mm) and c.force_n > 0):
                continue
            w = self.kernel(c.x_mm, c.y_mm, c.radius_mm)
            load += c.force_n * w
            speed = math.hypot(c.vx_mm_s, c.vy_mm_s) if math.isfinite(c.vx_mm_s + c.vy_mm_s) else 0.0
            if speed > self.min_slide_mm_s and self.friction > 0 and shear_ratio > 0:
                ft = (self.friction * c.force_n / speed) * np.array([c.vx_mm_s, c.vy_mm_s])
                share = w[MODULE_TAXELS].sum(axis=1)                      # (36,) module's share of F
                load[MODULE_TAXELS] += (shear_ratio * share)[:, None] * (TAXEL_DIRECTIONS @ ft)[None, :]
        return load

    def mix_crosstalk(self, signal: np.ndarray) -> np.ndarray:
        """(144,) -> (144,): leak a fraction :attr:`crosstalk` of each cell to the rest of its module."""
        if self.crosstalk == 0:
            return signal
        modules = signal[MODULE_TAXELS]                                        # (36, 4)
        mixed = (1.0 - 4.0 * self.crosstalk / 3.0) * modules + (self.crosstalk / 3.0) * modules.sum(1, keepdims=True)
        out = np.empty_like(signal)
        out[MODULE_TAXELS] = mixed
        return out

    def force_matrix(self, full_scale_counts: float) -> np.ndarray:
        """(3, 4) float64: the module matrix that inverts this model for a calibrator with that full scale.

        fz = (full_scale_counts / gain) * sum(q); fx, fy = full_scale_counts / (4 shear_gain (1 - 4c/3))
        times the right-minus-left and bottom-minus-top sums of the normalised signals ``q``.
        Position inside a module also moves the left/right balance, so a single module's fx, fy are
        exact only for a load centred on it; summed over the modules under a finger it cancels
        to a few percent of fz.

        >>> FingerContactModel().force_matrix(16000.0).round(4)[:, :2]
        array([[-1.0563,  1.0563],
               [-1.0563, -1.0563],
               [ 2.    ,  2.    ]])
        """
        z = full_scale_counts / self.gain_counts_per_n
        if self.shear_counts_per_n == 0:
            s = 0.0
        else:
            s = full_scale_counts / (4.0 * self.shear_counts_per_n * (1.0 - 4.0 * self.crosstalk / 3.0))
        return np.array([s * TAXEL_DIRECTIONS[:, 0], s * TAXEL_DIRECTIONS[:, 1], [z] * 4], dtype=np.float64)


class HysteresisPlay:
    """Per-taxel play operator with a load-dependent band (module doc, step 3); bounded state (144,).

    >>> h = HysteresisPlay(0.1027)
    >>> up = [float(h.update(np.full(144, u))[0]) for u in (0.25, 0.5, 1.0)]
    >>> down = [float(h.update(np.full(144, u))[0]) for u in (0.5, 0.0)]
    >>> round(down[0] - up[1], 4), down[1]                   # gap at half scale = H, none at zero
    (0.1027, 0.0)
    """

    def __init__(self, hysteresis: float, size: int = N_TAXELS) -> None:
        self.hysteresis = float(hysteresis)
        self.state = np.zeros(size, dtype=np.float64)

    def update(self, u: np.ndarray) -> np.ndarray:
        """Load normalised to full scale (any real values) -> deformation output, same shape."""
        band = (2.0 * self.hysteresis) * u * (1.0 - u)
        np.maximum(band, 0.0, out=band)               # zero outside 0 <= u <= 1
        np.clip(self.state, u - band, u + band, out=self.state)
        return self.state.copy()

    def reset(self) -> None:
        self.state[:] = 0.0
