"""CDR encoders and decoders generated per message type, byte-identical to rosbags (and to ROS 2).

rosbags' generic (de)serialiser is slow on messages of ours: one struct call per
scalar, a size pass before the write pass, a copy of the payload before decoding, and the
message built through the class's checking ``__init__``. Here each type gets two
functions, generated once from its field definitions (Python source compiled with
``exec``, as rosbags and dataclasses do):

- fields whose offsets are known at generation time are packed or unpacked by one
  ``struct.Struct`` per run, padding included (``x`` bytes);
- arrays of primitives are joined into the output as they are (their buffer, no
  ``tobytes`` copy first); fixed-size numeric arrays are decoded as read-only numpy views
  of the received bytes, and the fixed-size arrays of one run become views of one
  structured record (one ``numpy.ndarray`` call and a field lookup each, about half the
  cost of one ``numpy.frombuffer`` each);
- the decoded field types are rclpy's: a numeric sequence is an ``array.array`` (a copy of
  its bytes), ``bool[N]`` and ``bool[]`` are lists of Python bools, a ``byte`` is ``bytes`` of
  length 1 and ``byte[N]``/``byte[]`` lists of them;
- a runtime alignment step is emitted only after a field of variable size (a string, a
  sequence), where the offset is no longer known;
- nested messages are inlined; decoded messages are made without ``__init__`` and their
  fields' slots written directly (what the bytes give has the field's type by
  construction), bounded strings and sequences checked.

Encoding is XCDR1 little endian with the 4-byte encapsulation header; every primitive is
aligned to its size relative to the end of that header, and the elements of an empty
primitive sequence are not aligned (as rosbags and Fast-CDR). Decoding takes little
endian; :mod:`touch_graph.messages` hands big-endian payloads to rosbags (whose ``byte`` ints
the message classes turn into bytes).

Errors: an encoder raises :class:`~touch_graph.errors.MessageError` for a field value
of the wrong type or size, a decoder for bytes that do not decode (truncated, bad length,
bad UTF-8, a bound exceeded, trailing garbage); never another exception.
"""

from __future__ import annotations

import array
import struct
from collections.abc import Callable
from typing import Any

import numpy as np
from rosbags.interfaces import Nodetype

from .errors import MessageError

__all__ = ['OCTETS', 'Codec', 'UnsupportedType', 'make_codec']

#: Encapsulation header of little-endian plain CDR (XCDR1), options zero.
HEADER_LE = b'\x00\x01\x00\x00'

_FORMATS = {'bool': '?', 'byte': 'c', 'char': 'B', 'int8': 'b', 'uint8': 'B', 'int16': 'h', 'uint16': 'H',
            'int32': 'i', 'uint32': 'I', 'int64': 'q', 'uint64': 'Q', 'float32': 'f', 'float64': 'd'}
_SIZES = {name: struct.calcsize(fmt) for name, fmt in _FORMATS.items()}
_DTYPES = {'bool': np.dtype(np.bool_), 'byte': np.dtype(np.uint8), 'char': np.dtype(np.uint8),
           **{name: np.dtype(name) for name in _FORMATS if name not in ('bool', 'byte', 'char')}}
#: ``array.array`` typecodes of numeric sequences (rclpy's field type for them).
#: Every ``byte`` value as rclpy holds it: ``bytes`` of length 1 (``OCTETS[n]`` is ``bytes([n])``, shared).
OCTETS = tuple(bytes([n]) for n in range(256))
_TYPECODES = {'int8': 'b', 'uint8': 'B', 'char': 'B', 'int16': 'h', 'uint16': 'H', 'int32': 'i', 'uint32': 'I',
              'int64': 'q', 'uint64': 'Q', 'float32': 'f', 'float64': 'd'}
_ZEROS = tuple(bytes(n) for n in range(16))
_COUNT = struct.Struct('<I').pack
#: Minimum bytes of one element of a sequence (guards a huge count in garbage), as rosbags checks it.
_MIN_STRING_BYTES = 5
_ENCODE_ERRORS = (AttributeError, TypeError, ValueError, OverflowError, struct.error, BufferError)
_DECODE_ERRORS = (struct.error, ValueError, IndexError, TypeError, OverflowError)


class UnsupportedType(Exception):
    """A field type the generator does not handle (the caller falls back to rosbags)."""


class Codec:
    """The generated ``encode`` and ``decode`` of one message type.

    Attributes:
        typename: ``pkg/msg/Name``.
        encode: ``encode(message, pad=False) -> bytes``: header and fields; ``pad`` adds zero
            bytes up to a multiple of 4, as rmw_cyclonedds sends a payload.
        decode: ``decode(data) -> message`` for CDR ``bytes`` (not another bytes-like type);
            what is not little endian goes to the ``other`` decoder given to :func:`make_codec`.
        source: the generated Python source (for reading and debugging).
    """

    def __init__(self, typename: str, encode: Callable[..., bytes], decode: Callable[[bytes], Any],
                 source: str) -> None:
        self.typename = typename
        self.encode = encode
        self.decode = decode
        self.source = source


def _low_alignment(offset: int, known: int) -> int:
    """Alignment still known after moving ``offset`` bytes from a position aligned to ``known``."""
    while known > 1 and offset % known:
        known //= 2
    return known


class _Generator:
    """Emits the source of one encoder or one decoder, tracking what is known about the offset.

    ``p`` is the runtime position (payload-relative when encoding, absolute in the buffer
    when decoding); ``off`` is a static offset from it, and ``p``'s payload position is a
    multiple of ``known``. Padding is static while ``known`` covers it, else emitted.
    """

    def __init__(self, fielddefs: dict, get_class: Callable[[str], type]) -> None:
        self.fielddefs = fielddefs
        self.get_class = get_class
        self.lines: list[str] = []
        self.env: dict[str, Any] = {'_ZEROS': _ZEROS, '_frombuffer': np.frombuffer, '_ndarray': np.ndarray,
                                    '_new': object.__new__, '_coerce': _coerce, '_bad': _bad,
                                    '_array': array.array, '_bools': _bools, '_to_sequence': _to_sequence,
                                    '_sequence': _sequence, '_octets': _octets, '_octet_list': _octet_list}
        self.indent = 1
        self.off = 0
        self.known = 8
        self.run_fmt: list[str] = []
        self.run_items: list[str] = []
        self._names = 0

    # ------------------------------------------------------------------ helpers
    def name(self, prefix: str) -> str:
        self._names += 1
        return f'{prefix}{self._names}'

    def const(self, prefix: str, value: Any) -> str:
        name = self.name(f'_{prefix}')
        self.env[name] = value
        return name

    def emit(self, line: str) -> None:
        self.lines.append('    ' * self.indent + line)

    def sync(self) -> None:
        """Make ``p`` the current position (after flushing the pending run)."""
        self.flush()
        if self.off:
            self.emit(f'p += {self.off}')
            self.known = _low_alignment(self.off, self.known)
            self.off = 0

    def pad(self, align: int) -> None:
        """Align to ``align``: padding bytes in the pending run when the offset is known, else at run time."""
        pad = -self.off % align if align <= self.known else -1
        if pad >= 0:
            self.run_fmt += ['x'] * pad
            self.off += pad
            return
        self.runtime_pad(align)
        self.known = align

    def scalar(self, base: str, ref: str) -> None:
        """A primitive: one more value in the pending struct run."""
        size = _SIZES[base]
        self.pad(size)
        self.run_fmt.append(_FORMATS[base])
        self.run_items.append(ref)
        self.off += size

    def align_elements(self, count: str, size: int) -> None:
        """Align to ``size`` at run time when the sequence of ``count`` elements is not empty (``p`` is current)."""
        if size > self.known:
            self.emit(f'if {count}:')
            self.indent += 1
            self.step_to(size)
            self.indent -= 1

    def field(self, desc: tuple, ref: str, field: str) -> None:
        """Emit one field; ``ref`` is the expression (encoding) or assignment target (decoding) of its value."""
        kind, detail = desc
        if kind == Nodetype.BASE:
            base, bound = detail
            if base == 'string':
                self.string(ref, bound, field)
            elif base in _FORMATS:
                self.scalar(base, ref)
            else:
                raise UnsupportedType(base)
        elif kind == Nodetype.NAME:  # inlined; its first primitive aligns itself
            self.nested(detail, ref)
        elif kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            (sub_kind, sub_detail), size = detail
            length = size if kind == Nodetype.ARRAY else None
            bound = size if kind == Nodetype.SEQUENCE else 0
            if sub_kind == Nodetype.BASE and sub_detail[0] in _FORMATS:
                self.array(sub_detail[0], ref, length, bound, field)
            elif sub_kind == Nodetype.NAME or (sub_kind == Nodetype.BASE and sub_detail[0] == 'string'):
                self.items((sub_kind, sub_detail), ref, length, bound, field)
            else:
                raise UnsupportedType(str(sub_detail))
        else:
            raise UnsupportedType(str(desc))

    # Each generator's own: the pending run, the steps that move p, and each kind of field.
    def flush(self) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def runtime_pad(self, align: int) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def step_to(self, align: int) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def string(self, ref: str, bound: int, field: str) -> None:  # pragma: no cover - overridden
        raise NotImplementedError

    def array(self, base: str, ref: str, length: int | None, bound: int, field: str) -> None:  # pragma: no cover
        raise NotImplementedError

    def items(self, desc: tuple, ref: str, length: int | None, bound: int, field: str) -> None:  # pragma: no cover
        raise NotImplementedError

    def nested(self, typename: str, ref: str) -> None:  # pragma: no cover - overridden
        raise NotImplementedError


class _Encoder(_Generator):
    """Generates ``encode(m, pad=False)``: parts joined once, struct runs packed once each."""

    def flush(self) -> None:
        if not self.run_fmt:
            return
        if any(f != 'x' for f in self.run_fmt):
            packer = self.const('S', struct.Struct('<' + ''.join(self.run_fmt)).pack)
            self.emit(f'_a({packer}({", ".join(self.run_items)}))')
        else:
            self.emit(f'_a({self.const("Z", bytes(len(self.run_fmt)))})')
        self.run_fmt, self.run_items = [], []

    def runtime_pad(self, align: int) -> None:
        pending = len(self.run_fmt)
        if 0 < pending <= 8 and all(f == 'x' for f in self.run_fmt):  # zero bytes waiting: one part with the padding
            k = self.name('k')
            self.emit(f'{k} = -(p + {self.off}) % {align}')
            self.emit(f'_a(_ZEROS[{pending} + {k}])')
            self.emit(f'p += {self.off} + {k}')
            self.run_fmt, self.run_items, self.off = [], [], 0
        else:
            self.sync()
            self.step_to(align)

    def step_to(self, align: int) -> None:
        """Zero bytes up to the next multiple of ``align`` (``p`` is current)."""
        k = self.name('k')
        self.emit(f'{k} = -p % {align}')
        self.emit(f'if {k}:')
        self.emit(f'    _a(_ZEROS[{k}])')
        self.emit(f'    p += {k}')

    def string(self, expr: str, bound: int, field: str) -> None:
        encoded = self.name('s')
        self.emit(f'{encoded} = {expr}.encode()')
        self.scalar('uint32', f'len({encoded}) + 1')
        self.flush()
        self.emit(f'_a({encoded})')
        # The terminating zero byte starts the next run, as if it were padding.
        self.emit(f'p += {self.off} + len({encoded})')
        self.off, self.known = 1, 1
        self.run_fmt.append('x')

    def array(self, base: str, expr: str, length: int | None, bound: int, field: str) -> None:
        dtype, size = _DTYPES[base], _SIZES[base]
        dt = self.const('DT', dtype)
        arr = self.name('a')
        self.emit(f'{arr} = {expr}')
        if base in ('bool', 'byte'):  # a list of bools or of bytes: one octet each
            self.emit(f'{arr} = {"_bools" if base == "bool" else "_octets"}({arr}, {length}, {field!r})')
            if length is not None:
                self.flush()
                self.emit(f'_a({arr})')
                self.off += length
                return
            self.scalar('uint32', f'len({arr})')
            self.sync()
            self.emit(f'_a({arr})')
            self.emit(f'p += len({arr})')
            self.known = 1
            return
        if length is not None:
            self.emit(f'if {arr}.dtype is not {dt} or {arr}.shape != ({length},):')
            self.emit(f'    {arr} = _coerce({arr}, {dt}, {length}, {field!r})')
            self.pad(size)
            self.flush()
            self.emit(f'_a({arr})')
            self.off += length * size
            return
        if base in _TYPECODES:  # an array.array (rclpy's type), or a numpy array of the same values
            typecode = _TYPECODES[base]
            self.emit(f'if type({arr}) is not _array or {arr}.typecode != {typecode!r}:')
            self.emit(f'    {arr} = _to_sequence({arr}, {typecode!r}, {dt}, {field!r})')
        else:
            self.emit(f'if {arr}.dtype is not {dt} or {arr}.ndim != 1:')
            self.emit(f'    {arr} = _coerce({arr}, {dt}, None, {field!r})')
        self.scalar('uint32', f'len({arr})')
        self.sync()
        self.align_elements(f'len({arr})', size)
        self.emit(f'_a({arr})')
        self.emit(f'p += len({arr}) * {size}')
        self.known = min(4, size)

    def items(self, desc: tuple, expr: str, length: int | None, bound: int, field: str) -> None:
        """A fixed array (``length``) or a sequence (None) of strings or messages."""
        seq = self.name('q')
        self.emit(f'{seq} = {expr}')
        if length is None:
            self.scalar('uint32', f'len({seq})')
        else:
            self.emit(f'if len({seq}) != {length}:')
            self.emit(f'    raise ValueError("field {field} needs {length} items, got %d" % len({seq}))')
        self.sync()
        if length is None and desc[0] == Nodetype.BASE:  # a sequence of strings: p is 4-aligned after its count
            run = self.name('c')
            self.emit(f'{run} = _string_run({seq}, {self.const("M", [([], b"")])})')
            self.emit(f'_a({run})')
            self.emit(f'p += len({run})')
            self.known = 1
            return
        item = self.name('i')
        self.emit(f'for {item} in {seq}:')
        self.indent += 1
        self.known = 1  # each element aligns itself at run time
        self.field(desc, item, field)
        self.sync()
        self.indent -= 1
        self.known = min(self.known, 4)

    def nested(self, typename: str, expr: str) -> None:
        for name, desc in self.fielddefs[typename][1]:
            if desc[0] == Nodetype.NAME:  # bound once, its fields read from the local
                value = self.name('v')
                self.emit(f'{value} = {expr}._f_{name}')  # the field's slot, behind its property
                self.field(desc, value, name)
            else:
                self.field(desc, f'{expr}._f_{name}', name)

    def build(self, typename: str) -> str:
        self.indent = 2
        self.emit('parts = [_HEADER]')
        self.emit('_a = parts.append')
        self.emit('p = 0')
        self.nested(typename, 'm')
        self.sync()
        self.emit('if pad and p % 4:')
        self.emit('    _a(_ZEROS[-p % 4])')
        self.emit('try:')
        self.emit("    return b''.join(parts)")
        self.emit('except TypeError:  # an array that is not contiguous (a strided view) has no flat buffer')
        self.emit('    return _join_copies(parts)')
        self.env.update(_HEADER=HEADER_LE, _ERRORS=_ENCODE_ERRORS, _failed=_failure('serialise', typename),
                        _join_copies=_join_copies, _string_run=_string_run)
        return ('def encode(m, pad=False):\n    try:\n' + '\n'.join(self.lines) +
                '\n    except _ERRORS as err:\n        raise _failed(m, err) from err\n')


class _Decoder(_Generator):
    """Generates ``decode(data)``; ``p`` indexes ``data``, whose first 4 bytes are the header."""

    def __init__(self, fielddefs: dict, get_class: Callable[[str], type]) -> None:
        super().__init__(fielddefs, get_class)
        self.run_views: list[tuple[str, str, int, int]] = []  # fixed arrays of the run: target, base, length, off

    def flush(self) -> None:
        if not self.run_fmt:
            return
        fmt = ''.join(self.run_fmt)
        start = self.off - struct.calcsize('<' + fmt)
        if self.run_items:  # unpacked first: its struct also checks that the run's arrays are in the data
            unpack = self.const('U', struct.Struct('<' + fmt).unpack_from)
            where = f'p + {start}' if start else 'p'
            targets = ', '.join(self.run_items)
            self.emit(f'{targets}, = {unpack}(data, {where})' if len(self.run_items) == 1
                      else f'{targets} = {unpack}(data, {where})')
        self.flush_views()
        self.run_fmt, self.run_items = [], []

    def flush_views(self) -> None:
        """The fixed arrays of the run: one view each, or fields of one record view when there are several."""
        views, self.run_views = self.run_views, []
        if len(views) == 1:
            target, base, length, off = views[0]
            where = f'p + {off}' if off else 'p'
            self.emit(f'{target} = ' + _as_field(base, f'_frombuffer(data, {self.const("DT", _DTYPES[base])}, '
                                                       f'{length}, {where})'))
        elif views:
            first = views[0][3]
            record = np.dtype({'names': [f'f{i}' for i in range(len(views))],
                               'formats': [(_DTYPES[base], (length,)) for _, base, length, _ in views],
                               'offsets': [off - first for *_, off in views]})
            rec = self.name('r')
            self.emit(f'{rec} = _ndarray((), {self.const("RT", record)}, data, p + {first})')
            for i, (target, base, *_rest) in enumerate(views):
                self.emit(f'{target} = ' + _as_field(base, f"{rec}['f{i}']"))

    def runtime_pad(self, align: int) -> None:
        self.sync()
        self.step_to(align)

    def step_to(self, align: int) -> None:
        self.emit(f'p += (4 - p) % {align}')  # p - 4 is the payload position

    def count(self) -> str:
        """Read a uint32 count into a new local; return its name."""
        n = self.name('n')
        self.scalar('uint32', n)
        return n

    def string_at_p(self, target: str, bound: int, field: str, n: str) -> None:
        """Decode the characters of a string whose length ``n`` was read; ``p`` is at them."""
        end = self.name('e')
        self.emit(f'{end} = p + {n}')
        self.emit(f'if {n} < 1 or {end} > L or data[{end} - 1]:')
        self.emit(f'    raise _bad("string {field}: length %d at offset %d" % ({n}, p - 4))')
        self.emit(f'{target} = data[p:{end} - 1].decode()')
        if bound:
            self.emit(f'if len({target}) > {bound}:')
            self.emit(f'    raise _bad("string {field} is longer than its bound {bound}")')
        self.emit(f'p = {end}')
        self.known = 1

    def string(self, target: str, bound: int, field: str) -> None:
        n = self.count()
        self.sync()
        self.string_at_p(target, bound, field, n)

    def array(self, base: str, target: str, length: int | None, bound: int, field: str) -> None:
        dtype, size = _DTYPES[base], _SIZES[base]
        dt = self.const('DT', dtype)
        if length is not None:
            self.pad(size)
            if length:
                self.run_views.append((target, base, length, self.off))
            else:
                self.emit(f'{target} = []' if base in ('bool', 'byte') else f'{target} = _frombuffer(data, {dt}, 0)')
            self.run_fmt.append(f'{length * size}x')  # the pending run's unpack skips the array
            self.off += length * size
            return
        n = self.count()
        self.sync()
        if bound:
            self.emit(f'if {n} > {bound}:')
            self.emit(f'    raise _bad("sequence {field} holds %d values, more than its bound {bound}" % {n})')
        self.align_elements(n, size)
        if base in _TYPECODES:  # rclpy's type for a numeric sequence
            self.emit(f'{target} = _sequence({_TYPECODES[base]!r}, data, p, {n} * {size})')
        else:
            self.emit(f'{target} = ' + _as_field(base, f'_frombuffer(data, {dt}, {n}, p)'))
        self.emit(f'p += {n} * {size}')
        self.known = min(4, size)

    def items(self, desc: tuple, target: str, length: int | None, bound: int, field: str) -> None:
        sub_kind, sub_detail = desc
        is_string = sub_kind == Nodetype.BASE
        if length is None:
            n = self.count()
            self.sync()
            if bound:
                self.emit(f'if {n} > {bound}:')
                self.emit(f'    raise _bad("sequence {field} holds %d items, more than its bound {bound}" % {n})')
            least = _MIN_STRING_BYTES if is_string else 1
            self.emit(f'if {n} * {least} > L - p:')
            self.emit(f'    raise _bad("sequence {field}: %d items cannot fit in %d bytes" % ({n}, L - p))')
        else:
            n = str(length)
            self.sync()
        items = self.name('l')
        memo = is_string and length is None  # a sequence of strings: p is 4-aligned after its count
        if memo:
            # The last sequence decoded and its bytes: the same bytes decode to the same strings
            # (a node sends the same labels message after message).
            last, start = self.const('M', [(b'', ())]), self.name('s')
            self.emit(f'{start}, {items} = {last}[0]')
            self.emit(f'if len({items}) == {n} and data.startswith({start}, p):')
            self.emit(f'    {items} = list({items})')
            self.emit(f'    p += len({start})')
            self.emit('else:')
            self.indent += 1
            self.emit(f'{start} = p')
        self.emit(f'{items} = []')
        self.emit(f'for _ in range({n}):')
        self.indent += 1
        self.known = 1
        value = self.name('x')
        if is_string:
            self.string(value, sub_detail[1], field)
        else:
            self.message(sub_detail, value)
        self.sync()
        self.emit(f'{items}.append({value})')
        self.indent -= 1
        if memo:
            self.emit(f'{last}[0] = (data[{start}:p], tuple({items}))')
            self.indent -= 1
        self.emit(f'{target} = {items}')
        self.known = min(self.known, 4)

    def message(self, typename: str, target: str) -> None:
        """Make ``target`` a new message of ``typename`` and decode its fields into it."""
        cls = self.const('C', self.get_class(typename))
        self.emit(f'{target} = _new({cls})')
        for name, desc in self.fielddefs[typename][1]:
            self.field(desc, f'{target}._f_{name}', name)  # the field's slot, behind its property

    def nested(self, typename: str, target: str) -> None:
        value = self.name('o')
        self.message(typename, value)  # made before any pending run that fills it is unpacked
        self.emit(f'{target} = {value}')

    def build(self, typename: str, other: Callable[[bytes], Any]) -> str:
        self.indent = 2
        self.emit('L = len(data)')
        self.emit('p = 4')
        self.message(typename, 'm')
        self.sync()
        self.emit('if p + 3 < L:')
        self.emit('    raise _bad("%d bytes left over after the message" % (L - p))')
        self.emit('return m')
        self.env.update(_LE=HEADER_LE[:2], _other=other, _ERRORS=_DECODE_ERRORS,
                        _failed=_failure('deserialise', typename))
        return ('def decode(data):\n    if not data.startswith(_LE):\n        return _other(data)\n    try:\n' +
                '\n'.join(self.lines) + '\n    except _ERRORS as err:  # UnicodeDecodeError is a ValueError\n'
                '        raise _failed(data, err) from err\n')


def _as_field(base: str, view: str) -> str:
    """The expression of a decoded array field from ``view`` (a numpy view of its octets) as rclpy has it."""
    if base == 'bool':
        return f'{view}.tolist()'
    if base == 'byte':
        return f'_octet_list({view})'
    return view


def _coerce(arr: Any, dtype: np.dtype, length: int | None, field: str) -> np.ndarray:
    """An array field that is not exactly ``dtype``, 1-D: accepted if equal in dtype, else ValueError."""
    if not isinstance(arr, np.ndarray) or arr.dtype != dtype or arr.ndim != 1:
        shown = f'array of {arr.dtype}, shape {arr.shape}' if isinstance(arr, np.ndarray) else type(arr).__name__
        raise ValueError(f'field {field} must be a 1-D numpy array of {dtype}; got {shown}')
    if length is not None and arr.shape[0] != length:
        raise ValueError(f'field {field} must hold {length} values; got {arr.shape[0]}')
    return arr


def _bools(values: Any, length: int | None, field: str) -> bytes:
    """The bytes of a ``bool[N]``/``bool[]`` field given as a list (or tuple) of bools."""
    if isinstance(values, np.ndarray):
        raise ValueError(f'field {field} must be a list of bools; got a numpy array (pass .tolist(): rclpy aborts '
                         'the process on numpy bools)')
    data = bytes(values)  # TypeError for an item that is not an int
    if data.strip(b'\x00\x01'):
        raise ValueError(f'field {field} must hold bools; got {values!r}'[:200])
    if length is not None and len(data) != length:
        raise ValueError(f'field {field} must hold {length} values; got {len(data)}')
    return data


def _octets(values: Any, length: int | None, field: str) -> bytes:
    """The octets of a ``byte[N]``/``byte[]`` field given as a list (or tuple) of bytes of length 1."""
    if isinstance(values, (bytes, bytearray, str, np.ndarray)):
        raise ValueError(f'field {field} must be a list of bytes of length 1; got {type(values).__name__}')
    data = b''.join(values)  # TypeError for an item that is not bytes-like
    if len(data) != len(values):
        raise ValueError(f'field {field} must hold bytes of length 1; got {values!r}'[:200])
    if length is not None and len(data) != length:
        raise ValueError(f'field {field} must hold {length} values; got {len(data)}')
    return data


def _octet_list(view: np.ndarray) -> list:
    """A ``byte[N]``/``byte[]`` field from a uint8 view of its octets: a list of bytes of length 1."""
    return list(map(OCTETS.__getitem__, view.tobytes()))


def _to_sequence(values: Any, typecode: str, dtype: np.dtype, field: str) -> array.array:
    """A numeric sequence given as something other than an ``array.array`` of ``typecode``: a 1-D numpy
    array of ``dtype`` is accepted (its bytes), anything else is a ValueError."""
    out = array.array(typecode)
    out.frombytes(_coerce(values, dtype, None, field).tobytes())
    return out


def _sequence(typecode: str, data: bytes, p: int, size: int) -> array.array:
    """An ``array.array`` of the ``size`` bytes at ``p`` (a copy, as rclpy makes it)."""
    if p + size > len(data):
        raise ValueError(f'a sequence of {size} bytes at offset {p - 4} runs past the end ({len(data) - 4} bytes)')
    out = array.array(typecode)
    out.frombytes(memoryview(data)[p:p + size])
    return out


def _string_run(texts: list, memo: list) -> bytes:
    """The CDR of a sequence's strings, from a 4-aligned position: each a uint32 length, UTF-8 and a
    zero byte, zero bytes up to 4-alignment between them.

    ``memo[0]`` is the last list encoded and its bytes (a node sends the same labels message
    after message); equal strings encode to equal bytes.
    """
    last, run = memo[0]
    if type(texts) is list and texts == last:
        return run
    parts = []
    for text in texts:
        data = text.encode()
        parts += (_COUNT(len(data) + 1), data, _ZEROS[1 + -(len(data) + 1) % 4])
    if parts:
        parts[-1] = b'\0'  # no padding after the last: the next field aligns itself
    run = b''.join(parts)
    memo[0] = (list(texts), run)
    return run


def _join_copies(parts: list) -> bytes:
    """``b''.join(parts)`` where some arrays are not contiguous: those are copied to bytes first."""
    return b''.join(np.ascontiguousarray(part).tobytes() if isinstance(part, np.ndarray) else part for part in parts)


def _bad(text: str) -> ValueError:
    return ValueError(text)


def _compile(source: str, env: dict[str, Any], name: str) -> Callable:
    exec(compile(source, f'<cdr {name}>', 'exec'), env)  # source built from parsed field definitions only
    return env[name.split()[0]]


def _failure(verb: str, typename: str) -> Callable[[Any, Exception], MessageError]:
    def failed(subject: Any, err: Exception) -> MessageError:
        what = f'{len(subject)} bytes as ' if verb == 'deserialise' else ''
        return MessageError(f'cannot {verb} {what}{typename}: {err}')
    return failed


def make_codec(typename: str, fielddefs: dict, get_class: Callable[[str], type],
               other: Callable[[bytes], Any]) -> Codec:
    """Generate the encoder and decoder of ``typename``.

    Args:
        fielddefs: rosbags' field definitions (``typestore.fielddefs``) of the type and every type it uses.
        get_class: the message class of a type name (decoded messages are made of these classes).
        other: decodes what is not little-endian CDR (big endian, or raises MessageError).

    Raises:
        UnsupportedType: a field type outside ROS 2's primitives, strings, arrays and messages.
    """
    encoder = _Encoder(fielddefs, get_class)
    enc_source = encoder.build(typename)
    decoder = _Decoder(fielddefs, get_class)
    dec_source = decoder.build(typename, other)
    return Codec(typename, _compile(enc_source, encoder.env, 'encode'), _compile(dec_source, decoder.env, 'decode'),
                 enc_source + '\n' + dec_source)
