"""Type descriptions and RIHS01 type hashes as ROS 2 (Iron and later) computes them.

The hash (REP-2011) is the SHA-256 of ``type_description_interfaces/msg/TypeDescription`` as JSON
in ``rosidl_generator_type_description``'s layout, built from the rosbags type store with rosidl's
mapping (``char`` is ``uint8``, ``byte`` is ``octet``; rosbags' ``hash_rihs01`` differs there). A
service is described as rosidl does: ``request_message``, ``response_message``, ``event_message``.

>>> type_hash('std_msgs/msg/Char')
'RIHS01_3ad2d04dd29ba19d04b16659afa3ccaedd691914b02a64e82e252f2fa6a586a9'
"""

from __future__ import annotations

import hashlib
import json
import threading
from typing import Any

from rosbags.interfaces import Nodetype

from .errors import MessageError
from .messages import typestore

__all__ = ['FIELD_TYPE_IDS', 'hash_description', 'individual_description', 'type_description', 'type_hash']

#: ``type_description_interfaces/msg/FieldType`` ids of the scalar types, by ``.msg`` name.
FIELD_TYPE_IDS = {
    'nested': 1, 'int8': 2, 'uint8': 3, 'char': 3, 'int16': 4, 'uint16': 5, 'int32': 6, 'uint32': 7,
    'int64': 8, 'uint64': 9, 'float32': 10, 'float64': 11, 'bool': 15, 'byte': 16,
    'string': 17, 'wstring': 18, 'bounded_string': 21, 'bounded_wstring': 22,
}
#: What ``FieldType`` adds to a scalar id for a fixed array, a bounded and an unbounded sequence.
_ARRAY, _BOUNDED_SEQUENCE, _UNBOUNDED_SEQUENCE = 48, 96, 144

#: ``service_msgs/msg/ServiceEventInfo`` (Jazzy), which every service's ``_Event`` message refers to.
_SERVICE_EVENT_INFO = 'service_msgs/msg/ServiceEventInfo'

_lock = threading.Lock()
_hashes: dict[str, str] = {}


def _field_type(desc: tuple) -> dict[str, Any]:
    """``FieldType`` of a rosbags field descriptor."""
    kind, detail = desc
    capacity, offset = 0, 0
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        (kind, detail), size = detail
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            raise MessageError('nested arrays are not ROS 2 types')
        if desc[0] == Nodetype.ARRAY:
            capacity, offset = size, _ARRAY
        elif size:
            capacity, offset = size, _BOUNDED_SEQUENCE
        else:
            offset = _UNBOUNDED_SEQUENCE
    nested, string_capacity = '', 0
    if kind == Nodetype.BASE:
        base, bound = detail
        if base in ('string', 'wstring') and bound:
            string_capacity, base = bound, f'bounded_{base}'
        if base not in FIELD_TYPE_IDS:
            raise MessageError(f"'{base}' is not a ROS 2 field type")
        type_id = FIELD_TYPE_IDS[base]
    elif kind == Nodetype.NAME:
        type_id, nested = FIELD_TYPE_IDS['nested'], detail
    else:
        raise MessageError(f'unsupported field descriptor {desc!r}')
    return {'type_id': type_id + offset, 'capacity': capacity, 'string_capacity': string_capacity,
            'nested_type_name': nested}


def _field(name: str, field_type: dict[str, Any]) -> dict[str, Any]:
    return {'name': name, 'type': field_type, 'default_value': ''}


def _nested(name: str, type_name: str, capacity: int = 0) -> dict[str, Any]:
    type_id = FIELD_TYPE_IDS['nested'] + (_BOUNDED_SEQUENCE if capacity else 0)
    return _field(name, {'type_id': type_id, 'capacity': capacity, 'string_capacity': 0,
                         'nested_type_name': type_name})


def _service_of(type_name: str) -> str:
    """``pkg/srv/X`` of ``pkg/srv/X`` (a service) or ``pkg/srv/X_Event``; '' for anything else."""
    pkg, _, rest = type_name.partition('/srv/')
    if not rest or not pkg:
        return ''
    return type_name[:-len('_Event')] if rest.endswith('_Event') else type_name


def individual_description(type_name: str, store: Any = None) -> dict[str, Any]:
    """``IndividualTypeDescription`` of one type (as a dict): its name and fields, nested types by name.

    Raises:
        MessageError: for a type the type store does not know.
    """
    if store is None:
        store = typestore
    if type_name in store.fielddefs:
        _, fields = store.fielddefs[type_name]
        return {'type_name': type_name, 'fields': [_field(name, _field_type(desc)) for name, desc in fields]}
    service = _service_of(type_name)
    if service and f'{service}_Request' in store.fielddefs:
        if type_name == service:
            return {'type_name': type_name, 'fields': [
                _nested('request_message', f'{service}_Request'), _nested('response_message', f'{service}_Response'),
                _nested('event_message', f'{service}_Event')]}
        return {'type_name': type_name, 'fields': [
            _nested('info', _SERVICE_EVENT_INFO), _nested('request', f'{service}_Request', 1),
            _nested('response', f'{service}_Response', 1)]}
    raise MessageError(f"no type description for unknown type '{type_name}'")


def type_description(type_name: str, store: Any = None) -> dict[str, Any]:
    """``TypeDescription`` (as a dict): ``type_description`` and ``referenced_type_descriptions`` (sorted by name)."""
    top = individual_description(type_name, store)
    seen: dict[str, dict[str, Any]] = {}
    queue = [f['type']['nested_type_name'] for f in top['fields'] if f['type']['nested_type_name']]
    while queue:
        name = queue.pop()
        if name in seen:
            continue
        seen[name] = individual_description(name, store)
        queue += [f['type']['nested_type_name'] for f in seen[name]['fields'] if f['type']['nested_type_name']]
    return {'type_description': top, 'referenced_type_descriptions': [seen[n] for n in sorted(seen)]}


def hash_description(description: dict[str, Any]) -> str:
    """RIHS01 hash of a ``TypeDescription`` dict (default values are left out, as REP-2011 says)."""
    stripped = {
        'type_description': _without_defaults(description['type_description']),
        'referenced_type_descriptions': [_without_defaults(t) for t in description['referenced_type_descriptions']],
    }
    text = json.dumps(stripped, ensure_ascii=True, allow_nan=False, separators=(', ', ': '), sort_keys=False)
    return 'RIHS01_' + hashlib.sha256(text.encode('utf-8')).hexdigest()


def _without_defaults(individual: dict[str, Any]) -> dict[str, Any]:
    return {'type_name': individual['type_name'],
            'fields': [{'name': f['name'], 'type': f['type']} for f in individual['fields']]}


def type_hash(type_name: str, store: Any = None) -> str:
    """The RIHS01 hash ROS 2 computes for ``type_name`` (a message ``pkg/msg/X`` or a service ``pkg/srv/X``).

    Args:
        store: a rosbags type store other than the runtime's (not cached).

    Raises:
        MessageError: for a type that is not known.
    """
    if store is not None:
        return hash_description(type_description(type_name, store))
    with _lock:
        value = _hashes.get(type_name)
    if value is None:
        value = hash_description(type_description(type_name))
        with _lock:
            _hashes[type_name] = value
    return value
