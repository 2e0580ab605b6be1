"""Serial drivers of the three touch sensors: framing, wire protocols, calibration and driver nodes.

The virtual sensors behind ``bearsim://``, ``patchsim://`` and ``skinsim://`` URLs are in
:mod:`touch_sim`; a driver finds them through entry points when a port URL asks for one
(:func:`touch_driver.serial_driver.prepare_port_url`).
"""
