"""Run the doctests of the skin gesture modules as part of the suite."""

from __future__ import annotations

import importlib

import pytest
from doctest_testing import check_doctests

MODULES = [f'touch_gestures.skin.{name}' for name in ('gesture', 'features', 'segmentation', 'proposed', 'registry',
                                                      'codebook', 'fused', 'base', 'blobs', 'assignment',
                                                      'stroke_orders')] + \
    [f'touch_lab.skin.{name}' for name in ('datasets', 'cli', 'gaps', 'logged_times',
                                           'recognisers', 'recognisers.ndollar',
                                           'recognisers.oriented')]


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    check_doctests(importlib.import_module(name))
