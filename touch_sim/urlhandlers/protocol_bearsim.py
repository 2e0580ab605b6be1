"""``bearsim://NAME?scene=...``: a virtual Sensate Bear behind a pyserial URL (synthetic data).

Options (all optional):

- ``scene``: a registered stimulus name (:func:`touch_sim.scenes.register_stimulus`), ``idle``
  (the default: nobody touches the bear) or the path of a YAML timeline (see :mod:`touch_sim.scenes`);
- ``rate`` (scans/s, default 3.4), ``scan`` (``sequential``/``parallel``), ``channel_dt`` (s),
  ``noise`` (counts), ``drift`` (counts), ``crosstalk`` (fraction): the sensor model of
  :class:`touch_sim.bear.device.BearDevice`;
- ``dead``, ``saturated``, ``stuck``: comma-separated sensor names or channels with that fault;
- the port faults of :mod:`touch_sim.virtual_port`: ``garbage``, ``corrupt``, ``drop``,
  ``unplug_at``, ``replug_at``, ``buffer_s``, and ``seed`` (which also seeds the sensor model).

>>> import serial, touch_sim
>>> port = serial.serial_for_url('bearsim://doc?rate=25&scan=parallel&seed=1', do_not_open=True)
>>> port.attach_clock(lambda: 0.0); port.open()
>>> len(port.read(1000))  # frame 0 is due at t = 0: 14 bytes of framing + 128 of payload
142
>>> port.close(); touch_sim.virtual_port.forget_devices()
"""

from __future__ import annotations

from typing import Any

from touch_sim.bear.device import BearDevice
from touch_sim.scenes import load_stimulus
from touch_sim.virtual_port import VirtualSerial


class Serial(VirtualSerial):
    """pyserial port of a simulated bear (see the module docstring for the URL options)."""

    scheme = 'bearsim'

    def make_model(self, name: str, options: dict[str, str], seed: int = 0) -> Any:
        options = dict(options)
        stimulus = load_stimulus(options.pop('scene', 'idle'), sensor='bear')
        return BearDevice.from_options(stimulus, options, seed=seed)
