"""Run the doctests of the skin driver modules as part of the suite."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ['protocol', 'calibration', 'calibration_config', 'contact', 'stimuli', 'traces', 'device']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(f'touch_driver.skin.{name}')
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
    if name in ('protocol', 'calibration', 'contact', 'traces'):
        assert result.attempted > 0
