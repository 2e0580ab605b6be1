"""Every YAML a user can write is bounded before anything walks or prints it (issue 25)."""

from __future__ import annotations

import subprocess
import sys
import time

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_graph.errors import ConfigError
from touch_graph.yamlconf import MAX_DEPTH, MAX_VALUES, YamlBoundsError, check_bounds, excerpt, load_yaml, loads_yaml


def laughs(levels: int = 9, width: int = 9, key: str = 'gestures') -> str:
    """The "billion laughs": ``levels`` anchors, each ``width`` aliases of the one before (width**levels values)."""
    names = 'abcdefghijklmnop'
    lines = [f'a: &a [{",".join(["lol"] * width)}]']
    lines += [f'{names[i]}: &{names[i]} [{",".join(["*" + names[i - 1]] * width)}]' for i in range(1, levels - 1)]
    lines.append(f'{key}: [{",".join(["*" + names[levels - 2]] * width)}]')
    return '\n'.join(lines) + '\n'


def test_billion_laughs_is_refused_fast_and_quotes_a_bounded_excerpt():
    text = laughs()
    assert len(text) <= 340
    start = time.perf_counter()
    with pytest.raises(YamlBoundsError) as err:
        loads_yaml(text, 'laughs.yaml')
    assert time.perf_counter() - start < 1.0
    message = str(err.value)
    assert 'aliases are expanded' in message and message.startswith('laughs.yaml:')
    assert len(message) < 400


def test_a_gestures_file_of_aliases_is_a_clear_error_in_under_a_second(tmp_path):
    """The 333-byte file of issue 25, given as gestures:=, in a fresh process as a user would."""
    path = tmp_path / 'gestures.yaml'
    path.write_text(laughs())
    code = ('from touch_gestures.bear.symbolic import GestureLibrary\n'
            f'GestureLibrary.load({str(path)!r})\n')
    start = time.perf_counter()
    run = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True, timeout=60)
    assert run.returncode != 0
    assert 'YamlBoundsError' in run.stderr and 'aliases are expanded' in run.stderr
    assert len(run.stderr) < 5000
    # the whole process (interpreter, numpy) is timed; the refusal itself is timed above
    assert time.perf_counter() - start < 30


@pytest.mark.parametrize('text, words', [
    ('a: &a [*a]\n', 'inside its own anchor'),
    ('a: &a\n  b: *a\n', 'inside its own anchor'),
    ('[' * (MAX_DEPTH + 1) + ']' * (MAX_DEPTH + 1), 'nest deeper'),
    ('a: &a ' + '[' * 40 + ']' * 40 + '\nb: ' + '[' * 30 + '*a' + ']' * 30 + '\n', 'nest deeper'),
])
def test_cycles_and_depth_are_refused(text, words):
    with pytest.raises(YamlBoundsError, match=words):
        loads_yaml(text)


def test_size_is_refused_before_reading_the_whole_file(tmp_path):
    path = tmp_path / 'big.yaml'
    path.write_text('a: ' + 'x' * (3 * 1024 * 1024) + '\n')
    with pytest.raises(YamlBoundsError, match='bytes'):
        load_yaml(path)


def test_errors_of_the_checkers_quote_an_excerpt():
    doc = loads_yaml('format: [' + ','.join(['1'] * 100_000) + ']\ngestures: {}\n')
    with pytest.raises(ConfigError) as err:
        from touch_gestures.bear.symbolic import GestureLibrary
        GestureLibrary._from_doc(doc, None, 'x.yaml')
    assert len(str(err.value)) < 400
    assert len(excerpt(list(range(10 ** 6)))) <= 120


def test_the_shipped_configs_are_within_bounds():
    from touch_graph.paths import share_file
    for name in ('bear_body.yaml', 'bear_gestures.yaml', 'skin_calibration.yaml', 'panels.yaml',
                 'patch_outline.yaml', 'skin_commands.yaml'):
        load_yaml(share_file('config', name))


def _expanded_values(node) -> int:
    if isinstance(node, dict):
        return 1 + sum(_expanded_values(k) + _expanded_values(v) for k, v in node.items())
    if isinstance(node, list):
        return 1 + sum(_expanded_values(v) for v in node)
    return 1


@settings(max_examples=60, deadline=None)
@given(levels=st.integers(2, 7), width=st.integers(1, 8))
def test_alias_expansion_is_counted_exactly(levels, width):
    """A document within the bound loads and equals yaml.safe_load's; one over it is refused, never built."""
    text = laughs(levels, width, key='top')
    expanded = _expanded_values(yaml.safe_load(text)) if width ** levels <= 10 ** 6 else None
    if expanded is not None and expanded <= MAX_VALUES:
        assert loads_yaml(text) == yaml.safe_load(text)
        with pytest.raises(YamlBoundsError):
            check_bounds(text, max_values=expanded - 1)
        check_bounds(text, max_values=expanded)
    elif width ** (levels - 1) > MAX_VALUES:
        with pytest.raises(YamlBoundsError):
            loads_yaml(text)


_plain = st.recursive(st.none() | st.booleans() | st.integers() | st.text(max_size=8),
                      lambda inner: st.lists(inner, max_size=4)
                      | st.dictionaries(st.text(max_size=5), inner, max_size=4),
                      max_leaves=30)


@settings(max_examples=80, deadline=None)
@given(_plain)
def test_any_small_document_loads_as_yaml_safe_load_does(value):
    text = yaml.safe_dump(value)
    assert loads_yaml(text) == yaml.safe_load(text)


def test_command_line_values_are_bounded():
    """``topic pub`` and ``service call`` values are YAML a user types: bounded as files are."""
    from touch_graph.yamlconf import safe_load
    with pytest.raises(YamlBoundsError):
        safe_load(laughs(), 'the message values')
    assert safe_load('{data: 1}') == {'data': 1}


def test_parameter_files_and_values_are_bounded_too(tmp_path):
    from touch_graph.runtime.param_yaml import ParameterOverrides, parse_parameter_value
    deep = tmp_path / 'deep.yaml'
    deep.write_text('node:\n  ros__parameters:\n    x: ' + '[' * 200 + ']' * 200 + '\n')
    with pytest.raises(ConfigError, match='deep'):
        ParameterOverrides.from_file(deep)
    big = tmp_path / 'big.yaml'
    big.write_text('node:\n  ros__parameters:\n    x: "' + 'a' * (3 * 1024 * 1024) + '"\n')
    with pytest.raises(ConfigError, match='bytes'):
        ParameterOverrides.from_file(big)
    with pytest.raises(ConfigError, match='deep'):
        parse_parameter_value('[' * 200 + ']' * 200)
    with pytest.raises(ConfigError, match='not found'):
        ParameterOverrides.from_file(tmp_path / 'missing.yaml')
