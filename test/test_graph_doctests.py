"""Run the doctests of the graph runtime's small pure helpers."""

from __future__ import annotations

import doctest
import importlib

import pytest

MODULES = ['touch_graph.runtime.param_yaml', 'touch_graph.runtime.parameters', 'touch_graph.yamlconf',
           'social_touch_msgs.msg', 'touch_graph.srv_types', 'touch_graph.runtime.parameter_messages',
           'touch_graph.runtime.parameter_service', 'touch_graph.dds.services']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name: str) -> None:
    result = doctest.testmod(importlib.import_module(name), optionflags=doctest.ELLIPSIS)
    assert result.failed == 0 and result.attempted > 0
