"""The Python type of every field of every message type of ours, on real rclpy or on our runtime.

``python test/field_types_probe.py rclpy|ours`` prints one JSON object: for each type in msg/*.msg,
and for each field, the type its value has when the message is made with defaults (``default``),
after a value is assigned to every field (``assigned``: a list to a fixed-size array, a numpy array
to a sequence, Python bools to a bool array...), and as a subscriber receives it (``received``:
serialised and deserialised, as rclpy's ``serialize_message``/``deserialize_message`` and our CDR
codec do). test/test_field_types.py compares the backends and holds ours to rclpy's rule.
"""

from __future__ import annotations

import array
import importlib
import json
import re
import sys
from pathlib import Path
from typing import Any

import numpy as np

MSG_DIR = Path(__file__).resolve().parents[1] / 'msg'
#: ``base[N]``, ``base[]``, ``base[<=N]`` (ours) or ``sequence<base>``, ``sequence<base, N>`` (rclpy's).
_ARRAY = re.compile(r'^(?P<base>[\w/]+?)(?:<=\d+)?\[(?P<size>\d*|<=\d+)\]$')
_SEQUENCE = re.compile(r'^sequence<(?P<base>[\w/]+?)(?:<=\d+)?(?:, ?\d+)?>$')


def describe(value: Any) -> str:
    """``ndarray[float32]``, ``array.array[d]``, ``list[bool]``, ``int``..."""
    if isinstance(value, np.ndarray):
        return f'ndarray[{value.dtype}]'
    if isinstance(value, array.array):
        return f'array.array[{value.typecode}]'
    if isinstance(value, list):
        return f'list[{type(value[0]).__name__}]' if value else 'list[]'
    return type(value).__name__


def sample(type_str: str, cls_of: Any) -> Any:
    """A value for a field of ``type_str`` (``float32[144]``, ``float64[]``, ``SensorState[]``...)."""
    match = _ARRAY.match(type_str) or _SEQUENCE.match(type_str)
    if match is None:
        return None  # scalars and nested messages keep their defaults
    base, size = match['base'], match.groupdict().get('size') or ''
    length = int(size) if size.isdigit() else 2
    if base in ('boolean', 'bool'):
        return [True] * length
    if base == 'string':
        return ['a'] * length
    if '/' in base:
        return [cls_of(base)() for _ in range(length)]
    if size.isdigit():
        return list(range(length))          # a list where a fixed-size array belongs
    return np.arange(length, dtype=np.float64 if base.startswith(('float', 'double')) else np.int64)


def run(backend: str) -> dict[str, Any]:
    if backend == 'rclpy':
        from rclpy.serialization import deserialize_message, serialize_message

        def cls_of(name: str) -> Any:
            package, _, type_name = name.rpartition('/')
            package = package.split('/')[0] if '/' in package else package
            return getattr(importlib.import_module(f'{package}.msg'), type_name)

        def roundtrip(msg: Any) -> Any:
            return deserialize_message(serialize_message(msg), type(msg))
    else:
        from touch_graph.messages import deserialize, get_message, serialize

        def cls_of(name: str) -> Any:
            return get_message(name if '/' in name else f'social_touch_msgs/msg/{name}')

        def roundtrip(msg: Any) -> Any:
            return deserialize(serialize(msg), msg.__msgtype__)
    out: dict[str, Any] = {}
    for path in sorted(MSG_DIR.glob('*.msg')):
        cls = cls_of(f'social_touch_msgs/{path.stem}')
        fields = cls.get_fields_and_field_types()
        default, filled = cls(), cls()
        for name, type_str in fields.items():
            value = sample(type_str, cls_of)
            if value is not None:
                setattr(filled, name, value)
        received = roundtrip(filled)
        out[path.stem] = {name: {'default': describe(getattr(default, name)),
                                 'assigned': describe(getattr(filled, name)),
                                 'received': describe(getattr(received, name))} for name in fields}
    return out


if __name__ == '__main__':
    print(json.dumps(run(sys.argv[1]), sort_keys=True))
