"""Run the doctests of the bear recogniser modules."""

from __future__ import annotations

import importlib

import pytest
from doctest_testing import check_doctests

MODULES = ['touch_gestures.bear.sensor_level', 'touch_gestures.bear.features', 'touch_gestures.bear.subtype',
           'touch_gestures.bear.subtype_labels', 'touch_gestures.bear.subtype_model', 'touch_sim.bear.people',
           'touch_sim.bear.hand_people',
           'touch_sim.bear.render', 'touch_gestures.bear.pipeline', 'touch_lab.bear.subtype_training']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name: str) -> None:
    check_doctests(importlib.import_module(name))
