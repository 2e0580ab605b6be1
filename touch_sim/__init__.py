"""The simulation: virtual sensors behind pyserial URLs, contact models, simulated people, scenes.

Nothing here runs on the robot; the demo, the tests and the lab run on it. Importing this
package makes ``bearsim://``, ``patchsim://`` and ``skinsim://`` URLs open with
``serial.serial_for_url`` (pyserial looks the handlers up in :mod:`touch_sim.urlhandlers`).
"""

import serial

if 'touch_sim.urlhandlers' not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append('touch_sim.urlhandlers')
