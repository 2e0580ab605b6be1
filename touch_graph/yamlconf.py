"""YAML configuration with line numbers, for errors that point at the typo.

Every config in the project (launch files, parameter files, body maps, gesture
filters, command maps) is read through :func:`load_yaml`. Mappings and sequences come
back as :class:`YamlDict` and :class:`YamlList`, plain ``dict`` and ``list`` subclasses
that also remember the file and the line of each key or item, so a checker can say
``config/bear_body.yaml:12: sensor 'hed2' ...`` instead of just the value.

>>> doc = loads_yaml('a: 1\\nb:\\n  - x\\n', source='inline.yaml')
>>> doc['b'], doc.line_of('b'), doc['b'].line_of(0)
(['x'], 2, 3)
>>> check_keys(doc, required=('a',), optional=('b',), what='example')
>>> check_keys(doc, required=('a',), optional=('bb',), what='example')
Traceback (most recent call last):
...
touch_graph.errors.ConfigError: inline.yaml:2: unknown key 'b' in example; expected one of: a, bb (did you mean 'bb'?)
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError

__all__ = ['YamlDict', 'YamlList', 'check_keys', 'did_you_mean', 'load_yaml', 'loads_yaml', 'typed']


class YamlDict(dict):
    """A mapping read from YAML that knows the file and the line of each key."""

    path: str | None = None
    line: int | None = None

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.key_lines: dict[Any, int] = {}

    def line_of(self, key: Any) -> int | None:
        """1-based line of ``key``, or of the mapping itself if the key is absent."""
        return self.key_lines.get(key, self.line)

    def error(self, message: str, key: Any = None) -> ConfigError:
        """A :class:`ConfigError` located at ``key`` (or at the mapping)."""
        return ConfigError(message, self.path, self.line_of(key) if key is not None else self.line)


class YamlList(list):
    """A sequence read from YAML that knows the file and the line of each item."""

    path: str | None = None
    line: int | None = None

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self.item_lines: list[int] = []

    def line_of(self, index: int) -> int | None:
        if 0 <= index < len(self.item_lines):
            return self.item_lines[index]
        return self.line

    def error(self, message: str, index: int | None = None) -> ConfigError:
        return ConfigError(message, self.path, self.line_of(index) if index is not None else self.line)


def _make_loader(source: str) -> type[yaml.SafeLoader]:
    class _Loader(yaml.SafeLoader):
        pass

    def construct_mapping(loader: yaml.SafeLoader, node: yaml.MappingNode) -> YamlDict:
        loader.flatten_mapping(node)
        out = YamlDict()
        out.path, out.line = source, node.start_mark.line + 1
        for key_node, value_node in node.value:
            key = loader.construct_object(key_node, deep=True)
            try:
                hash(key)
            except TypeError as err:
                raise ConfigError(f'unhashable mapping key {key!r}', source,
                                  key_node.start_mark.line + 1) from err
            if key in out:
                raise ConfigError(
                    f'duplicate key {key!r} (first on line {out.key_lines[key]}); YAML would keep '
                    'only the last one, so remove or rename one of them', source, key_node.start_mark.line + 1)
            out[key] = loader.construct_object(value_node, deep=True)
            out.key_lines[key] = key_node.start_mark.line + 1
        return out

    def construct_sequence(loader: yaml.SafeLoader, node: yaml.SequenceNode) -> YamlList:
        out = YamlList(loader.construct_object(child, deep=True) for child in node.value)
        out.path, out.line = source, node.start_mark.line + 1
        out.item_lines = [child.start_mark.line + 1 for child in node.value]
        return out

    _Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, construct_mapping)
    _Loader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, construct_sequence)
    return _Loader


def loads_yaml(text: str, source: str = '<string>') -> Any:
    """Parse YAML text; syntax errors become :class:`ConfigError` with the line."""
    try:
        return yaml.load(text, Loader=_make_loader(source))  # a SafeLoader subclass
    except yaml.MarkedYAMLError as err:
        mark = err.problem_mark or err.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = err.problem or err.context or str(err)
        raise ConfigError(f'YAML syntax error: {problem}', source, line) from err
    except yaml.YAMLError as err:
        raise ConfigError(f'YAML error: {err}', source) from err


def load_yaml(path: str | Path) -> Any:
    """Read a YAML file; a missing file or bad syntax raises :class:`ConfigError`."""
    path = Path(path)
    try:
        text = path.read_text(encoding='utf-8')
    except FileNotFoundError as err:
        raise ConfigError('file not found', str(path)) from err
    except (OSError, UnicodeDecodeError) as err:
        raise ConfigError(f'cannot read file: {err}', str(path)) from err
    return loads_yaml(text, source=str(path))


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest choice, or an empty string."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ''


def check_keys(mapping: Any, required: Iterable[str] = (), optional: Iterable[str] = (),
               what: str = 'mapping') -> None:
    """Check that ``mapping`` is a mapping with all ``required`` keys and no others.

    Raises:
        ConfigError: naming the file and line of the first offending key.
    """
    required, optional = tuple(required), tuple(optional)
    if not isinstance(mapping, dict):
        raise _error_at(mapping, f'{what} must be a mapping with keys {", ".join(required + optional)}; '
                        f'got {type(mapping).__name__} {mapping!r}')
    allowed = required + optional
    for key in mapping:
        if key not in allowed:
            raise _error_at(mapping, f"unknown key '{key}' in {what}; expected one of: "
                            f'{", ".join(allowed)}{did_you_mean(key, allowed)}', key)
    for key in required:
        if key not in mapping:
            raise _error_at(mapping, f"missing key '{key}' in {what}")


def typed(mapping: dict, key: str, types: type | tuple[type, ...], what: str, default: Any = ...) -> Any:
    """``mapping[key]`` checked against ``types`` (``default`` when absent, if given).

    ``bool`` is never accepted where a number is expected, since YAML turns ``yes``/``on``
    into booleans; an int is accepted where a float is, and returned as a float.
    """
    if key not in mapping:
        if default is ...:
            raise _error_at(mapping, f"missing key '{key}' in {what}")
        return default
    value = mapping[key]
    types = types if isinstance(types, tuple) else (types,)
    if isinstance(value, bool) and bool not in types:
        ok = False
    elif isinstance(value, int) and not isinstance(value, bool) and float in types and int not in types:
        return float(value)
    else:
        ok = isinstance(value, types)
    if not ok:
        names = ' or '.join(t.__name__ for t in types)
        raise _error_at(mapping, f"'{key}' in {what} must be {names}; got {type(value).__name__} {value!r}", key)
    return value


def _error_at(container: Any, message: str, key: Any = None) -> ConfigError:
    if isinstance(container, (YamlDict, YamlList)):
        return container.error(message, key)
    return ConfigError(message)
