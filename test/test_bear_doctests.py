"""Run the doctests of the bear recogniser modules."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ['touch_gestures.bear.sensor_level', 'touch_gestures.bear.features', 'touch_gestures.bear.subtype',
           'touch_gestures.bear.subtype_labels', 'touch_gestures.bear.subtype_model', 'touch_sim.bear.people',
           'touch_sim.bear.hand_people',
           'touch_sim.bear.render', 'touch_gestures.bear.pipeline']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
