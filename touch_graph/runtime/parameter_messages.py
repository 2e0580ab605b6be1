"""Parameters to and from their ``rcl_interfaces`` messages (``ParameterValue``, ``Parameter``,
``ParameterDescriptor``, ``ParameterEvent``), as rclpy converts them.

>>> msg = parameter_value(Parameter('rate', value=25.0))
>>> msg.type, msg.double_value
(3, 25.0)
>>> value_of(parameter_value(Parameter('names', value=['a', 'b'])))
['a', 'b']
>>> parameter_from_msg(parameter_msg(Parameter('on', value=True)))
Parameter('on', BOOL, True)
"""

from __future__ import annotations

from typing import Any

import numpy as np

from ..messages import get_message
from .parameters import FloatingPointRange, IntegerRange, Parameter, ParameterDescriptor, ParameterType

__all__ = ['descriptor_from_msg', 'descriptor_msg', 'parameter_event', 'parameter_from_msg', 'parameter_msg',
           'parameter_value', 'value_of']

ParameterValue = get_message('rcl_interfaces/msg/ParameterValue')
ParameterMsg = get_message('rcl_interfaces/msg/Parameter')
DescriptorMsg = get_message('rcl_interfaces/msg/ParameterDescriptor')
FloatRangeMsg = get_message('rcl_interfaces/msg/FloatingPointRange')
IntegerRangeMsg = get_message('rcl_interfaces/msg/IntegerRange')
ParameterEvent = get_message('rcl_interfaces/msg/ParameterEvent')

#: ParameterType -> the ParameterValue field holding such a value.
FIELDS = {
    ParameterType.BOOL: 'bool_value', ParameterType.INTEGER: 'integer_value', ParameterType.DOUBLE: 'double_value',
    ParameterType.STRING: 'string_value', ParameterType.BYTE_ARRAY: 'byte_array_value',
    ParameterType.BOOL_ARRAY: 'bool_array_value', ParameterType.INTEGER_ARRAY: 'integer_array_value',
    ParameterType.DOUBLE_ARRAY: 'double_array_value', ParameterType.STRING_ARRAY: 'string_array_value',
}


def parameter_value(param: Parameter) -> Any:
    """The ``ParameterValue`` of a parameter (``type`` NOT_SET, no value, for an unset one)."""
    if param.type_ == ParameterType.NOT_SET or param.value is None:
        return ParameterValue(type=int(ParameterType.NOT_SET))
    value = param.value
    if param.type_ == ParameterType.BYTE_ARRAY:
        value = np.frombuffer(bytes(value), np.uint8) if isinstance(value, (bytes, bytearray)) else value
    return ParameterValue(type=int(param.type_), **{FIELDS[param.type_]: value})


def value_of(msg: Any) -> Any:
    """The Python value a ``ParameterValue`` holds (None for NOT_SET or an unknown type)."""
    try:
        kind = ParameterType(msg.type)
    except ValueError:
        return None
    if kind == ParameterType.NOT_SET:
        return None
    value = getattr(msg, FIELDS[kind])
    if kind == ParameterType.BYTE_ARRAY:
        return bytes(np.asarray(value, np.uint8))
    if isinstance(value, np.ndarray):
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
