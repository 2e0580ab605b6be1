"""Run the doctests of the skin gesture modules as part of the suite."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ['traces', 'gesture', 'features', 'segmentation', 'proposed', 'registry', 'codebook', 'cli', 'base',
           'paper', 'peers', 'commands', 'synthetic', 'render', 'evaluate', 'bench', 'report']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(f'touch_gestures.skin.{name}')
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
