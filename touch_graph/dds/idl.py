"""DDS type descriptions (XTypes) of ROS 2 messages, generated from the ``.msg`` definitions.

cyclonedds-python registers no type without one; it says what ROS 2's IDL says, as rmw_cyclonedds
builds it: structs ``@final`` named ``pkg::msg::dds_::Name_``, ``byte``/``char`` as ``uint8``, fixed
arrays, bounded sequences and strings. Payloads are never serialised by cyclonedds: they are the
CDR bytes :mod:`touch_graph.messages` makes (for a final type XCDR1 is ROS 2's classic CDR).
"""

from __future__ import annotations

import threading
from typing import Any

from cyclonedds.idl import IdlStruct, make_idl_struct
from cyclonedds.idl import types as t
from rosbags.interfaces import Nodetype

from ..errors import MessageError
from ..messages import typestore
from .names import dds_type_name

__all__ = ['REQUEST_HEADER_FIELDS', 'idl_service_struct', 'idl_struct']

#: The request header rmw_cyclonedds writes before a request's or a reply's fields (``cdds_request_header_t``):
#: the client's id (its request writer's instance handle) and the request's sequence number.
REQUEST_HEADER_FIELDS = (('request_guid', t.uint64), ('request_seq', t.int64))

_BASES: dict[str, Any] = {
    'bool': bool, 'byte': t.uint8, 'char': t.uint8, 'uint8': t.uint8, 'int8': t.int8,
    'int16': t.int16, 'uint16': t.uint16, 'int32': t.int32, 'uint32': t.uint32,
    'int64': t.int64, 'uint64': t.uint64, 'float32': t.float32, 'float64': t.float64,
}

_lock = threading.Lock()
_cache: dict[tuple[int, str], type[IdlStruct]] = {}


def idl_struct(ros_type: str, store: Any = None) -> type[IdlStruct]:
    """The cyclonedds ``IdlStruct`` class describing ``pkg/msg/Name`` (cached).

    Args:
        ros_type: a full type name known to ``store``.
        store: a rosbags typestore (default :data:`touch_graph.messages.typestore`).

    Raises:
        MessageError: for a type the store does not know or a field DDS cannot describe.
    """
    if store is None:
        store = typestore
    key = (id(store), ros_type)
    with _lock:
        cls = _cache.get(key)
        if cls is None:
            cls = _cache[key] = _build(ros_type, store)
        return cls


def idl_service_struct(ros_type: str, store: Any = None) -> type[IdlStruct]:
    """The ``IdlStruct`` of a request or reply on the wire: the request header, then ``ros_type``'s fields.

    ``ros_type`` is ``pkg/srv/Name_Request`` or ``pkg/srv/Name_Response``; the DDS type name is
    ROS 2's (``pkg::srv::dds_::Name_Request_``). Cyclone checks every received payload against
    this description, so it must hold the 16 header bytes rmw_cyclonedds puts first. ROS 2 up to
    Kilted announces no type information for services, so peers match it by name.
    """
    if store is None:
        store = typestore
    key = (id(store), 'header+' + ros_type)
    with _lock:
        cls = _cache.get(key)
        if cls is None:
            if ros_type not in store.fielddefs:
                raise MessageError(f'no definition of {ros_type} to describe it to DDS')
            fields = store.fielddefs[ros_type][1]
            clash = {name for name, _ in fields} & {name for name, _ in REQUEST_HEADER_FIELDS}
            if clash:
                raise MessageError(f'{ros_type} has a field named {sorted(clash)[0]!r}, which the request header '
                                   'uses on DDS; rename it')
            annotations = dict(REQUEST_HEADER_FIELDS)
            annotations.update({name: _field_type(ros_type, name, desc, store) for name, desc in fields})
            cls = _cache[key] = make_idl_struct(ros_type.rsplit('/', 1)[-1] + '_', dds_type_name(ros_type),
                                                annotations)
        return cls


def _build(ros_type: str, store: Any) -> type[IdlStruct]:
    if ros_type not in store.fielddefs:
        raise MessageError(f'no definition of {ros_type} to describe it to DDS')
    _consts, fields = store.fielddefs[ros_type]
    annotations = {name: _field_type(ros_type, name, desc, store) for name, desc in fields}
    class_name = ros_type.rsplit('/', 1)[-1] + '_'
    return make_idl_struct(class_name, dds_type_name(ros_type), annotations)


def _field_type(owner: str, field: str, desc: tuple, store: Any) -> Any:
    kind, detail = desc
    if kind == Nodetype.BASE:
        base, bound = detail
        if base == 'string':
            return t.bounded_str[bound] if bound else str
        if base not in _BASES:
            raise MessageError(f"field '{field}' of {owner}: type {base} cannot be described to DDS")
        return _BASES[base]
    if kind == Nodetype.NAME:
        return _cached_nested(detail, store)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        element, size = detail
        item = _field_type(owner, field, element, store)
        if kind == Nodetype.ARRAY:
            return t.array[item, size]
        return t.sequence[item, size] if size else t.sequence[item]
    raise MessageError(f"field '{field}' of {owner}: unsupported descriptor {desc!r}")


def _cached_nested(ros_type: str, store: Any) -> type[IdlStruct]:
    key = (id(store), ros_type)
    cls = _cache.get(key)  # the caller holds _lock
    if cls is None:
        cls = _cache[key] = _build(ros_type, store)
    return cls
