"""``skinsim://NAME?scene=...`` : the virtual optoelectronic skin behind a pyserial URL.

Options (all optional)::

    scene=NAME_OR_PATH   a stimulus registered with touch_sim.skin.device.register_stimulus, or a YAML
                         scene file (touch_sim.skin.stimuli); default: nobody touches the skin
    noise=COUNTS         Gaussian noise, ADC counts (default 25)
    drift=COUNTS         common-mode baseline drift amplitude (default 600)
    taxel_drift=COUNTS   per-taxel drift amplitude bound (default 100)
    dead=I,J,...         taxels (row-major 0..143) that read ~0
    stuck=I,J,...        taxels frozen at their rest value
    saturated=I,J,...    taxels stuck at 65535
    seed=N               seeds the device model and the port's fault injection

plus the port faults of :mod:`touch_sim.virtual_port` (garbage, corrupt, drop, unplug_at,
replug_at, buffer_s). Example: ``skinsim://demo?scene=press.yaml&garbage=0.01&dead=17&seed=3``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from touch_graph.errors import ConfigError
from touch_graph.yamlconf import did_you_mean
from touch_sim.skin.device import SkinDevice, registered_stimulus
from touch_sim.skin.stimuli import load_scene
from touch_sim.virtual_port import VirtualSerial

__all__ = ['Serial']

_FLOAT_OPTIONS = {'noise': 'noise_counts', 'drift': 'drift_counts', 'taxel_drift': 'taxel_drift_counts'}
_LIST_OPTIONS = ('dead', 'stuck', 'saturated')
_OPTIONS = ('scene', *_FLOAT_OPTIONS, *_LIST_OPTIONS)


def _resolve_scene(scene: str) -> Any:
    try:
        return registered_stimulus(scene)
    except KeyError as err:
        if Path(scene).is_file():
            try:
                return load_scene(scene)
            except ConfigError as cerr:
                raise ValueError(str(cerr)) from cerr
        raise ValueError(f'scene {scene!r} is neither a registered stimulus nor a YAML file '
                         f'({err.args[0]})') from err


def make_device(options: dict[str, str], seed: int = 0) -> SkinDevice:
    """A :class:`SkinDevice` from URL options (without the port fault options); ValueError on bad ones."""
    kw: dict[str, Any] = {}
    for key, value in options.items():
        if key not in _OPTIONS:
            raise ValueError(f'unknown skinsim option {key!r}; expected one of {", ".join(_OPTIONS)} or a port '
                             f'fault option{did_you_mean(key, _OPTIONS)}')
        if key in _FLOAT_OPTIONS:
            try:
                kw[_FLOAT_OPTIONS[key]] = float(value)
            except ValueError as err:
                raise ValueError(f'option {key}={value!r} must be a number of ADC counts') from err
        elif key in _LIST_OPTIONS:
            try:
                kw[key] = [int(v) for v in value.split(',') if v.strip()]
            except ValueError as err:
                raise ValueError(f'option {key}={value!r} must be comma-separated taxel indices 0..143') from err
    stimulus = _resolve_scene(options['scene']) if options.get('scene') else None
    return SkinDevice(stimulus, seed=seed, **kw)


class Serial(VirtualSerial):
    """pyserial port of the virtual skin: ``serial.serial_for_url('skinsim://demo?scene=...')``."""

    scheme = 'skinsim'

    def make_model(self, name: str, options: dict[str, str], seed: int = 0) -> SkinDevice:
        return make_device(options, seed=seed)
