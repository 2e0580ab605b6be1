"""YAML configuration with line numbers, for errors that point at the typo.

Every config in the project (launch files, parameter files, body maps, gesture
filters, command maps) is read through :func:`load_yaml`. Mappings and sequences come
back as :class:`YamlDict` and :class:`YamlList`, plain ``dict`` and ``list`` subclasses
that also remember the file and the line of each key or item, so a checker can say
``config/bear_body.yaml:12: sensor 'hed2' ...`` instead of just the value.

Every document is bounded before anything walks or prints it (:func:`check_bounds`): its size in
bytes, how deep collections nest, and how many values it holds once every alias is expanded, so a
few hundred bytes of anchors and aliases (a "billion laughs") is refused at once instead of eating
the memory of whoever prints it. Errors quote a bounded excerpt of a value (:func:`excerpt`).

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

import reprlib
from collections.abc import Iterable
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError, did_you_mean

__all__ = ['MAX_BYTES', 'MAX_DEPTH', 'MAX_VALUES', 'YamlBoundsError', 'YamlDict', 'YamlList', 'check_bounds',
           'check_keys', 'did_you_mean', 'excerpt', 'load_yaml', 'loads_yaml', 'read_text', 'safe_load', 'typed']

#: Largest YAML document read, in bytes (the project's own configs are a few kB).
MAX_BYTES = 2 * 1024 * 1024
#: Deepest nesting of collections, aliases expanded.
MAX_DEPTH = 64
#: Most values (scalars and collections) in one document once every alias is expanded.
MAX_VALUES = 200_000

class _Excerpt(reprlib.Repr):
    """reprlib's bounded repr, which finds its methods by type name: YAML's collections are lists and dicts."""

    def repr_YamlList(self, obj: list, level: int) -> str:  # reprlib looks methods up by type name
        return self.repr_list(obj, level)

    def repr_YamlDict(self, obj: dict, level: int) -> str:
        return self.repr_dict(obj, level)


_EXCERPT = _Excerpt()
_EXCERPT.maxlevel, _EXCERPT.maxdict, _EXCERPT.maxlist, _EXCERPT.maxtuple = 3, 6, 6, 6
_EXCERPT.maxstring, _EXCERPT.maxother, _EXCERPT.maxlong = 60, 60, 40


def excerpt(value: Any, limit: int = 120) -> str:
    """A repr of ``value`` of at most ``limit`` characters that never walks all of a large value.

    >>> excerpt(list(range(10**6)))
    '[0, 1, 2, 3, 4, 5, ...]'
    >>> excerpt(loads_yaml('[' + ','.join(['1'] * 1000) + ']'))
    '[1, 1, 1, 1, 1, 1, ...]'
    >>> len(excerpt('x' * 10**6)) <= 120
    True
    """
    text = _EXCERPT.repr(value)
    return text if len(text) <= limit else text[:limit - 3] + '...'


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
        return self.item_lines[index] if 0 <= index < len(self.item_lines) else self.line

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
                raise ConfigError(f'unhashable mapping key {excerpt(key)}', source,
                                  key_node.start_mark.line + 1) from err
            if key in out:
                raise ConfigError(
                    f'duplicate key {excerpt(key, 60)} (first on line {out.key_lines[key]}); YAML would keep '
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


def _text_excerpt(text: str, line: int | None) -> str:
    """The start of line ``line`` (1-based) of ``text``, at most 60 characters."""
    if line is None:
        return ''
    lines = text.splitlines()
    return f': {lines[line - 1][:60]!r}' if 0 < line <= len(lines) else ''


def check_bounds(text: str, source: str = '<string>', *, max_bytes: int = MAX_BYTES, max_depth: int = MAX_DEPTH,
                 max_values: int = MAX_VALUES) -> None:
    """Refuse YAML ``text`` that is too large, too deep or expands too far, before it is built.

    One pass over the parser's events: nothing is constructed, so an alias costs what its
    anchor's count says, and a document of 9 anchors of 9 aliases each (9**9 values) is refused
    after reading a few hundred bytes. An alias inside its own anchor (a cycle) is refused too.

    Raises:
        ConfigError: naming the file, the line and the limit, with a bounded excerpt of the line.

    >>> check_bounds('a: &a [1, 2]\\nb: [*a, *a]\\n')
    >>> laughs = 'a: &a [1,1,1,1,1,1,1,1,1]\\n' + ''.join(
    ...     f'{n}: &{n} [{",".join(["*" + p] * 9)}]\\n' for p, n in zip('abcdefgh', 'bcdefghi'))
    >>> check_bounds(laughs, 'laughs.yaml')
    Traceback (most recent call last):
    ...
    touch_graph.yamlconf.YamlBoundsError: laughs.yaml:6: more than 200000 values once aliases are expanded ...
    """
    size = len(text.encode('utf-8', 'surrogatepass')) if len(text) * 4 > max_bytes else len(text)
    if size > max_bytes:
        raise YamlBoundsError(f'{size} bytes of YAML; a config is at most {max_bytes} bytes', source)
    sizes: dict[str, tuple[int, int]] = {}  # anchor -> (values, depth) of what it names, aliases expanded
    open_anchors: set[str] = set()
    stack: list[list] = []  # [anchor, values, depth below] of each open collection
    total = 0

    def add(values: int, depth: int, mark: Any) -> None:
        nonlocal total
        total += values
        if total > max_values:
            raise _bound_error(f'more than {max_values} values once aliases are expanded (anchors and *aliases '
                               'repeat what they name; a config needs far fewer)', source, text, mark)
        if len(stack) + depth > max_depth:
            raise _bound_error(f'collections nest deeper than {max_depth} levels', source, text, mark)
        if stack:
            stack[-1][1] += values
            stack[-1][2] = max(stack[-1][2], depth)

    try:
        for event in yaml.parse(text, Loader=PARSER):
            if isinstance(event, yaml.AliasEvent):
                if event.anchor in open_anchors:
                    raise _bound_error(f'alias *{event.anchor} is inside its own anchor &{event.anchor}: '
                                       'the value would contain itself', source, text, event.start_mark)
                values, depth = sizes.get(event.anchor, (1, 0))
                add(values, depth, event.start_mark)
            elif isinstance(event, yaml.ScalarEvent):
                add(1, 0, event.start_mark)
                if event.anchor is not None:
                    sizes[event.anchor] = (1, 0)
            elif isinstance(event, (yaml.SequenceStartEvent, yaml.MappingStartEvent)):
                if len(stack) + 1 > max_depth:
                    raise _bound_error(f'collections nest deeper than {max_depth} levels', source, text,
                                       event.start_mark)
                stack.append([event.anchor, 1, 0])
                if event.anchor is not None:
                    open_anchors.add(event.anchor)
            elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                anchor, values, depth = stack.pop()
                total -= values - 1  # add() below counts them again, as one collection
                if anchor is not None:
                    open_anchors.discard(anchor)
                    sizes[anchor] = (values, depth + 1)
                add(values, depth + 1, event.start_mark)
    except yaml.YAMLError as err:
        raise syntax_error(err, source) from err


class YamlBoundsError(ConfigError):
    """YAML refused for its size, depth or alias expansion (not for its syntax)."""


def _bound_error(message: str, source: str, text: str, mark: Any) -> ConfigError:
    line = mark.line + 1 if mark is not None else None
    return YamlBoundsError(message + _text_excerpt(text, line), source, line)


def syntax_error(err: yaml.YAMLError, source: str) -> ConfigError:
    """A pyyaml error as a :class:`ConfigError` naming ``source`` and, where pyyaml knows it, the line."""
    if isinstance(err, yaml.MarkedYAMLError):
        mark = err.problem_mark or err.context_mark
        line = mark.line + 1 if mark is not None else None
        problem = err.problem or err.context or str(err)
        return ConfigError(f'YAML syntax error: {problem}', source, line)
    return ConfigError(f'YAML error: {str(err)[:200]}', source)


#: pyyaml's safe loader, in C when libyaml is there.
PARSER = getattr(yaml, 'CSafeLoader', yaml.SafeLoader)


def loads_yaml(text: str, source: str = '<string>') -> Any:
    """Parse YAML text, bounded (:func:`check_bounds`); syntax errors become :class:`ConfigError` with the line."""
    check_bounds(text, source)
    try:
        return yaml.load(text, Loader=_make_loader(source))  # a SafeLoader subclass
    except yaml.YAMLError as err:
        raise syntax_error(err, source) from err


def safe_load(text: str, source: str = '<string>') -> Any:
    """``yaml.safe_load`` of ``text`` (plain dicts and lists), bounded as :func:`loads_yaml` is.

    For YAML that is not a config file: values typed on a command line, a bag's metadata.
    """
    check_bounds(text, source)
    try:
        return yaml.load(text, Loader=PARSER)
    except yaml.YAMLError as err:
        raise syntax_error(err, source) from err


def read_text(path: str | Path, max_bytes: int = MAX_BYTES) -> str:
    """The text of ``path``, refused above ``max_bytes`` before it is read whole.

    Raises:
        ConfigError: a missing, unreadable, non-UTF-8 or too large file.
    """
    path = Path(path)
    try:
        with open(path, 'rb') as f:
            data = f.read(max_bytes + 1)
    except FileNotFoundError as err:
        raise ConfigError('file not found', str(path)) from err
    except OSError as err:
        raise ConfigError(f'cannot read file: {err}', str(path)) from err
    if len(data) > max_bytes:
        raise YamlBoundsError(f'more than {max_bytes} bytes; a YAML config is at most {max_bytes} bytes '
                          '(is this the right file?)', str(path))
    try:
        return data.decode('utf-8')
    except UnicodeDecodeError as err:
        raise ConfigError(f'cannot read file: not UTF-8 text ({err.reason} at byte {err.start})', str(path)) from err


def load_yaml(path: str | Path) -> Any:
    """Read a YAML file, bounded; a missing, too large file or bad syntax raises :class:`ConfigError`."""
    return loads_yaml(read_text(path), source=str(path))


def check_keys(mapping: Any, required: Iterable[str] = (), optional: Iterable[str] = (),
               what: str = 'mapping') -> None:
    """Check that ``mapping`` is a mapping with all ``required`` keys and no others.

    Raises:
        ConfigError: naming the file and line of the first offending key.
    """
    required, optional = tuple(required), tuple(optional)
    if not isinstance(mapping, dict):
        raise _error_at(mapping, f'{what} must be a mapping with keys {", ".join(required + optional)}; '
                        f'got {type(mapping).__name__} {excerpt(mapping)}')
    allowed = required + optional
    for key in mapping:
        if key not in allowed:
            raise _error_at(mapping, f"unknown key {excerpt(key, 60)} in {what}; expected one of: "
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
    if isinstance(value, int) and not isinstance(value, bool) and float in types and int not in types:
        return float(value)
    if not isinstance(value, types) or (isinstance(value, bool) and bool not in types):
        names = ' or '.join(t.__name__ for t in types)
        raise _error_at(mapping, f"'{key}' in {what} must be {names}; got {type(value).__name__} {excerpt(value)}", key)
    return value


def _error_at(container: Any, message: str, key: Any = None) -> ConfigError:
    if isinstance(container, (YamlDict, YamlList)):
        return container.error(message, key)
    return ConfigError(message)
