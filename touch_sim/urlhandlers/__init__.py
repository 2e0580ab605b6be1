"""pyserial URL handlers for the virtual sensors (``protocol_<scheme>.py``, class ``Serial``).

``import touch_driver`` appends this package to ``serial.protocol_handler_packages``, so
``serial.serial_for_url('bearsim://...')`` finds ``protocol_bearsim.Serial``.
"""
