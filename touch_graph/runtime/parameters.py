"""Node parameters with rclpy's names, ROS 2 parameter YAML files and ``--ros-args``.

A parameter file is what ``ros2 run ... --ros-args --params-file F`` reads::

    /bear/subtype:            # a fully qualified node name; /** and * are wildcards
      ros__parameters:
        alpha: 0.4
        cutoffs:              # nested mappings flatten to dotted names: cutoffs.tickle
          tickle: 3.0

Files and ``-p`` values are read and typed by rcl's rules and applied to the nodes rclpy
applies them to (:mod:`.param_yaml`). Values keep their file and line, so a wrong type is
reported as ``config/x.yaml:4: parameter 'alpha' of /bear/subtype ...``.
"""

from __future__ import annotations

import array
import math
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ConfigError, ParameterError
from ..messages import get_message
from .param_yaml import OverrideValue, ParameterOverrides, parse_parameter_value

__all__ = [
    'FloatingPointRange',
    'IntegerRange',
    'InvalidParameterValueException',
    'OverrideValue',
    'Parameter',
    'ParameterDescriptor',
    'ParameterNotDeclaredException',
    'ParameterOverrides',
    'ParameterType',
    'RosArgs',
    'SetParametersResult',
    'descriptor_from_msg',
    'descriptor_msg',
    'load_parameter_file',
    'parameter_event',
    'parameter_from_msg',
    'parameter_msg',
    'parameter_value',
    'parse_ros_args',
    'value_of',
]


class ParameterType(IntEnum):
    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9


def _infer_type(value: Any) -> ParameterType:
    if value is None:
        return ParameterType.NOT_SET
    if isinstance(value, bool):
        return ParameterType.BOOL
    if isinstance(value, int):
        return ParameterType.INTEGER
    if isinstance(value, float):
        return ParameterType.DOUBLE
    if isinstance(value, str):
        return ParameterType.STRING
    if isinstance(value, (bytes, bytearray)):
        return ParameterType.BYTE_ARRAY
    if isinstance(value, (list, tuple)):
        if not value:
            raise ParameterError('an empty list has no parameter type; declare the parameter with a '
                                 'non-empty default or an explicit descriptor type')
        kinds = {_infer_type(v) if isinstance(v, (bool, int, float, str)) else None for v in value}
        if kinds == {ParameterType.INTEGER, ParameterType.DOUBLE}:
            return ParameterType.DOUBLE_ARRAY
        if len(kinds) == 1 and None not in kinds:
            return ParameterType[f'{kinds.pop().name}_ARRAY']
        raise ParameterError(f'a parameter array must hold one type (bools, ints, doubles or strings); got {value!r}')
    raise ParameterError(f'unsupported parameter value {value!r} of type {type(value).__name__}')


class Parameter:
    """``Parameter(name, value=...)`` or ``Parameter(name, Parameter.Type.DOUBLE, 1.0)``, as in rclpy."""

    Type = ParameterType

    def __init__(self, name: str, type_: ParameterType | None = None, value: Any = None) -> None:
        if not isinstance(name, str) or not name:
            raise ParameterError(f'parameter name must be a non-empty string, got {name!r}')
        if type_ is None:
            type_ = _infer_type(value)
        if type_ == ParameterType.DOUBLE_ARRAY and value is not None:
            value = [float(v) for v in value]
        elif isinstance(value, tuple):
            value = list(value)
        self.name = name
        self.type_ = ParameterType(type_)
        self.value = value

    def __repr__(self) -> str:
        return f'Parameter({self.name!r}, {self.type_.name}, {self.value!r})'

    def get_parameter_value(self) -> Any:
        """The ``rcl_interfaces/ParameterValue`` message (rclpy's name)."""
        return parameter_value(self)

    def to_parameter_msg(self) -> Any:
        """The ``rcl_interfaces/Parameter`` message (rclpy's name)."""
        return parameter_msg(self)

    @classmethod
    def from_parameter_msg(cls, msg: Any) -> Parameter:
        """A parameter from an ``rcl_interfaces/Parameter`` message (rclpy's name)."""
        return parameter_from_msg(msg)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Parameter) and (self.name, self.type_, self.value) == (
            other.name, other.type_, other.value)

    __hash__ = None


@dataclass
class FloatingPointRange:
    from_value: float = -math.inf
    to_value: float = math.inf
    step: float = 0.0


@dataclass
class IntegerRange:
    from_value: int = -(2**63)
    to_value: int = 2**63 - 1
    step: int = 0


@dataclass
class ParameterDescriptor:
    """rcl_interfaces/ParameterDescriptor's useful fields."""

    name: str = ''
    type: int = 0
    description: str = ''
    additional_constraints: str = ''
    read_only: bool = False
    dynamic_typing: bool = False
    floating_point_range: list[FloatingPointRange] = field(default_factory=list)
    integer_range: list[IntegerRange] = field(default_factory=list)


@dataclass
class SetParametersResult:
    successful: bool = True
    reason: str = ''


class ParameterNotDeclaredException(ParameterError):
    """``get_parameter`` of a name the node never declared."""


class InvalidParameterValueException(ParameterError):
    """An on-set-parameters callback refused a parameter as it was declared (rclpy's exception and text)."""

    def __init__(self, parameter: str, value: Any, reason: str) -> None:
        super().__init__(f'Invalid parameter value ({value}) for parameter. Reason: {reason}', parameter)
        self.parameter = parameter
        self.reason = reason

    def __str__(self) -> str:
        return f"{self.args[0]} (parameter '{self.parameter}')"


def type_name(type_: ParameterType) -> str:
    """``'double array'`` for DOUBLE_ARRAY."""
    return ParameterType(type_).name.lower().replace('_', ' ')


def coerce_to_type(name: str, value: Any, expected: ParameterType, node: str, source: Any) -> Any:
    """``value`` as a parameter of type ``expected``, or ParameterError naming the source.

    An integer is accepted for a double (and becomes a float): YAML writes ``1`` for 1.0
    and the strict ROS 2 rule trips up users for no gain.
    """
    got = _infer_type(value)
    if got == expected or expected == ParameterType.NOT_SET:
        return value
    if expected == ParameterType.DOUBLE and got == ParameterType.INTEGER:
        return float(value)
    if expected == ParameterType.DOUBLE_ARRAY and got == ParameterType.INTEGER_ARRAY:
        return [float(v) for v in value]
    where = f'{source}: ' if source else ''
    article = 'an' if type_name(expected)[0] in 'aeiou' else 'a'
    raise ParameterError(f"{where}parameter '{name}' of {node} must be {article} {type_name(expected)}; "
                         f'got {type_name(got)} {value!r}')


#: rclpy's relative tolerance for range edges and steps (rclpy.node.Node.PARAM_REL_TOL).
PARAM_REL_TOL = 1e-6


def check_ranges(name: str, value: Any, descriptor: ParameterDescriptor, node: str) -> str | None:
    """Why ``value`` is outside the descriptor's range, or None: rclpy's rule and text (its first range
    only; edges within PARAM_REL_TOL pass; NaN is out of any range; a step is checked from the lower
    end), followed by ours naming the node."""
    if descriptor.floating_point_range and isinstance(value, float):
        rng = descriptor.floating_point_range[0]
        low, high = min(rng.from_value, rng.to_value), max(rng.from_value, rng.to_value)
        ours = f"parameter '{name}' of {node} must be in [{low}, {high}]; got {value!r}"
        if math.isclose(value, low, rel_tol=PARAM_REL_TOL) or math.isclose(value, high, rel_tol=PARAM_REL_TOL):
            return None
        if not low < value < high:
            return f'Parameter {name} out of range Min: {low}, Max: {high}, value: {value} ({ours})'
        if rng.step != 0.0 and not math.isclose(low + round((value - low) / rng.step) * rng.step, value,
                                                 rel_tol=PARAM_REL_TOL):
            return (f'The parameter value for {name} is not close enough to a valid step. Min: {low}, max: {high}, '
                    f'value: {value}, step: {rng.step} ({node})')
    if descriptor.integer_range and isinstance(value, int) and not isinstance(value, bool):
        rng = descriptor.integer_range[0]
        low, high = min(rng.from_value, rng.to_value), max(rng.from_value, rng.to_value)
        if value in (low, high):
            return None
        if not low < value < high:
            return (f'Parameter {name} out of range. Min: {low}, Max: {high}, value: {value} '
                    f"(parameter '{name}' of {node} must be in [{low}, {high}]; got {value!r})")
        if rng.step != 0 and (value - low) % rng.step != 0:
            return (f'The parameter value for {name} is not a valid step. Min: {low}, max: {high}, value: {value}, '
                    f'step: {rng.step} ({node})')
    return None


# --------------------------------------------------------------------------- parameter files

def load_parameter_file(path: str | Path, text: str | None = None) -> ParameterOverrides:
    """Read a ROS 2 parameter YAML file by rcl's rules (:mod:`.param_yaml`); errors name file and line."""
    return ParameterOverrides.from_file(path, text)


# --------------------------------------------------------------------------- --ros-args

@dataclass
class RosArgs:
    """What ``--ros-args`` gave: remap rules, parameter values, parameter files, log level.

    ``params`` and ``params_files`` list what was given; :meth:`overrides` merges them in the
    order they were given, as rcl merges them into one set of overrides.
    """

    remaps: list[str] = field(default_factory=list)
    params: list[tuple[str, Any]] = field(default_factory=list)
    params_files: list[str] = field(default_factory=list)
    log_level: str | None = None
    unparsed: list[str] = field(default_factory=list)
    _ordered: list[tuple[str, Any]] = field(default_factory=list, repr=False, compare=False)

    def overrides(self) -> ParameterOverrides:
        """Files and ``-p`` values merged in argument order; ``-p`` applies to every node (``/**``)."""
        out = ParameterOverrides()
        for kind, item in self._ordered:
            if kind == 'file':
                out.merge(load_parameter_file(item))
            else:
                name, value = item
                out.set('/**', name, OverrideValue(value, '--ros-args -p'))
        return out


def parse_ros_args(args: list[str] | None) -> RosArgs:
    """Parse ``[... --ros-args -r a:=b -p x:=1 --params-file F --log-level debug -- ...]``.

    ``-p`` values are typed by rcl's rules (``-p rate:=1e-6`` is a double, ``-p t:=1:30`` a string).
    """
    out = RosArgs()
    if not args:
        return out
    i, inside = 0, False
    while i < len(args):
        arg = args[i]
        if arg == '--ros-args':
            inside = True
        elif arg == '--' and inside:
            inside = False
        elif not inside:
            out.unparsed.append(arg)
        elif arg in ('-r', '--remap', '-p', '--param', '--params-file', '--log-level', '-e', '--enclave'):
            if i + 1 >= len(args):
                raise ParameterError(f'--ros-args: {arg} needs a value')
            value = args[i + 1]
            i += 1
            if arg in ('-r', '--remap'):
                out.remaps.append(value)
            elif arg in ('-p', '--param'):
                if ':=' not in value:
                    raise ParameterError(f'--ros-args -p expects name:=value, got {value!r}')
                name, text = value.split(':=', 1)
                if not name:
                    raise ParameterError(f'--ros-args -p {value!r}: the parameter name is empty')
                try:
                    parsed = parse_parameter_value(text, f'-p {name}')
                except ConfigError as err:
                    raise ParameterError(f'--ros-args -p {value!r}: {err.bare_message}') from err
                out.params.append((name, parsed))
                out._ordered.append(('param', (name, parsed)))
            elif arg == '--params-file':
                out.params_files.append(value)
                out._ordered.append(('file', value))
            elif arg == '--log-level':
                out.log_level = value
        else:
            raise ParameterError(f'--ros-args: unknown argument {arg!r}; supported: -r/--remap from:=to, '
                                 '-p/--param name:=value, --params-file FILE, --log-level LEVEL')
        i += 1
    return out


# Parameters to and from their rcl_interfaces messages, as rclpy converts them.

ParameterValue = get_message('rcl_interfaces/msg/ParameterValue')
ParameterMsg = get_message('rcl_interfaces/msg/Parameter')
DescriptorMsg = get_message('rcl_interfaces/msg/ParameterDescriptor')
FloatRangeMsg = get_message('rcl_interfaces/msg/FloatingPointRange')
IntegerRangeMsg = get_message('rcl_interfaces/msg/IntegerRange')
ParameterEvent = get_message('rcl_interfaces/msg/ParameterEvent')

def _field(type_: ParameterType) -> str:
    """The ParameterValue field holding a value of ``type_`` (``double_array_value``)."""
    return f'{ParameterType(type_).name.lower()}_value'


def parameter_value(param: Parameter) -> Any:
    """The ``ParameterValue`` of a parameter (``type`` NOT_SET, no value, for an unset one).

    >>> msg = parameter_value(Parameter('rate', value=25.0))
    >>> msg.type, msg.double_value
    (3, 25.0)
    >>> value_of(parameter_value(Parameter('names', value=['a', 'b'])))
    ['a', 'b']
    >>> parameter_from_msg(parameter_msg(Parameter('on', value=True)))
    Parameter('on', BOOL, True)
    """
    if param.type_ == ParameterType.NOT_SET or param.value is None:
        return ParameterValue(type=int(ParameterType.NOT_SET))
    value = param.value
    if param.type_ == ParameterType.BYTE_ARRAY:
        value = np.frombuffer(bytes(value), np.uint8) if isinstance(value, (bytes, bytearray)) else value
    return ParameterValue(type=int(param.type_), **{_field(param.type_): value})


def value_of(msg: Any) -> Any:
    """The Python value a ``ParameterValue`` holds (None for NOT_SET or an unknown type)."""
    try:
        kind = ParameterType(msg.type)
    except ValueError:
        return None
    if kind == ParameterType.NOT_SET:
        return None
    value = getattr(msg, _field(kind))
    if kind == ParameterType.BYTE_ARRAY:
        return bytes(np.asarray(value, np.uint8))
    if isinstance(value, (np.ndarray, array.array)):  # array.array: rclpy's integer and double arrays
        return value.tolist()
    return list(value) if isinstance(value, list) else value


def parameter_msg(param: Parameter) -> Any:
    return ParameterMsg(name=param.name, value=parameter_value(param))


def parameter_from_msg(msg: Any) -> Parameter:
    """A :class:`Parameter` from an ``rcl_interfaces/Parameter`` (an unknown type reads as NOT_SET)."""
    value = value_of(msg.value)
    if value is None:
        return Parameter(msg.name, ParameterType.NOT_SET, None)
    return Parameter(msg.name, ParameterType(msg.value.type), value)


def descriptor_msg(descriptor: ParameterDescriptor) -> Any:
    return DescriptorMsg(
        name=descriptor.name, type=int(descriptor.type), description=descriptor.description,
        additional_constraints=descriptor.additional_constraints, read_only=descriptor.read_only,
        dynamic_typing=descriptor.dynamic_typing,
        floating_point_range=[FloatRangeMsg(from_value=float(r.from_value), to_value=float(r.to_value),
                                            step=float(r.step)) for r in descriptor.floating_point_range[:1]],
        integer_range=[IntegerRangeMsg(from_value=int(r.from_value), to_value=int(r.to_value), step=int(r.step))
                       for r in descriptor.integer_range[:1]])


def descriptor_from_msg(msg: Any) -> ParameterDescriptor:
    return ParameterDescriptor(
        name=msg.name, type=int(msg.type), description=msg.description,
        additional_constraints=msg.additional_constraints, read_only=msg.read_only,
        dynamic_typing=msg.dynamic_typing,
        floating_point_range=[FloatingPointRange(r.from_value, r.to_value, r.step) for r in msg.floating_point_range],
        integer_range=[IntegerRange(r.from_value, r.to_value, r.step) for r in msg.integer_range])


def parameter_event(node: str, stamp: Any, new: list[Parameter] = (), changed: list[Parameter] = (),
                    deleted: list[Parameter] = ()) -> Any:
    """The ``ParameterEvent`` of a node (fully qualified name) at ``stamp`` (``builtin_interfaces/Time``)."""
    return ParameterEvent(stamp=stamp, node=node, new_parameters=[parameter_msg(p) for p in new],
                          changed_parameters=[parameter_msg(p) for p in changed],
                          deleted_parameters=[parameter_msg(p) for p in deleted])
