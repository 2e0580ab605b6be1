"""The doctests of the skin node's modules (screening, scene, frames, record CLI, ...)."""

import doctest
import importlib

import pytest

MODULES = ['screening', 'frames', 'scene', 'graph_chain', 'recording', 'record_cli', 'node', 'session_eval']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(f'touch_gestures.skin.{name}')
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
