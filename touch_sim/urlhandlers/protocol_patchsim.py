"""``patchsim://NAME?scene=...``: a virtual textile patch with its 11 panels behind a pyserial URL (synthetic).

Options (all optional):

- ``scene``: a registered stimulus name (:func:`touch_sim.scenes.register_stimulus`), ``idle``
  (the default: nobody touches) or the path of a YAML timeline (see :mod:`touch_sim.scenes`);
- ``mode``: ``raw`` (default: every 100 Hz scan, frame id 0x51) or ``averaged`` (the paper's
  firmware: 20 Hz averaged frames, id 0x50);
- ``noise``, ``drift`` (counts), ``crosstalk``, ``creep`` (fractions), ``scan_rate`` (Hz): the
  sensor model of :class:`touch_sim.patch.device.PatchDevice`;
- ``dead``, ``saturated``, ``stuck``: comma-separated cells ``row:col`` with that fault;
  ``dead_panels``: comma-separated panel numbers;
- the port faults of :mod:`touch_sim.virtual_port`: ``garbage``, ``corrupt``, ``drop``,
  ``unplug_at``, ``replug_at``, ``buffer_s``, and ``seed`` (which also seeds the sensor model).

>>> import serial, touch_sim
>>> port = serial.serial_for_url('patchsim://doc?mode=averaged', do_not_open=True)
>>> port.attach_clock(lambda: 0.0); port.open()
>>> len(port.read(1000))  # 14 bytes of framing + 342 of payload
356
>>> port.close(); touch_sim.virtual_port.forget_devices()
"""

from __future__ import annotations

from typing import Any

from touch_sim.patch.device import PatchDevice
from touch_sim.scenes import load_stimulus
from touch_sim.virtual_port import VirtualSerial


class Serial(VirtualSerial):
    """pyserial port of a simulated patch (see the module docstring for the URL options)."""

    scheme = 'patchsim'

    def make_model(self, name: str, options: dict[str, str], seed: int = 0) -> Any:
        options = dict(options)
        stimulus = load_stimulus(options.pop('scene', 'idle'), sensor='patch')
        return PatchDevice.from_options(stimulus, options, seed=seed)
