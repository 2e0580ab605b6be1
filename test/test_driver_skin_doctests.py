"""Run the doctests of the skin driver modules as part of the suite."""

from __future__ import annotations

import importlib

import pytest
from doctest_testing import check_doctests

MODULES = ['touch_driver.skin.protocol', 'touch_driver.skin.calibration', 'touch_driver.skin.calibration_config',
           'touch_sim.skin.contact', 'touch_sim.skin.stimuli', 'touch_sim.skin.traces']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    check_doctests(importlib.import_module(name))
