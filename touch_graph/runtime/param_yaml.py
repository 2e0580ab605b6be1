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
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from ..errors import ConfigError
from ..yamlconf import check_bounds, read_text, syntax_error

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


# --------------------------------------------------------------------------- YAML -> nodes

class _Composer(yaml.SafeLoader):
    """pyyaml's node tree as rcl reads it: an untagged scalar keeps ``tag`` None (rcl types its text),
    anchors and aliases are refused (rcl refuses them) and mapping keys are scalars."""

    def __init__(self, text: str, source: str) -> None:
        super().__init__(text)
        self.source = source

    def resolve(self, kind: type, value: Any, implicit: Any) -> Any:
        return None if kind is yaml.ScalarNode else super().resolve(kind, value, implicit)

    def compose_node(self, parent: Any, index: Any) -> Any:
        event = self.peek_event()
        if isinstance(event, yaml.AliasEvent) or getattr(event, 'anchor', None):
            raise ConfigError('YAML anchors and aliases are not supported in ROS 2 parameter files '
                              '(rcl refuses them); write the value out', self.source, _line(event))
        return super().compose_node(parent, index)

    def compose_mapping_node(self, anchor: Any) -> Any:
        node = super().compose_mapping_node(anchor)
        for key, _ in node.value:
            if not isinstance(key, yaml.ScalarNode):
                raise ConfigError('a mapping key must be a plain name, not a sequence or mapping', self.source,
                                  _line(key))
        return node


def _documents(text: str, source: str) -> list[Any]:
    """The documents of ``text`` as pyyaml nodes (:class:`_Composer`)."""
    loader = _Composer(text, source)
    try:
        docs = []
        while loader.check_node():
            docs.append(loader.get_node())
        return docs
    except yaml.YAMLError as err:
        raise syntax_error(err, source) from err
    finally:
        loader.dispose()


def _line(node: Any) -> int:
    """1-based line of a pyyaml node or event."""
    return node.start_mark.line + 1


# --------------------------------------------------------------------------- values

def _value(node: Any, source: str, name: str) -> Value:
    """A parameter value from a scalar or a sequence of scalars of one type."""
    if isinstance(node, yaml.ScalarNode):
        try:
            return parse_scalar(node.value, node.style, node.tag)
        except ValueError as err:
            raise ConfigError(f"parameter '{name}': {err}", source, _line(node)) from err
    if isinstance(node, yaml.SequenceNode):
        if not node.value:
            raise ConfigError(f"parameter '{name}' is an empty list: ROS 2 cannot tell its element type "
                              '(rcl leaves it unset); give at least one item or remove the key', source, _line(node))
        values = []
        for item in node.value:
            if not isinstance(item, yaml.ScalarNode):
                raise ConfigError(f"parameter '{name}': a list holds bools, integers, doubles or strings, "
                                  'not lists or mappings', source, _line(item))
            values.append(_value(item, source, name))
        kinds = {type(v) for v in values}
        if len(kinds) > 1 or type(None) in kinds:
            got = ', '.join(f'{v!r} ({_SCALAR_TYPES.get(type(v), "null")})' for v in values)
            raise ConfigError(f"parameter '{name}': the items of a list must share one type, as rcl requires "
                              f'(write 1.0, not 1, in a list of doubles); got {got}', source, _line(node))
        return values
    raise ConfigError(f"parameter '{name}': expected a value or a list of values", source, _line(node))


def parse_parameter_value(text: str, source: str = '-p') -> Value:
    """A ``-p name:=value`` value, typed as rcl types it (a scalar or a list of one type).

    >>> parse_parameter_value('1e-6'), parse_parameter_value('[1, 2]'), parse_parameter_value("'on'")
    (1e-06, [1, 2], 'on')
    """
    check_bounds(text, source)
    docs = _documents(text, source)
    if not docs:
        raise ConfigError('no value', source)
    if len(docs) != 1 or isinstance(docs[0], yaml.MappingNode):
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
        for doc in _documents(text, source):
            if not isinstance(doc, yaml.MappingNode):
                raise ConfigError('a parameter file maps node names to {ros__parameters: {name: value}}',
                                  source, _line(doc))
            out._read_node_level(doc, [], source)
        return out

    def _read_node_level(self, mapping: yaml.MappingNode, prefix: list[str], source: str) -> None:
        for key, value in mapping.value:
            if key.value == '':
                raise ConfigError('a node name cannot be empty', source, _line(key))
            if key.value.startswith(PARAMS_KEY):
                if not prefix:
                    raise ConfigError(f"'{PARAMS_KEY}' needs a node name above it (node_name: "
                                      f"{{{PARAMS_KEY}: ...}}, or '/**' for every node)", source, _line(key))
                others = [k for k, _ in mapping.value if not k.value.startswith(PARAMS_KEY)]
                if others:
                    raise ConfigError(f"unexpected key '{others[0].value}' beside {PARAMS_KEY} under "
                                      f"'{'/'.join(prefix)}'", source, _line(others[0]))
                node_key = _check_node_key(_join(prefix), source, _line(key))
                if not isinstance(value, yaml.MappingNode):
                    raise ConfigError(f"{PARAMS_KEY} of '{node_key}' must be a mapping of names to values",
                                      source, _line(key))
                self.nodes.setdefault(node_key, {})
                self._read_params(value, node_key, '', source)
            elif isinstance(value, yaml.MappingNode):
                self._read_node_level(value, [*prefix, key.value], source)
            else:
                hint = 'a sequence' if isinstance(value, yaml.SequenceNode) else f'the value {value.value!r}'
                raise ConfigError(f"'{key.value}' holds {hint} where a node name with {PARAMS_KEY} belongs "
                                  f'(node_name: {{{PARAMS_KEY}: {{name: value}}}}); is ros__parameters misspelt?',
                                  source, _line(key))

    def _read_params(self, mapping: yaml.MappingNode, node_key: str, prefix: str, source: str) -> None:
        for key, value in mapping.value:
            if key.value == '':
                raise ConfigError('a parameter name cannot be empty', source, _line(key))
            name = f'{prefix}.{key.value}' if prefix else key.value
            if isinstance(value, yaml.MappingNode):
                self._read_params(value, node_key, name, source)
            else:
                self.set(node_key, name, OverrideValue(_value(value, source, name), source, _line(key)))


def _join(prefix: list[str]) -> str:
    """Node key from the namespace components above ``ros__parameters`` (rcl joins with '/')."""
    joined = '/'.join(p.strip('/') if i else p.rstrip('/') for i, p in enumerate(prefix))
    return joined.replace('//', '/') or '/'
