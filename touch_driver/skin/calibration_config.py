"""Constants of the skin calibration and their YAML file, ``config/skin_calibration.yaml``.

:class:`SkinCalibrationConfig` holds every constant of :class:`~touch_driver.skin.calibration.SkinCalibrator`
with its default; :func:`load_skin_calibration` reads the YAML file (checked with
:mod:`touch_graph.yamlconf`, so a typo gives file, line and "did you mean").
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from touch_graph.errors import ConfigError
from touch_graph.paths import share_file
from touch_graph.yamlconf import check_keys, load_yaml, typed

from .protocol import N_MODULES

__all__ = ['FORMAT_VERSION', 'SkinCalibrationConfig', 'default_force_matrix', 'load_skin_calibration']

FORMAT_VERSION = 1


def default_force_matrix(z_n: float = 2.0, shear_n: float = 1.056338) -> np.ndarray:
    """(3, 4) float64: the derived default module matrix; rows fx, fy, fz; columns taxels TL, TR, BL, BR.

    fz sums the four taxels; fx is right minus left, fy bottom (larger row) minus top. The
    defaults come from the simulator's contact model (see ``FingerContactModel.force_matrix``).

    >>> default_force_matrix(2.0, 1.0)
    array([[-1.,  1., -1.,  1.],
           [-1., -1.,  1.,  1.],
           [ 2.,  2.,  2.,  2.]])
    """
    return np.array([[-shear_n, shear_n, -shear_n, shear_n],
                     [-shear_n, -shear_n, shear_n, shear_n],
                     [z_n, z_n, z_n, z_n]], dtype=np.float64)


@dataclass(frozen=True)
class SkinCalibrationConfig:
    """Calibration constants. Defaults equal ``config/skin_calibration.yaml`` (a test checks it).

    The paper (cirillo2017) gives the rate and the sensor's figures, not the calibration
    constants of its firmware; the other defaults are derived from the simulator's contact model
    (:mod:`touch_sim.skin.contact`) and labelled so in the YAML file.
    """

    #: frames per second (cirillo2017 2.2: 150 Hz); converts the time constants below to frames.
    rate_hz: float = 150.0
    #: tared counts read as pressure 1.0. Contact model: 2 N on one taxel (8000 counts/N).
    full_scale_counts: float = 16000.0
    #: True when the hardware's counts fall with pressure: counts are mirrored (65535 - c) first.
    invert: bool = False
    #: seconds of frames averaged for the initial tare.
    tare_s: float = 0.2
    #: contact on when any taxel's pressure exceeds this (160 counts, 6.4 noise sigmas of the model:
    #: about one false contact in 100 hours); the model's 0.2 N touch (cirillo2017 2.3
    #: sensitivity) gives >= 0.0125 anywhere on the skin.
    contact_on: float = 0.01
    #: contact off when every taxel's pressure is below this (hysteresis).
    contact_off: float = 0.006
    #: pressure subtracted before the centroid, so noise does not pull the point to the centre.
    centroid_floor: float = 0.006
    #: time constant of each quiet taxel's own baseline tracking, s. A press that builds up slower
    #: than ``drift_gate`` per ``drift_tau_s`` (about 0.02 N/s of finger force at the model's gain)
    #: is taken for drift.
    drift_tau_s: float = 5.0
    #: time constant of the common-mode tracking (mean offset of the quiet taxels, applied to all), s.
    common_tau_s: float = 0.5
    #: time constant of re-taring a taxel that reads below its baseline, s.
    recover_tau_s: float = 0.5
    #: how often drift tracking runs, Hz (drift is slow; fewer updates save time per frame).
    drift_update_hz: float = 30.0
    #: |pressure| below which a taxel is quiet (6 noise sigmas of the model).
    drift_gate: float = 0.01
    #: taxels around a pressed taxel (Chebyshev distance) also kept frozen.
    guard_taxels: int = 1
    #: counts at or below which a taxel is dead (no light reaches the phototransistor).
    dead_counts: int = 256
    #: counts at or above which a taxel is saturated (16-bit full scale).
    saturation_counts: int = 65535
    #: seconds without any change after which a taxel is stuck (0 disables it, for noiseless data).
    stuck_s: float = 1.0
    #: (36, 3, 4) float64 force matrices, N per unit pressure; rows fx, fy, fz; columns TL, TR, BL, BR.
    force_matrices: np.ndarray = field(default_factory=lambda: np.tile(default_force_matrix(), (N_MODULES, 1, 1)))

    def __post_init__(self) -> None:
        problems = []
        for name in ('rate_hz', 'full_scale_counts', 'tare_s', 'drift_tau_s', 'common_tau_s', 'recover_tau_s',
                     'drift_update_hz',
                     'drift_gate'):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                problems.append(f'{name} must be a finite number > 0, got {value!r}')
        if not 0 < self.contact_off <= self.contact_on:
            problems.append(f'need 0 < contact_off <= contact_on, got off={self.contact_off} on={self.contact_on}')
        if not 0 <= self.centroid_floor < self.contact_on:
            problems.append(f'need 0 <= centroid_floor < contact_on, got {self.centroid_floor}')
        if not 0 <= self.guard_taxels <= 3:
            problems.append(f'guard_taxels must be 0..3, got {self.guard_taxels}')
        if not 0 <= self.dead_counts < self.saturation_counts <= 65535:
            problems.append(f'need 0 <= dead_counts < saturation_counts <= 65535, got {self.dead_counts}, '
                            f'{self.saturation_counts}')
        if not (math.isfinite(self.stuck_s) and self.stuck_s >= 0):
            problems.append(f'stuck_s must be >= 0, got {self.stuck_s}')
        matrices = np.asarray(self.force_matrices, dtype=np.float64)
        if matrices.shape != (N_MODULES, 3, 4) or not np.isfinite(matrices).all():
            problems.append(f'force_matrices must be (36, 3, 4) finite numbers, got shape {matrices.shape}')
        if problems:
            raise ValueError('invalid skin calibration: ' + '; '.join(problems))
        object.__setattr__(self, 'force_matrices', matrices)

    def frames(self, seconds: float) -> int:
        """A duration in frames at :attr:`rate_hz`, at least 1 (``stuck_s = 0`` gives 0: disabled)."""
        return 0 if seconds == 0 else max(1, round(seconds * self.rate_hz))


# ---------------------------------------------------------------------- YAML
_TOP_KEYS = ('format_version', 'rate_hz', 'full_scale_counts', 'invert', 'tare_s', 'contact', 'drift', 'faults',
             'force')


def _matrix(node: Any, where: Any, key: Any, what: str) -> np.ndarray:
    try:
        m = np.array(node, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise where.error(f'{what} must be a 3x4 list of numbers (rows fx, fy, fz; columns TL, TR, BL, BR); '
                          f'got {node!r}', key) from err
    if m.shape != (3, 4) or not np.isfinite(m).all():
        raise where.error(f'{what} must be 3 rows (fx, fy, fz) of 4 finite numbers (taxels TL, TR, BL, BR); '
                          f'got shape {m.shape}', key)
    return m


def load_skin_calibration(path: str | Path | None = None) -> SkinCalibrationConfig:
    """Read ``config/skin_calibration.yaml`` (or ``path``) into a :class:`SkinCalibrationConfig`.

    Raises:
        ConfigError: naming file and line of a missing, unknown or mistyped key.
    """
    path = share_file('config', 'skin_calibration.yaml') if path is None else Path(path)
    doc = load_yaml(path)
    what = 'skin calibration'
    check_keys(doc, required=('format_version', 'force'), optional=_TOP_KEYS, what=what)
    version = typed(doc, 'format_version', int, what)
    if version != FORMAT_VERSION:
        raise doc.error(f'format_version {version} is not supported; this code reads version {FORMAT_VERSION}',
                        'format_version')
    defaults = SkinCalibrationConfig()
    kw: dict[str, Any] = {}
    for key in ('rate_hz', 'full_scale_counts', 'tare_s'):
        kw[key] = typed(doc, key, float, what, getattr(defaults, key))
    kw['invert'] = typed(doc, 'invert', bool, what, False)
    sections = {
        # Not 'on'/'off': YAML 1.1 reads those keys as booleans.
        'contact': {'threshold_on': ('contact_on', float), 'threshold_off': ('contact_off', float),
                    'centroid_floor': ('centroid_floor', float)},
        'drift': {'tau_s': ('drift_tau_s', float), 'common_tau_s': ('common_tau_s', float),
                  'recover_tau_s': ('recover_tau_s', float),
                  'update_hz': ('drift_update_hz', float), 'gate': ('drift_gate', float),
                  'guard_taxels': ('guard_taxels', int)},
        'faults': {'dead_counts': ('dead_counts', int), 'saturation_counts': ('saturation_counts', int),
                   'stuck_s': ('stuck_s', float)},
    }
    for section, fields in sections.items():
        node = doc.get(section, {})
        check_keys(node, optional=tuple(fields), what=f'{what} {section}')
        for key, (name, kind) in fields.items():
            kw[name] = typed(node, key, kind, f'{what} {section}', getattr(defaults, name))
    force = doc['force']
    check_keys(force, required=('default',), optional=('modules',), what=f'{what} force')
    matrices = np.tile(_matrix(force['default'], force, 'default', 'force default'), (N_MODULES, 1, 1))
    modules = force.get('modules') or {}
    if not isinstance(modules, dict):
        raise force.error(f'force modules must map a module index (0..35) to a 3x4 matrix; got {modules!r}',
                          'modules')
    for module, node in modules.items():
        if isinstance(module, bool) or not isinstance(module, int) or not 0 <= module < N_MODULES:
            raise modules.error(f'force modules are keyed by module index 0..35; got {module!r}', module)
        matrices[module] = _matrix(node, modules, module, f'force matrix of module {module}')
    kw['force_matrices'] = matrices
    try:
        return SkinCalibrationConfig(**kw)
    except ValueError as err:
        raise ConfigError(str(err), str(path)) from err
