"""Message classes generated at import from the package's rosidl ``.msg`` files.

The ``.msg`` files in ``msg/`` are the one definition of every message. The rosbags
type system parses them (and knows the standard ROS 2 types such as
``std_msgs/msg/Header``); this module turns each type into a Python class with rclpy's
manners: keyword construction with ROS defaults for every field, checked field types,
constants as class attributes, ``get_fields_and_field_types()`` (with rclpy's IDL type names:
``float[144]``, ``sequence<double>``, ``boolean``, ``octet`` for ``byte``). CDR (de)serialisation,
the bytes ROS 2 puts on the wire and in bags, comes from an encoder and a decoder generated
per type (:mod:`touch_graph.cdr`), byte-identical to rosbags', which still decodes
big-endian payloads and the types the generator does not handle.

Type names are those of the interface package ``social_touch-export-interfaces`` writes
(``social_touch_msgs/msg/SkinFrame``), so bags recorded here open on a ROS 2 machine.

Field types are rclpy's, on construction, on assignment and on receipt: a fixed-size numeric
array (``float32[144]``) is a ``numpy.ndarray`` of the field's dtype; a numeric sequence
(``float64[]``, ``uint8[<=N]``) is an ``array.array`` of the matching typecode; ``bool[N]`` and
``bool[]`` are lists of Python bools (rclpy aborts the process on numpy bools there, so they are
refused: pass ``.tolist()``); strings and messages in arrays are lists. As with rclpy's
generated properties, assigning a field converts or checks the value. A numpy array passed
with the right dtype is kept, not copied: in process, publishers and subscribers share it, as
with intra-process communication in ROS 2, so do not modify a message after publishing it.

>>> Header = get_message('std_msgs/msg/Header')
>>> h = Header(frame_id='bear')
>>> deserialize(serialize(h), 'std_msgs/msg/Header') == h
True
>>> try:
...     Header(frame_idd='bear')
... except MessageError as err:
...     print(err)
std_msgs/msg/Header has no field 'frame_idd' (did you mean 'frame_id'?); its fields are: stamp, frame_id
"""

from __future__ import annotations

import array
import math
import operator
import struct
import threading
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from rosbags.interfaces import Nodetype
from rosbags.serde import SerdeError
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.base import TypesysError

from .cdr import OCTETS, Codec, UnsupportedType, make_codec
from .errors import MessageError
from .paths import INTERFACE_PACKAGE, share_file
from .srv_definitions import service_types
from .yamlconf import did_you_mean

__all__ = [
    'Message', 'decoder', 'deserialize', 'encoder', 'from_dict', 'get_message',
    'interface_names', 'message_definition', 'msg_field_types', 'msg_files', 'normalize_type_name', 'serialize',
    'to_dict', 'typestore',
]

_INT_RANGES = {
    'int8': (-2**7, 2**7 - 1), 'uint8': (0, 2**8 - 1), 'byte': (0, 255), 'char': (0, 255),
    'int16': (-2**15, 2**15 - 1), 'uint16': (0, 2**16 - 1),
    'int32': (-2**31, 2**31 - 1), 'uint32': (0, 2**32 - 1),
    'int64': (-2**63, 2**63 - 1), 'uint64': (0, 2**64 - 1),
}
_FLOATS = {'float32': np.float32, 'float64': np.float64}
_DTYPES = {**{k: np.dtype(k) for k in _INT_RANGES if k not in ('byte', 'char')},
           'byte': np.dtype(np.uint8), 'char': np.dtype(np.uint8), 'bool': np.dtype(np.bool_),
           **{k: np.dtype(v) for k, v in _FLOATS.items()}}

#: ``array.array`` typecodes of numeric sequences, as rclpy's generated classes use them.
_TYPECODES = {'int8': 'b', 'uint8': 'B', 'char': 'B', 'int16': 'h', 'uint16': 'H', 'int32': 'i', 'uint32': 'I',
              'int64': 'q', 'uint64': 'Q', 'float32': 'f', 'float64': 'd'}

_lock = threading.RLock()
_classes: dict[str, type[Message]] = {}
_codecs: dict[str, Codec | None] = {}


def msg_files() -> list[Path]:
    """The package's ``.msg`` files, sorted by name."""
    return sorted(share_file('msg').glob('*.msg'))


def _build_typestore():
    store = get_typestore(Stores.LATEST)
    types: dict = {}
    for path in msg_files():
        name = f'{INTERFACE_PACKAGE}/msg/{path.stem}'
        try:
            types.update(get_types_from_msg(path.read_text(encoding='utf-8'), name))
        except (TypesysError, Exception) as err:  # the parser raises several kinds
            raise MessageError(f'{path}: cannot parse message definition: {err}') from err
    store.register(types)
    store.register(service_types())
    return store


#: The rosbags type store holding the standard ROS 2 types and this package's messages.
typestore = _build_typestore()


def interface_names() -> list[str]:
    """Full names of this package's message types, e.g. ``social_touch_msgs/msg/SkinFrame``."""
    return [f'{INTERFACE_PACKAGE}/msg/{p.stem}' for p in msg_files()]


def normalize_type_name(name: str) -> str:
    """``pkg/msg/T``, ``pkg/T`` or a bare ``T`` of this package -> ``pkg/msg/T``.

    Raises:
        MessageError: when no such type is known.
    """
    parts = name.strip().split('/')
    if len(parts) == 2:
        parts = [parts[0], 'msg', parts[1]]
    elif len(parts) == 1:
        parts = [INTERFACE_PACKAGE, 'msg', parts[0]]
    full = '/'.join(parts)
    if full not in typestore.fielddefs:
        known = list(typestore.fielddefs)
        raise MessageError(f"unknown message type '{name}'{did_you_mean(full, known)}; this package's "
                           f'types are: {", ".join(interface_names())}')
    return full


class Message:
    """Base class of generated message classes (rclpy-like).

    Subclasses have ``__slots__`` for their fields, ``__msgtype__`` (the full type name),
    ``_fields`` (field names in definition order) and constants as class attributes.
    """

    __slots__ = ()
    __msgtype__: ClassVar[str]
    _fields: ClassVar[tuple[str, ...]]
    _field_types: ClassVar[dict[str, str]]
    _msg_field_types: ClassVar[dict[str, str]]

    @classmethod
    def get_fields_and_field_types(cls) -> dict[str, str]:
        """Field name -> ROS type string, as on rclpy's generated classes."""
        return dict(cls._field_types)

    def __eq__(self, other: object) -> bool:
        if type(other) is not type(self):
            return NotImplemented
        return all(_values_equal(getattr(self, f), getattr(other, f)) for f in self._fields)

    __hash__ = None  # mutable, like rclpy messages

    def __repr__(self) -> str:
        pkg, kind, name = self.__msgtype__.split('/')
        body = ', '.join(f'{f}={getattr(self, f)!r}' for f in self._fields)
        return f'{pkg}.{kind}.{name}({body})'


def _values_equal(a: Any, b: Any) -> bool:
    # NaN equals NaN here: a round trip through CDR must compare equal.
    if isinstance(a, (np.ndarray, array.array)) or isinstance(b, (np.ndarray, array.array)):
        a, b = np.asarray(a), np.asarray(b)
        if a.shape != b.shape:
            return False
        if a.dtype.kind == 'f' and b.dtype.kind == 'f':
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(np.array_equal(a, b))
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    if isinstance(a, list) and isinstance(b, list):
        return len(a) == len(b) and all(_values_equal(x, y) for x, y in zip(a, b, strict=True))
    return a == b


# --------------------------------------------------------------------------- field converters
# Each field gets a converter: value -> checked value, raising FieldError with the field name.

class FieldError(MessageError, AssertionError):
    """A value a message field does not take. Also an ``AssertionError``: what rclpy's generated setters
    raise for it (with ``ROS_PYTHON_CHECK_FIELDS=1``), so a node catching either catches it on both runtimes."""


def _fail(owner: str, field: str, expected: str, value: Any, hint: str = '') -> FieldError:
    shown = f'array of dtype {value.dtype} and shape {value.shape}' if isinstance(value, np.ndarray) \
        else f'{type(value).__name__} {value!r}'[:120]
    return FieldError(f"field '{field}' of {owner} expects {expected}; got {shown}{hint}")


_BYTE_HINT = ' (a byte field holds bytes of length 1, as in rclpy: write bytes([n]) or b\'\\x01\')'


def _scalar_converter(owner: str, field: str, base: str, bound: int) -> tuple[Callable, Any]:
    if base == 'byte':
        def conv_byte(v: Any) -> bytes:
            if type(v) is bytes and len(v) == 1:
                return v
            if isinstance(v, (bytes, bytearray)) and len(v) == 1:  # rclpy takes a bytearray too
                return OCTETS[v[0]]
            raise _fail(owner, field, 'bytes of length 1 (byte)', v, _BYTE_HINT)
        return conv_byte, OCTETS[0]
    if base in _INT_RANGES:
        lo, hi = _INT_RANGES[base]

        def conv_int(v: Any) -> int:
            if type(v) is int and lo <= v <= hi:  # the common case first: every header's stamp takes it
                return v
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, np.integer)):
                raise _fail(owner, field, f'an int ({base})', v)
            v = int(v)
            if not lo <= v <= hi:
                raise _fail(owner, field, f'an int in [{lo}, {hi}] ({base})', v)
            return v
        return conv_int, 0
    if base in _FLOATS:
        # float32 fields hold the float32-rounded value, so a CDR round trip gives the same message.
        narrow = _FLOATS[base] if base == 'float32' else float
        wide = base != 'float32'

        def conv_float(v: Any) -> float:
            if wide and type(v) is float:  # a Python float is a float64 already
                return v
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, (int, float, np.integer, np.floating)):
                raise _fail(owner, field, f'a float ({base})', v)
            return float(narrow(v))
        return conv_float, 0.0
    if base == 'bool':
        def conv_bool(v: Any) -> bool:
            if type(v) is bool:
                return v
            if not isinstance(v, (bool, np.bool_)):
                raise _fail(owner, field, 'a bool', v)
            return bool(v)
        return conv_bool, False
    if base == 'string':
        def conv_str(v: Any) -> str:
            if type(v) is str and not bound:
                return v
            if not isinstance(v, str):
                raise _fail(owner, field, 'a str', v)
            if bound and len(v) > bound:
                raise _fail(owner, field, f'a str of at most {bound} characters', v)
            return v
        return conv_str, ''
    raise MessageError(f"field '{field}' of {owner} has unsupported type {base}")


def _numeric_array_converter(owner: str, field: str, base: str, length: int | None,
                             bound: int) -> tuple[Callable, Callable]:
    dtype = _DTYPES[base]
    kinds = {'b': 'b', 'i': 'iub', 'u': 'iub', 'f': 'iuf'}[dtype.kind]
    if dtype.kind in 'iu':
        kinds = 'iu'
    expected = f'{length} {base} values ({base}[{length}])' if length else f'a 1-D array of {base} ({base}[])'

    def conv_array(v: Any) -> np.ndarray:
        if isinstance(v, np.ndarray) and v.dtype == dtype:
            arr = v
        else:
            try:
                arr = np.asarray(v)
            except (ValueError, TypeError) as err:
                raise _fail(owner, field, expected, v) from err
            if arr.size == 0:
                arr = arr.astype(dtype)
            elif arr.dtype.kind not in kinds:
                raise _fail(owner, field, expected, v)
            else:
                if dtype.kind in 'iu':
                    lo, hi = _INT_RANGES[base]
                    if int(arr.min()) < lo or int(arr.max()) > hi:
                        raise _fail(owner, field, f'{expected} in [{lo}, {hi}]', v)
                arr = arr.astype(dtype)
        if arr.ndim != 1:
            raise _fail(owner, field, expected, arr, '; flatten it (e.g. .ravel(), row-major)')
        if length is not None and arr.shape[0] != length:
            raise _fail(owner, field, expected, arr)
        if bound and arr.shape[0] > bound:
            raise _fail(owner, field, f'at most {bound} values', arr)
        return arr

    def default() -> np.ndarray:
        return np.zeros(length or 0, dtype=dtype)
    return conv_array, default


def _sequence_converter(owner: str, field: str, base: str, bound: int) -> tuple[Callable, Callable]:
    """A numeric sequence field: an ``array.array`` (rclpy's type), from any numeric iterable."""
    typecode = _TYPECODES[base]
    conv_array, _ = _numeric_array_converter(owner, field, base, None, bound)

    def conv_sequence(v: Any) -> array.array:
        if type(v) is array.array and v.typecode == typecode:
            if bound and len(v) > bound:
                raise _fail(owner, field, f'at most {bound} values', v)
            return v
        out = array.array(typecode)
        out.frombytes(conv_array(v).tobytes())
        return out

    def default() -> array.array:
        return array.array(typecode)
    return conv_sequence, default


def _bool_list_converter(owner: str, field: str, length: int | None, bound: int) -> tuple[Callable, Callable]:
    """A ``bool[N]`` or ``bool[]`` field: a list of Python bools (rclpy aborts on numpy bools there)."""
    expected = f'a list of {length} bools (bool[{length}])' if length else 'a list of bools (bool[])'

    def conv_bools(v: Any) -> list:
        if isinstance(v, np.ndarray):
            raise _fail(owner, field, expected, v, '; pass .tolist(): rclpy aborts the process on numpy bools '
                        "(Assertion 'PyBool_Check(item)' failed)")
        if isinstance(v, (str, bytes, dict)) or not hasattr(v, '__iter__'):
            raise _fail(owner, field, expected, v)
        out = list(v)
        for item in out:
            if type(item) is not bool:
                raise _fail(owner, field, expected, v, f'; an item is {type(item).__name__} (rclpy aborts the '
                            'process on anything but Python bools: pass .tolist() or bool(x))')
        if length is not None and len(out) != length:
            raise _fail(owner, field, expected, v)
        if bound and len(out) > bound:
            raise _fail(owner, field, f'a list of at most {bound} bools', v)
        return out

    def default() -> list:
        return [False] * (length or 0)
    return conv_bools, default


def _octets_converter(owner: str, field: str, length: int | None, bound: int) -> tuple[Callable, Callable]:
    """A ``byte[N]``, ``byte[]`` or ``byte[<=N]`` field: a list of ``bytes`` of length 1 each, as rclpy has it
    (rclpy's checks refuse a ``bytes``, a numpy array or ints there: write ``[bytes([n]) for n in data]``)."""
    what = (f'a list of {length} bytes of length 1 (byte[{length}])' if length
            else 'a list of bytes of length 1 (byte[])')

    def conv_octets(v: Any) -> list:
        if isinstance(v, (str, bytes, bytearray, dict, np.ndarray, array.array)) or not hasattr(v, '__iter__'):
            raise _fail(owner, field, what, v, '; write [bytes([n]) for n in data]')
        out = list(v)
        for item in out:
            if type(item) is not bytes or len(item) != 1:
                raise _fail(owner, field, what, v, f'; an item is {type(item).__name__} {item!r}'[:80] + _BYTE_HINT)
        if length is not None and len(out) != length:
            raise _fail(owner, field, what, v)
        if bound and len(out) > bound:
            raise _fail(owner, field, f'a list of at most {bound} bytes', v)
        return out

    def default() -> list:
        return [OCTETS[0]] * (length or 0)
    return conv_octets, default


def _list_converter(owner: str, field: str, item_conv: Callable, item_default: Callable,
                    length: int | None, bound: int, what: str) -> tuple[Callable, Callable]:
    def conv_list(v: Any) -> list:
        if isinstance(v, (str, bytes, dict)) or not hasattr(v, '__iter__'):
            raise _fail(owner, field, f'a list of {what}', v)
        out = [item_conv(x) for x in v]
        if length is not None and len(out) != length:
            raise _fail(owner, field, f'a list of exactly {length} {what}', v)
        if bound and len(out) > bound:
            raise _fail(owner, field, f'a list of at most {bound} {what}', v)
        return out

    def default() -> list:
        return [item_default() for _ in range(length or 0)]
    return conv_list, default


#: The field rosbags gives a message without fields (one uint8 on the wire, as rosidl sends it).
_EMPTY_PLACEHOLDER = 'structure_needs_at_least_one_member'
#: IDL names of the .msg basic types that differ (``char`` is IDL's ``uint8``), as rclpy's classes give them.
_IDL_BASE = {'float32': 'float', 'float64': 'double', 'bool': 'boolean', 'byte': 'octet', 'char': 'uint8'}


def _idl_array(item: str, length: int | None, bound: int) -> str:
    """rclpy's type string of an array (``float[144]``) or sequence (``sequence<double>``, ``sequence<int32, 5>``)."""
    if length is not None:
        return f'{item}[{length}]'
    return f'sequence<{item}, {bound}>' if bound else f'sequence<{item}>'


def _msg_type_str(desc: tuple) -> str:
    """A field's type as its ``.msg`` definition writes it (``float32[144]``, ``SensorState[]``, ``string<=8``)."""
    kind, detail = desc
    if kind == Nodetype.BASE:
        base, bound = detail
        return f'{base}<={bound}' if bound else base
    if kind == Nodetype.NAME:
        return detail.replace('/msg/', '/')
    sub, size = detail
    if kind == Nodetype.ARRAY:
        return f'{_msg_type_str(sub)}[{size}]'
    return f'{_msg_type_str(sub)}[<={size}]' if size else f'{_msg_type_str(sub)}[]'


def msg_field_types(cls: type[Message]) -> dict[str, str]:
    """Field name -> type as the ``.msg`` file writes it (``get_fields_and_field_types()`` gives IDL names)."""
    return dict(cls._msg_field_types)


def _field_converter(owner: str, field: str, desc: tuple) -> tuple[Callable, Callable, str]:
    """(converter, default factory, IDL type string as rclpy's ``get_fields_and_field_types`` gives it) for one
    field descriptor."""
    kind, detail = desc
    if kind == Nodetype.BASE:
        base, bound = detail
        conv, value = _scalar_converter(owner, field, base, bound)
        type_str = f'{base}<{bound}>' if bound else _IDL_BASE.get(base, base)
        return conv, (lambda: value), type_str
    if kind == Nodetype.NAME:
        cls = get_message(detail)

        def conv_nested(v: Any) -> Message:
            if type(v) is not cls:
                raise _fail(owner, field, f'a {detail} message', v)
            return v
        return conv_nested, cls, detail.replace('/msg/', '/')
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        (sub_kind, sub_detail), size = detail
        length = size if kind == Nodetype.ARRAY else None
        bound = size if kind == Nodetype.SEQUENCE else 0
        base = sub_detail[0] if sub_kind == Nodetype.BASE else None
        if base is None or base == 'string':  # strings and messages: lists of them
            item_conv, item_default, item_type = _field_converter(owner, field, (sub_kind, sub_detail))
            what = 'str' if sub_kind == Nodetype.BASE else f'{sub_detail} messages'
            conv, default = _list_converter(owner, field, item_conv, item_default, length, bound, what)
            return conv, default, _idl_array(item_type, length, bound)
        if base == 'bool':
            conv, default = _bool_list_converter(owner, field, length, bound)
        elif base == 'byte':
            conv, default = _octets_converter(owner, field, length, bound)
        elif length is None and base in _TYPECODES:
            conv, default = _sequence_converter(owner, field, base, bound)
        else:
            conv, default = _numeric_array_converter(owner, field, base, length, bound)
        return conv, default, _idl_array(_IDL_BASE.get(base, base), length, bound)
    raise MessageError(f"field '{field}' of {owner}: unsupported descriptor {desc!r}")


def _make_class(typename: str) -> type[Message]:
    consts, fields = typestore.fielddefs[typename]
    names = tuple(name for name, _ in fields)
    convs, defaults, type_strs = {}, {}, {}
    for name, desc in fields:
        convs[name], defaults[name], type_strs[name] = _field_converter(typename, name, desc)

    # A generated __init__ (as dataclasses do) keeps construction cheap on the hot path. Each field
    # is a slot '_f_<name>' behind a property whose setter converts, as rclpy's generated classes do;
    # the codecs read and write the slots directly.
    params = ', '.join(f'{n}=None' for n in names)
    body = '\n'.join(
        f'    self._f_{n} = _d_{n}() if {n} is None else _c_{n}({n})' for n in names) or '    pass'
    src = f'def __init__(self, {params}{", " if params else ""}**_unknown):\n' \
          f'    if _unknown:\n        _reject(_unknown)\n{body}\n'
    env: dict[str, Any] = {f'_c_{n}': convs[n] for n in names}
    env.update({f'_d_{n}': defaults[n] for n in names})

    def _reject(unknown: dict) -> None:
        bad = next(iter(unknown))
        raise MessageError(f"{typename} has no field '{bad}'{did_you_mean(bad, names)}; "
                           f'its fields are: {", ".join(names)}')
    env['_reject'] = _reject
    exec(src, env)  # source built from parsed field names only

    pkg, kind, short = typename.split('/')
    attrs: dict[str, Any] = {
        '__slots__': tuple(f'_f_{n}' for n in names), '__msgtype__': typename, '_fields': names,
        # rosbags' placeholder field of an empty message (e.g. a message of constants only) is on the wire, but
        # rclpy's classes do not list it.
        '_field_types': {n: t for n, t in type_strs.items() if n != _EMPTY_PLACEHOLDER},
        '_msg_field_types': {name: _msg_type_str(desc) for name, desc in fields},
        '__init__': env['__init__'], '__module__': f'{pkg}.{kind}', '__qualname__': short,
    }
    for cname, ctype, cvalue in consts:
        attrs[cname] = OCTETS[cvalue % 256] if ctype == 'byte' else cvalue  # rclpy: b'\x01' (rosbags: 1)
    cls = type(short, (Message,), attrs)
    for n in names:
        slot = cls.__dict__[f'_f_{n}']
        setattr(cls, n, property(operator.attrgetter(f'_f_{n}'), _setter(slot.__set__, convs[n]),
                                 doc=f'{type_strs[n]} field'))
    return cls


def _setter(set_slot: Callable[[Any, Any], None], conv: Callable[[Any], Any]) -> Callable[[Any, Any], None]:
    def fset(self: Any, value: Any) -> None:
        set_slot(self, conv(value))
    return fset


def _byte_kind(desc: tuple) -> str | None:
    """'scalar' for a ``byte`` field, 'list' for ``byte[N]``/``byte[]``, else None."""
    kind, detail = desc
    if kind == Nodetype.BASE:
        return 'scalar' if detail[0] == 'byte' else None
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0] == (Nodetype.BASE, ('byte', 0)):
        return 'list'
    return None


def _from_rosbags(kind: str | None, v: Any) -> Any:
    """A value rosbags decoded as rclpy has it: bools as lists, ``byte`` ints and arrays as bytes."""
    if kind == 'scalar' and isinstance(v, (int, np.integer)):
        return OCTETS[int(v) % 256]
    if kind == 'list' and isinstance(v, np.ndarray):
        return [OCTETS[n] for n in v.astype(np.uint8).tobytes()]
    return v.tolist() if isinstance(v, np.ndarray) and v.dtype == np.bool_ else v


def _rosbags_builder(cls: type[Message]) -> Callable[..., Message]:
    """What rosbags calls with a decoded message's values: numpy bool arrays become lists and ``byte`` ints
    and arrays bytes, as ours decode."""
    kinds = {name: _byte_kind(desc) for name, desc in typestore.fielddefs[cls.__msgtype__][1]}
    order = list(kinds.values())

    def build(*values: Any, **fields: Any) -> Message:
        return cls(*(_from_rosbags(k, v) for k, v in zip(order, values, strict=False)),
                   **{n: _from_rosbags(kinds.get(n), v) for n, v in fields.items()})
    return build


def get_message(typename: str) -> type[Message]:
    """The class of message type ``typename`` (``pkg/msg/T``, ``pkg/T`` or a bare type of this package).

    Raises:
        MessageError: when the type is unknown.
    """
    with _lock:
        cls = _classes.get(typename)
        if cls is not None:
            return cls
        full = normalize_type_name(typename)
        cls = _classes.get(full)
        if cls is None:
            if full in typestore.cache:
                raise MessageError(f'{full} was serialised before its class was made')  # pragma: no cover
            cls = _make_class(full)
            # rosbags builds deserialised messages as cls(*values): give it our class's builder.
            typestore.types[full] = _rosbags_builder(cls)
            _classes[full] = cls
        _classes[typename] = cls
        return cls


def _make_codec(full: str) -> Codec | None:
    """The generated codec of a type, else None (rosbags serves the type)."""
    try:
        return make_codec(full, typestore.fielddefs, get_message, partial(_rosbags_decode, full))
    except UnsupportedType:
        return None


def _codec(typename: str) -> Codec | None:
    """The codec of a type (None: a type the generator does not handle; rosbags serves it)."""
    codec = _codecs.get(typename)
    if codec is not None:
        return codec
    with _lock:
        if typename in _codecs:
            return _codecs[typename]
        full = get_message(typename).__msgtype__
        if full not in _codecs:
            _codecs[full] = _make_codec(full)
        _codecs[typename] = _codecs[full]
        return _codecs[full]


def encoder(typename: str) -> Callable[..., bytes]:
    """The fastest ``encode(message, pad=False) -> bytes`` of a type (see :func:`serialize`), for hot paths."""
    codec = _codec(typename)
    return codec.encode if codec is not None else partial(_rosbags_encode, get_message(typename).__msgtype__)


def decoder(typename: str) -> Callable[[bytes], Message]:
    """The fastest ``decode(data: bytes) -> message`` of a type (see :func:`deserialize`; ``bytes`` only)."""
    codec = _codec(typename)
    return codec.decode if codec is not None else partial(_rosbags_decode, get_message(typename).__msgtype__)


def serialize(message: Message, typename: str | None = None, *, pad: bool = False) -> bytes:
    """CDR bytes (little endian, with the 4-byte encapsulation header) of ``message``.

    Args:
        typename: the type to encode as (default: the message's own).
        pad: add zero bytes up to a multiple of 4, as rmw_cyclonedds sends a payload.

    Raises:
        MessageError: a field holds a value of the wrong type or size.
    """
    typename = typename or getattr(message, '__msgtype__', None)
    if typename is None:
        raise MessageError(f'cannot serialise {type(message).__name__}: not a message')
    return encoder(typename)(message, pad)


def deserialize(data: bytes | bytearray | memoryview, typename: str) -> Message:
    """The message of type ``typename`` in CDR bytes ``data`` (either byte order).

    Numeric arrays of the message are read-only views of the bytes.

    Raises:
        MessageError: on truncated or malformed bytes.
    """
    return decoder(typename)(data if type(data) is bytes else bytes(data))


def for_rosbags(message: Message) -> Message:
    """A copy of ``message`` with its sequences and bool lists as the numpy arrays rosbags' serialiser
    takes, and ``byte`` values as its ints (fields' slots written directly, past the converting properties)."""
    out = object.__new__(type(message))
    for name, desc in typestore.fielddefs[message.__msgtype__][1]:
        value = getattr(message, name)
        kind, detail = desc
        byte_kind = _byte_kind(desc)
        if byte_kind == 'scalar':
            value = value[0] - 256 * (value[0] > 127)  # rosbags packs a byte signed: the same octet on the wire
        elif byte_kind == 'list':
            value = np.frombuffer(b''.join(value), dtype=np.uint8)
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (sub_kind, sub_detail), _size = detail
            if sub_kind == Nodetype.NAME:
                value = [for_rosbags(v) for v in value]
            elif sub_detail[0] == 'bool':
                value = np.array(value, dtype=np.bool_)
            elif isinstance(value, array.array):
                value = np.frombuffer(value, dtype=_DTYPES[sub_detail[0]]) if len(value) else \
                    np.zeros(0, _DTYPES[sub_detail[0]])
        elif kind == Nodetype.NAME:
            value = for_rosbags(value)
        object.__setattr__(out, f'_f_{name}', value)
    return out


def _rosbags_encode(full: str, message: Message, pad: bool = False) -> bytes:
    try:
        data = bytes(typestore.serialize_cdr(for_rosbags(message), full, little_endian=True))
    except (AttributeError, TypeError, ValueError, SerdeError, OverflowError, struct.error) as err:
        raise MessageError(f'cannot serialise {full}: {err}') from err
    return data + b'\0' * (-len(data) % 4) if pad else data


def _rosbags_decode(full: str, data: bytes) -> Message:
    try:  # big endian, or a type without a generated codec
        message = typestore.deserialize_cdr(data, full)
    except (SerdeError, IndexError, ValueError, TypeError) as err:
        raise MessageError(f'cannot deserialise {len(data)} bytes as {full}: {err}') from err
    return _read_only(message)


def _read_only(value: Any) -> Any:
    """``value`` with its numeric arrays, and those of the messages in it, made read-only, as the codecs
    decode them (rosbags gives writeable copies where it swaps bytes, and for empty arrays)."""
    if isinstance(value, np.ndarray):
        value.flags.writeable = False
    elif isinstance(value, Message):
        for name in value._fields:
            _read_only(getattr(value, name))
    elif isinstance(value, list):
        for item in value:
            _read_only(item)
    return value


def to_dict(message: Message) -> dict[str, Any]:
    """Plain Python (dict, list, int, float, str, bool) form of a message, for echo and YAML; a ``byte``
    (``bytes`` of length 1 in the message) is its int, 0-255, which :func:`from_dict` takes back."""
    out = {}
    for name in message._fields:
        out[name] = _plain(getattr(message, name))
    return out


def _plain(value: Any) -> Any:
    if isinstance(value, Message):
        return to_dict(value)
    if isinstance(value, (np.ndarray, array.array)):
        return value.tolist()
    if isinstance(value, list):
        return [_plain(v) for v in value]
    if type(value) is bytes:  # a byte field's value (strings are str)
        return value[0]
    return value


def from_dict(typename: str, data: dict[str, Any], *, strict: bool = False) -> Message:
    """Build a message from its :func:`to_dict` form.

    Args:
        strict: when true, a missing field is an error (a field left out of a YAML message
            is more often a typo than a wish for the default).

    Raises:
        MessageError: naming the first unknown, missing or mistyped field with its path.
    """
    cls = get_message(typename)
    if not isinstance(data, dict):
        raise MessageError(f'{cls.__msgtype__} must be given as a mapping of fields; got {data!r}')
    kwargs = {}
    fields = typestore.fielddefs[cls.__msgtype__][1]
    for name, desc in fields:
        if name not in data:
            if strict:
                raise MessageError(f"{cls.__msgtype__}: missing field '{name}'")
            continue
        kwargs[name] = _from_plain(desc, data[name], strict, f'{cls.__msgtype__}.{name}')
    unknown = set(data) - {n for n, _ in fields}
    if unknown:
        bad = sorted(unknown)[0]
        raise MessageError(f"{cls.__msgtype__} has no field '{bad}'{did_you_mean(bad, cls._fields)}; "
                           f'its fields are: {", ".join(cls._fields)}')
    return cls(**kwargs)


def _from_plain(desc: tuple, value: Any, strict: bool, where: str) -> Any:
    kind, detail = desc
    if kind == Nodetype.NAME:
        if not isinstance(value, dict):
            raise MessageError(f'{where} must be a mapping of fields; got {value!r}')
        return from_dict(detail, value, strict=strict)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0][0] == Nodetype.NAME:
        if not isinstance(value, list):
            raise MessageError(f'{where} must be a list; got {value!r}')
        return [from_dict(detail[0][1], v, strict=strict) for v in value]
    byte_kind = _byte_kind(desc)
    if byte_kind == 'scalar':
        return _octet(value, where)
    if byte_kind == 'list' and isinstance(value, list):
        return [_octet(v, where) for v in value]
    return value


def _octet(value: Any, where: str) -> Any:
    """A ``byte`` given as an int 0-255 (as :func:`to_dict` writes it) -> ``bytes`` of length 1; else as given,
    for the field's converter to take or refuse."""
    if isinstance(value, int) and not isinstance(value, bool):
        if not 0 <= value <= 255:
            raise FieldError(f'{where} is a byte: expects an int in [0, 255] or bytes of length 1; got {value}')
        return OCTETS[value]
    return value


def message_definition(typename: str) -> str:
    """The ``.msg`` text of a type, nested types indented below it, as ``ros2 interface show`` prints."""
    full = get_message(typename).__msgtype__
    return _definition_text(full, indent='')


def _definition_text(full: str, indent: str) -> str:
    pkg, _, short = full.split('/')
    if pkg == INTERFACE_PACKAGE:
        text = share_file('msg', f'{short}.msg').read_text(encoding='utf-8')
    else:
        text = typestore.generate_msgdef(full, ros_version=2)[0].split('\n' + '=' * 80)[0]
    lines = []
    nested = {name: desc for name, desc in typestore.fielddefs[full][1]}
    for line in text.splitlines():
        lines.append(indent + line)
        stripped = line.split('#')[0].split()
        if len(stripped) >= 2 and stripped[1] in nested:
            sub = _nested_type(nested[stripped[1]])
            if sub:
                lines.append(_definition_text(sub, indent + '\t').rstrip('\n'))
    return '\n'.join(lines) + '\n'


def _nested_type(desc: tuple) -> str | None:
    kind, detail = desc
    if kind == Nodetype.NAME:
        return detail
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE) and detail[0][0] == Nodetype.NAME:
        return detail[0][1]
    return None


def _register_all() -> None:
    for name in interface_names():
        get_message(name)


_register_all()
