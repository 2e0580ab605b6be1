"""Random messages of every type the type store knows, for the CDR codec tests.

Test-only types with the layouts no real type has yet are registered here (fixed arrays of
strings and of messages, bounds, odd alignments); ``message_of`` draws messages of any type
with random field values: empty, long and unicode strings, NaN and infinities, empty and long
arrays, nested messages and sequences of them.
"""

import numpy as np
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from rosbags.interfaces import Nodetype
from rosbags.typesys import get_types_from_msg

from touch_graph import messages
from touch_graph.messages import get_message, typestore

# Layouts no type of ours has yet: fixed arrays of strings and of messages, bounds, a message
# that starts with a byte and needs 8-byte alignment later, empty float64 sequences mid-message.
TEST_TYPES = {
    'codec_test_msgs/msg/Inner': 'uint8 a\nint64 b\nstring s\n',
    'codec_test_msgs/msg/Wide': 'float64 x\nuint8 tail\n',
    'codec_test_msgs/msg/Layouts': (
        'byte b\nchar c\nint8 i8\nint16 i16\nstring[3] names\nInner[2] pair\nstring<=5 short\n'
        'float64[<=3] few\nInner[] many\nWide[] wides\nfloat64[] empty_or_not\nuint16 after\n'
        'bool[] flags\nbyte[] blob\nchar[4] code\nWide w\nint64[2] big\nuint8 last\n'),
    'codec_test_msgs/msg/Align': 'uint8 a\nfloat64[] d\nfloat64 x\nuint16[] h\nint64 y\nbool[] z\nfloat64 w\nInner i\n',
    'codec_test_msgs/msg/Strings': 'string<=3[<=2] tiny\nstring[] words\nuint32[] counts\nfloat32 f\n',
    # every byte-field shape (bytes of length 1 and lists of them, as rclpy has them) and char ones (ints)
    'codec_test_msgs/msg/Octets': 'byte one\nbyte[3] fixed\nbyte[] blob\nbyte[<=2] few\nchar c\nchar[] chars\n'
                                  'char[2] pair\nbyte[0] none\nuint16 after\n',
}
for _name, _text in TEST_TYPES.items():
    typestore.register(get_types_from_msg(_text, _name))

_INT = {'int8': (-2**7, 2**7 - 1), 'uint8': (0, 255), 'char': (0, 255), 'int16': (-2**15, 2**15 - 1),
        'uint16': (0, 2**16 - 1), 'int32': (-2**31, 2**31 - 1), 'uint32': (0, 2**32 - 1),
        'int64': (-2**63, 2**63 - 1), 'uint64': (0, 2**64 - 1)}
_OCTET = st.binary(min_size=1, max_size=1)  # a byte: bytes of length 1, as rclpy has it
_DTYPE = {'bool': np.bool_, 'byte': np.uint8, 'char': np.uint8, 'float32': np.float32, 'float64': np.float64}
_LENGTHS = st.one_of(st.integers(0, 3), st.integers(0, 300))
_TEXT = st.one_of(st.text(max_size=8), st.text(max_size=300), st.just(''), st.sampled_from(['ü', '触覚', '😀x']))


def _scalar(base: str, bound: int = 0) -> st.SearchStrategy:
    if base == 'string':
        return st.text(max_size=bound) if bound else _TEXT
    if base == 'bool':
        return st.booleans()
    if base == 'byte':
        return _OCTET
    if base in ('float32', 'float64'):
        return st.floats(width=32 if base == 'float32' else 64)  # NaN and infinities included
    lo, hi = _INT[base]
    return st.integers(lo, hi)


def _array(base: str, length: st.SearchStrategy) -> st.SearchStrategy:
    if base == 'byte':  # byte[N], byte[]: a list of bytes of length 1, as rclpy has it
        return length.flatmap(lambda n: st.lists(_OCTET, min_size=n, max_size=n))
    dtype = np.dtype(_DTYPE.get(base, base))
    if base in ('float32', 'float64'):
        elements = st.floats(width=dtype.itemsize * 8)
    elif base == 'bool':
        elements = st.booleans()
    else:
        lo, hi = _INT[base]
        elements = st.integers(lo, hi)
    arrays = hnp.arrays(dtype, length, elements=elements)
    return arrays.map(lambda a: a.tolist()) if base == 'bool' else arrays  # bool[]: a list, as rclpy takes it


def _field(desc: tuple, depth: int) -> st.SearchStrategy:
    kind, detail = desc
    if kind == Nodetype.BASE:
        return _scalar(*detail)
    if kind == Nodetype.NAME:
        return message_of(detail, depth + 1)
    (sub_kind, sub_detail), size = detail
    fixed = kind == Nodetype.ARRAY
    if sub_kind == Nodetype.BASE and sub_detail[0] != 'string':
        length = st.just(size) if fixed else (st.integers(0, size) if size else _LENGTHS)
        return _array(sub_detail[0], length)
    item = _field((sub_kind, sub_detail), depth)
    if fixed:
        return st.lists(item, min_size=size, max_size=size)
    return st.lists(item, max_size=min(size, 4) if size else (4 if depth < 2 else 1))


def message_of(typename: str, depth: int = 0) -> st.SearchStrategy:
    """Messages of ``typename`` with random values in every field."""
    cls = get_message(typename)
    fields = typestore.fielddefs[cls.__msgtype__][1]
    return st.fixed_dictionaries({name: _field(desc, depth) for name, desc in fields}).map(lambda kw: cls(**kw))



#: This package's types and the test-only ones; every message and service type the store knows.
OURS = sorted(set(messages.interface_names()) | set(TEST_TYPES))
EVERY = sorted(name for name in typestore.fielddefs if '/msg/' in name or '/srv/' in name)


def damaged(data: st.DataObject, good: bytes) -> list[bytes]:
    """Damaged forms of a valid payload ``good``: a few bytes flipped, garbage after it, and random bytes."""
    flipped = bytearray(good)
    for _ in range(data.draw(st.integers(1, 4))):
        flipped[data.draw(st.integers(0, len(good) - 1))] = data.draw(st.integers(0, 255))
    return [bytes(flipped), good + data.draw(st.binary(min_size=1, max_size=12)), data.draw(st.binary(max_size=64))]
