"""Run the doctests of the graph runtime's small pure helpers."""

from __future__ import annotations

import importlib

import pytest
from doctest_testing import check_doctests

MODULES = ['touch_graph.files', 'touch_graph.runtime.param_yaml', 'touch_graph.runtime.parameters',
           'touch_graph.yamlconf', 'social_touch_msgs.msg', 'touch_graph.srv_types',
           'touch_graph.runtime.parameter_service', 'touch_graph.dds.services',
           'touch_graph.runtime.graph_info', 'touch_graph.runtime.qos']


@pytest.mark.parametrize('name', MODULES)
def test_doctests(name: str) -> None:
    check_doctests(importlib.import_module(name))
