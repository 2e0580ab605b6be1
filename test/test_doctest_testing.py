"""The doctest harnesses' check fails when a module's example fails and when it has none."""

import types

import pytest
from doctest_testing import check_doctests


def _module(doc: str) -> types.ModuleType:
    module = types.ModuleType('example_module', doc)
    module.__file__ = 'example_module.py'
    return module


def test_a_module_with_passing_examples_passes():
    assert check_doctests(_module('>>> 1 + 1\n2\n')).attempted == 1


def test_a_module_without_examples_fails():
    with pytest.raises(AssertionError, match='has no example'):
        check_doctests(_module('No examples here.'))


def test_a_failing_example_fails(capsys):
    with pytest.raises(AssertionError, match='1 of 1 examples of example_module failed'):
        check_doctests(_module('>>> 1 + 1\n3\n'))
    assert 'Expected:' in capsys.readouterr().out
