"""ROS 2 parameter YAML read the way rcl reads it (``rcl_yaml_param_parser``), not by YAML's own typing.

Keys above ``ros__parameters`` are namespace components of the node name, keys below it are
parameter names; nested mappings flatten to dotted names. Plain scalars are typed by rcl's
rules on the raw text: ``y yes true on`` (any case rcl allows) and the ``false`` words are bools;
what C's ``strtoll(text, &end, 0)`` reads whole is an integer (``0x1F``, ``017``); what ``strtod``
reads whole, or ``.nan``/``.inf``, is a double; anything else, and quoted or ``!!str`` text, is a
string. A sequence holds one type. Aliases are refused. Stricter than rcl (an error naming file and
line): an empty sequence, and keys beside ``ros__parameters`` under a node name.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import yaml

from ..errors import ConfigError
from ..yamlconf import PARSER, check_bounds, read_text, syntax_error

__all__ = ['ParameterOverrides', 'parse_parameter_value', 'parse_scalar', 'pattern_matches']

PARAMS_KEY = 'ros__parameters'
_TRUE = frozenset(['Y', 'y', 'yes', 'Yes', 'YES', 'true', 'True', 'TRUE', 'on', 'On', 'ON'])
_FALSE = frozenset(['N', 'n', 'no', 'No', 'NO', 'false', 'False', 'FALSE', 'off', 'Off', 'OFF'])
_SPECIAL_FLOATS = {f'{sign}.{word}': float(f'{"-" if sign == "-" else ""}{word.lower()}')
                   for sign in ('', '+', '-') for word in ('inf', 'Inf', 'INF')}
_SPECIAL_FLOATS.update({f'.{word}': math.nan for word in ('nan', 'NaN', 'NAN')})
_STR_TAG, _BOOL_TAG, _INT_TAG, _FLOAT_TAG, _NULL_TAG = (
    f'tag:yaml.org,2002:{t}' for t in ('str', 'bool', 'int', 'float', 'null'))
_INT64_MIN, _INT64_MAX = -(2 ** 63), 2 ** 63 - 1
_DBL_MIN = 2.2250738585072014e-308  # smallest normal double: strtod sets ERANGE below it

# What C's strtod accepts as a whole string (glibc): decimal or hexadecimal floats, inf, nan.
_STRTOD = re.compile(r"""[+-]?(?:
      (?P<dec>(?P<dec_digits>\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)
    | (?P<hex>0[xX](?P<hex_digits>[0-9a-fA-F]+\.?[0-9a-fA-F]*|\.[0-9a-fA-F]+)(?:[pP][+-]?\d+)?)
    | (?P<inf>[iI][nN][fF](?:[iI][nN][iI][tT][yY])?)
    | (?P<nan>[nN][aA][nN](?:\([0-9A-Za-z_]*\))?)
)""", re.VERBOSE)
_STRTOLL = re.compile(r'(?P<sign>[+-]?)(?:0[xX](?P<hex>[0-9a-fA-F]+)|(?P<oct>0[0-7]*)|(?P<dec>[1-9]\d*))')

Value = bool | int | float | str | list | None
_SCALAR_TYPES = {bool: 'bool', int: 'integer', float: 'double', str: 'string'}


def strtoll(text: str) -> int | None:
    """The integer C's ``strtoll(text, &end, 0)`` reads when it consumes all of ``text`` without
    overflow, else None.

    >>> strtoll('42'), strtoll('0x1F'), strtoll('017'), strtoll('08'), strtoll('1e3'), strtoll('9' * 20)
    (42, 31, 15, None, None, None)
    """
    m = _STRTOLL.fullmatch(text)
    if m is None:
        return None
    digits, base = ((m['hex'], 16) if m['hex'] is not None else (m['oct'], 8) if m['oct'] is not None
                    else (m['dec'], 10))
    value = int(digits, base) * (-1 if m['sign'] == '-' else 1)
    return value if _INT64_MIN <= value <= _INT64_MAX else None


def strtod(text: str) -> float | None:
    """The double C's ``strtod`` reads when it consumes all of ``text`` with ``errno`` 0, else None.

    >>> strtod('1e-6'), strtod('.5'), strtod('0x1p-2'), strtod('-inf'), strtod('1e999'), strtod('1:30')
    (1e-06, 0.5, 0.25, -inf, None, None)
    """
    m = _STRTOD.fullmatch(text)
    if m is None:
        return None
    sign = -1.0 if text.startswith('-') else 1.0
    if m['inf'] is not None:
        return sign * math.inf
    if m['nan'] is not None:
        return math.nan
    if m['hex'] is not None:
        value, digits = sign * float.fromhex(m['hex']), m['hex_digits']
    else:
        value, digits = sign * float(m['dec']), m['dec_digits']
    if math.isinf(value):
        return None  # overflow: strtod sets ERANGE
    if abs(value) < _DBL_MIN and any(c not in '0.' for c in digits):
        return None  # underflow (to zero or a subnormal): strtod sets ERANGE
    return value


def parse_scalar(text: str, style: str | None = None, tag: str | None = None) -> Value:
    """A parameter value from one YAML scalar, by rcl's rules (module doc).

    Args:
        text: the scalar's text as written (without quotes).
        style: None for a plain scalar, ``"'"``/``'"'`` for quoted ones, ``'|'``/``'>'`` for blocks
            (typed like plain ones, as rcl does).
        tag: an explicit tag (``tag:yaml.org,2002:str`` for ``!!str``), or None.

    Raises:
        ValueError: a plain empty value, or a value that does not fit its explicit tag.

    >>> [parse_scalar(t) for t in ('yes', 'On', '10', '0x10', '1e-6', '.inf', '1:30', 'nan')]
    [True, True, 10, 16, 1e-06, inf, '1:30', nan]
    >>> parse_scalar('10', style="'"), parse_scalar('yes', tag='tag:yaml.org,2002:str')
    ('10', 'yes')
    """
    if tag is not None and tag != '!':
        return _tagged(text, tag)
    if style in ("'", '"'):
        return text  # rcl types every scalar but quoted ones
    if text == '':
        raise ValueError('no value')
    if text in _TRUE:
        return True
    if text in _FALSE:
        return False
    integer = strtoll(text)
    if integer is not None:
        return integer
    if text in _SPECIAL_FLOATS:
        return _SPECIAL_FLOATS[text]
    double = strtod(text)
    return double if double is not None else text


def _tagged(text: str, tag: str) -> Value:
    if tag == _STR_TAG:
        return text
    if tag == _NULL_TAG:
        return None
    if tag == _BOOL_TAG:
        if text in _TRUE or text in _FALSE:
            return text in _TRUE
        raise ValueError(f'!!bool needs one of {", ".join(sorted(_TRUE | _FALSE))}; got {text!r}')
    if tag == _INT_TAG:
        integer = strtoll(text)
        if integer is None:
            raise ValueError(f'!!int needs an integer; got {text!r}')
        return integer
    if tag == _FLOAT_TAG:
        double = _SPECIAL_FLOATS.get(text, strtod(text))
        if double is None:
            raise ValueError(f'!!float needs a number; got {text!r}')
        return float(double)
    raise ValueError(f'unsupported tag {tag!r}: ROS 2 parameters know !!str, !!bool, !!int, !!float and !!null')


# --------------------------------------------------------------------------- events -> tree

@dataclass
class _Scalar:
    text: str
    style: str | None
    tag: str | None
    line: int


@dataclass
class _Seq:
    items: list
    line: int


@dataclass
class _Map:
    pairs: list[tuple[_Scalar, Any]] = field(default_factory=list)
    line: int = 0


def _tree(events: Any, source: str) -> list[Any]:
    """The documents of an event stream as _Map/_Seq/_Scalar trees; aliases are refused (rcl)."""
    docs: list[Any] = []
    stack: list[Any] = []
    pending_key: list[Any] = []  # per open mapping: the key waiting for its value, or None

    def add(node: Any, line: int) -> None:
        if not stack:
            docs.append(node)
            return
        parent = stack[-1]
        if isinstance(parent, _Seq):
            parent.items.append(node)
        elif pending_key[-1] is None:
            if not isinstance(node, _Scalar):
                raise ConfigError('a mapping key must be a plain name, not a sequence or mapping', source, line)
            pending_key[-1] = node
        else:
            parent.pairs.append((pending_key[-1], node))
            pending_key[-1] = None

    try:
        for event in events:
            line = event.start_mark.line + 1 if event.start_mark else 0
            if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None):
                raise ConfigError('YAML anchors and aliases are not supported in ROS 2 parameter files '
                                  '(rcl refuses them); write the value out', source, line)
            if isinstance(event, yaml.ScalarEvent):
                add(_Scalar(event.value, event.style, event.tag, line), line)
            elif isinstance(event, yaml.SequenceStartEvent):
                node = _Seq([], line)
                add(node, line)
                stack.append(node)
                pending_key.append(None)
            elif isinstance(event, yaml.MappingStartEvent):
                node = _Map([], line)
                add(node, line)
                stack.append(node)
                pending_key.append(None)
            elif isinstance(event, (yaml.SequenceEndEvent, yaml.MappingEndEvent)):
                stack.pop()
                pending_key.pop()
    except yaml.YAMLError as err:
        raise syntax_error(err, source) from err
    return docs


def _events(text: str) -> Any:
    return yaml.parse(text, Loader=PARSER)


# --------------------------------------------------------------------------- values

def _value(node: Any, source: str, name: str) -> Value:
    """A parameter value from a scalar or a sequence of scalars of one type."""
    if isinstance(node, _Scalar):
        try:
            return parse_scalar(node.text, node.style, node.tag)
        except ValueError as err:
            raise ConfigError(f"parameter '{name}': {err}", source, node.line) from err
    if isinstance(node, _Seq):
        if not node.items:
            raise ConfigError(f"parameter '{name}' is an empty list: ROS 2 cannot tell its element type "
                              '(rcl leaves it unset); give at least one item or remove the key', source, node.line)
        values = []
        for item in node.items:
            if not isinstance(item, _Scalar):
                raise ConfigError(f"parameter '{name}': a list holds bools, integers, doubles or strings, "
                                  'not lists or mappings', source, item.line)
            values.append(_value(item, source, name))
        kinds = {type(v) for v in values}
        if len(kinds) > 1 or type(None) in kinds:
            got = ', '.join(f'{v!r} ({_SCALAR_TYPES.get(type(v), "null")})' for v in values)
            raise ConfigError(f"parameter '{name}': the items of a list must share one type, as rcl requires "
                              f'(write 1.0, not 1, in a list of doubles); got {got}', source, node.line)
        return values
    raise ConfigError(f"parameter '{name}': expected a value or a list of values", source, node.line)


def parse_parameter_value(text: str, source: str = '-p') -> Value:
    """A ``-p name:=value`` value, typed as rcl types it (a scalar or a list of one type).

    >>> parse_parameter_value('1e-6'), parse_parameter_value('[1, 2]'), parse_parameter_value("'on'")
    (1e-06, [1, 2], 'on')
    """
    check_bounds(text, source)
    docs = _tree(_events(text), source)
    if not docs:
        raise ConfigError('no value', source)
    if len(docs) != 1 or isinstance(docs[0], _Map):
        raise ConfigError(f'a parameter value is a scalar or a list, got {text!r}', source)
    return _value(docs[0], source, source)


# --------------------------------------------------------------------------- node names

_NAME = re.compile(r'[A-Za-z_][A-Za-z0-9_]*')


def _check_node_key(key: str, source: str, line: int) -> str:
    """The node key as rclpy compares it: with a leading '/'. Raises ConfigError if rcl would."""
    if key in ('/**', '/*'):
        return key
    full = key if key.startswith('/') else '/' + key
    tokens = full[1:].split('/')
    for i, token in enumerate(tokens):
        last = i == len(tokens) - 1
        if token in ('*', '**'):
            continue
        if not _NAME.fullmatch(token):
            what = 'node name' if last else 'namespace component'
            raise ConfigError(f"invalid {what} {token!r} in '{key}': letters, digits and underscores, not "
                              "starting with a digit (or the wildcards '*' and '**')", source, line)
    return full


def pattern_matches(pattern: str, fqn: str) -> bool:
    """Does a parameter-file node key apply to the node ``fqn``? rclpy's rule: ``/*`` is one
    name token, ``/**`` any number of them; a key without a leading '/' is in the root namespace.

    >>> pattern_matches('/**', '/x/a'), pattern_matches('/x/*', '/x/a'), pattern_matches('a', '/a')
    (True, True, True)
    >>> pattern_matches('a', '/x/a'), pattern_matches('/**/a', '/x/y/a'), pattern_matches('/*', '/x/a')
    (False, True, False)
    """
    full = pattern if pattern.startswith('/') else '/' + pattern
    regex = re.escape(full).replace(r'/\*', r'(/\w+)').replace(r'\*', '*')
    return re.fullmatch(regex, fqn) is not None


# --------------------------------------------------------------------------- files

@dataclass(frozen=True)
class OverrideValue:
    """One parameter value for the nodes a key matches, and where it was written."""

    value: Value
    where: str
    line: int | None = None

    def __str__(self) -> str:
        return f'{self.where}:{self.line}' if self.line is not None else self.where


class ParameterOverrides:
    """Parameter values by node key, merged as rcl merges ``--params-file`` and ``-p`` arguments.

    Node keys keep the order they first appeared in; a key seen again (in the same or a later
    file) merges into its first entry, a parameter written again overwrites its value there.
    A node takes, key by key in that order, every key that matches it: so a node-specific key
    beats ``/**`` when it first appeared after it, whatever the order of later files (rclpy).
    """

    def __init__(self) -> None:
        self.nodes: dict[str, dict[str, OverrideValue]] = {}

    def set(self, node_key: str, name: str, value: OverrideValue) -> None:
        self.nodes.setdefault(node_key, {})[name] = value

    def merge(self, other: ParameterOverrides) -> None:
        for key, params in other.nodes.items():
            for name, value in params.items():
                self.set(key, name, value)

    def for_node(self, fqn: str) -> dict[str, tuple[OverrideValue, str]]:
        """``{name: (value, node key)}`` for the node ``fqn``."""
        out: dict[str, tuple[OverrideValue, str]] = {}
        for key, params in self.nodes.items():
            if pattern_matches(key, fqn):
                for name, value in params.items():
                    out[name] = (value, key)
        return out

    def __bool__(self) -> bool:
        return any(self.nodes.values())

    # ------------------------------------------------------------------ reading
    @classmethod
    def from_file(cls, path: str | Path, text: str | None = None) -> ParameterOverrides:
        """Read a parameter file; every error names the file and line."""
        source = str(path)
        if text is None:
            text = read_text(path)             # bounded size, as every YAML input (touch_graph.yamlconf)
        check_bounds(text, source)             # and bounded depth, before anything is built
        out = cls()
        for doc in _tree(_events(text), source):
            if isinstance(doc, _Scalar) and doc.text == '' and doc.style is None:
                continue  # an empty document
            if not isinstance(doc, _Map):
                raise ConfigError('a parameter file maps node names to {ros__parameters: {name: value}}',
                                  source, doc.line)
            out._read_node_level(doc, [], source)
        return out

    def _read_node_level(self, mapping: _Map, prefix: list[str], source: str) -> None:
        for key, value in mapping.pairs:
            if key.text == '':
                raise ConfigError('a node name cannot be empty', source, key.line)
            if key.text.startswith(PARAMS_KEY):
                if not prefix:
                    raise ConfigError(f"'{PARAMS_KEY}' needs a node name above it "
                                      f"(node_name: {{{PARAMS_KEY}: ...}}, or '/**' for every node)", source, key.line)
                others = [k for k, _ in mapping.pairs if not k.text.startswith(PARAMS_KEY)]
                if others:
                    raise ConfigError(f"unexpected key '{others[0].text}' beside {PARAMS_KEY} under "
                                      f"'{'/'.join(prefix)}'", source, others[0].line)
                node_key = _check_node_key(_join(prefix), source, key.line)
                if isinstance(value, _Scalar) and value.text == '' and value.style is None:
                    self.nodes.setdefault(node_key, {})
                    continue  # ros__parameters with nothing under it
                if not isinstance(value, _Map):
                    raise ConfigError(f"{PARAMS_KEY} of '{node_key}' must be a mapping of names to values",
                                      source, key.line)
                self.nodes.setdefault(node_key, {})
                self._read_params(value, node_key, '', source)
            elif isinstance(value, _Map):
                self._read_node_level(value, [*prefix, key.text], source)
            else:
                hint = 'a sequence' if isinstance(value, _Seq) else f'the value {value.text!r}'
                raise ConfigError(f"'{key.text}' holds {hint} where a node name with {PARAMS_KEY} belongs "
                                  f'(node_name: {{{PARAMS_KEY}: {{name: value}}}}); is ros__parameters misspelt?',
                                  source, key.line)

    def _read_params(self, mapping: _Map, node_key: str, prefix: str, source: str) -> None:
        for key, value in mapping.pairs:
            if key.text == '':
                raise ConfigError('a parameter name cannot be empty', source, key.line)
            name = f'{prefix}.{key.text}' if prefix else key.text
            if isinstance(value, _Map):
                self._read_params(value, node_key, name, source)
            else:
                self.set(node_key, name, OverrideValue(_value(value, source, name), source, key.line))


def _join(prefix: list[str]) -> str:
    """Node key from the namespace components above ``ros__parameters`` (rcl joins with '/')."""
    joined = '/'.join(p.strip('/') if i else p.rstrip('/') for i, p in enumerate(prefix))
    return joined.replace('//', '/') or '/'
