"""Run the doctests of the skin gesture modules as part of the suite."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = [f'touch_gestures.skin.{name}' for name in ('gesture', 'features', 'segmentation', 'proposed', 'registry',
                                                      'codebook', 'base', 'paper', 'commands', 'fused',
                                                      'stroke_orders')] + \
    [f'touch_sim.skin.{name}' for name in ('synthetic', 'render')] + \
    [f'touch_lab.skin.{name}' for name in ('datasets', 'cli', 'evaluate', 'bench', 'report', 'gaps', 'logged_times',
                                           'recognisers', 'recognisers.peers', 'recognisers.ndollar',
                                           'recognisers.oriented')]


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    module = importlib.import_module(name)
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS)
    assert result.failed == 0
