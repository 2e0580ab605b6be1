"""Sensate Bear driver, pure layers (knight2009): body map, wire protocol, calibration.

- :mod:`.body_map`: wire channel -> sensor name, body location, region (config/bear_body.yaml)
- :mod:`.protocol`: the scan frame (id 0x42, 64 x uint16) and :class:`BearDecoder`
- :mod:`.calibration`: :class:`BearCalibrator`, counts -> levels 0..1, activation, faults
"""

from touch_driver.bear.body_map import BodyMap, BodySensor
from touch_driver.bear.calibration import BearCalibrator, BearLevels
from touch_driver.bear.protocol import BearDecoder, BearScan

__all__ = ['BearCalibrator', 'BearDecoder', 'BearLevels', 'BearScan', 'BodyMap', 'BodySensor']
