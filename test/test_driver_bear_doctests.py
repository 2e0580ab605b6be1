"""Run the doctests of the bear and patch driver modules, the scenes and their URL handlers."""

from __future__ import annotations

import importlib

import pytest
from doctest_testing import check_doctests

from touch_sim.virtual_port import forget_devices

MODULES = ['touch_driver.bear.body_map', 'touch_driver.bear.protocol', 'touch_driver.patch.protocol',
           'touch_driver.patch.panels', 'touch_sim.scenes', 'touch_sim.urlhandlers.protocol_bearsim',
           'touch_sim.urlhandlers.protocol_patchsim']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name: str) -> None:
    forget_devices()
    check_doctests(importlib.import_module(name))
