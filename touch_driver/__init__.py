"""Serial drivers for the three touch sensors, their calibration and virtual devices."""

import serial

# Make bearsim://, patchsim:// and skinsim:// URLs resolvable by serial.serial_for_url.
if 'touch_sim.urlhandlers' not in serial.protocol_handler_packages:
    serial.protocol_handler_packages.append('touch_sim.urlhandlers')
