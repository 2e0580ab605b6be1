"""Run the doctests of the skin driver modules as part of the suite."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ['touch_driver.skin.protocol', 'touch_driver.skin.calibration', 'touch_driver.skin.calibration_config',
           'touch_sim.skin.contact', 'touch_sim.skin.stimuli', 'touch_sim.skin.traces', 'touch_sim.skin.device']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
    if name.rsplit('.', 1)[1] in ('protocol', 'calibration', 'contact', 'traces'):
        assert result.attempted > 0
