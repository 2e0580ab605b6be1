"""The doctests of the skin node's modules (screening, scene, frames, record CLI, ...)."""

import doctest
import importlib

import pytest

MODULES = [f'touch_gestures.skin.{name}' for name in ('screening', 'frames', 'node')] + \
    ['touch_sim.skin.people'] + [f'touch_lab.skin.{name}' for name in ('recording', 'record_cli', 'session_eval')]


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
