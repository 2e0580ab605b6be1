"""The doctests of the skin node's modules (screening, scene, frames, record CLI, ...)."""

import importlib

import pytest
from doctest_testing import check_doctests

MODULES = ['touch_gestures.skin.screening', 'touch_sim.skin.people'] + \
    [f'touch_lab.skin.{name}' for name in ('record_cli', 'session_eval')]


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name):
    check_doctests(importlib.import_module(name))
