"""The compiled CDR codec: the layout program of a type, for the interpreter in ``_cdr_accel.c``.

:mod:`touch_graph.cdr` generates Python per type and sits at Python's floor (``social-touch bench
codec`` measures both codecs). Where the C extension ``touch_graph._cdr_accel`` was built (``pip install``
compiles it when a C compiler and Python's headers are there, as PyYAML does with libyaml),
one C routine encodes and decodes every type by interpreting a *layout program* this module
derives from rosbags' field definitions, by the same walk as cdr.py's generators:

- a layout per message type reached, layout 0 the type itself: ``(class, fields)``;
- a field: ``(name, shape, element, dtype, length, seq_bound, str_bound, sub)`` with ``shape``
  ``'one'``, ``'array'`` (fixed ``length``) or ``'sequence'`` (bounded by ``seq_bound``, 0 for
  none), ``element`` a primitive (``byte`` and ``char`` are ``uint8``), ``'string'`` (at most
  ``str_bound`` characters, 0 for any) or ``'message'`` (of layout ``sub``), and ``dtype`` the
  numpy dtype of an array of primitives (cdr.py's, so both decode the same dtypes).

The bytes, values and errors are the Python codec's (the C codec asks the Python codec to
explain a failure, so the MessageError text is the same); ``test/test_cdr_accel.py`` checks it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rosbags.interfaces import Nodetype

from .cdr import _DTYPES, _FORMATS, Codec, UnsupportedType
from .errors import MessageError

try:
    from . import _cdr_accel
    IMPORT_ERROR = ''
except ImportError as err:  # not built: no compiler at install time, or an unsupported platform
    _cdr_accel = None
    IMPORT_ERROR = str(err)

__all__ = ['IMPORT_ERROR', 'available', 'layout_program', 'make_accel_codec']

#: The element names of the C interpreter (byte and char are octets).
_ELEMENTS = {name: ('uint8' if name in ('byte', 'char') else name) for name in _FORMATS}


def available() -> bool:
    """True when the C extension was built and imports."""
    return _cdr_accel is not None


class _Program:
    """Builds the layouts of one type and of every message type it reaches, each once."""

    def __init__(self, fielddefs: dict, get_class: Callable[[str], type]) -> None:
        self.fielddefs = fielddefs
        self.get_class = get_class
        self.layouts: list[tuple[type, tuple]] = []
        self.index: dict[str, int] = {}

    def layout(self, typename: str) -> int:
        """The index of ``typename``'s layout (added with its fields' layouts on first use)."""
        if typename in self.index:
            return self.index[typename]
        at = self.index[typename] = len(self.layouts)
        self.layouts.append((self.get_class(typename), ()))
        fields = tuple(self.field(name, desc) for name, desc in self.fielddefs[typename][1])
        self.layouts[at] = (self.layouts[at][0], fields)
        return at

    def field(self, name: str, desc: tuple) -> tuple:
        kind, detail = desc
        if kind in (Nodetype.BASE, Nodetype.NAME):
            return (name, 'one', *self.element(desc), 0, 0, *self.element_sizes(desc))
        if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            sub, size = detail
            shape = 'array' if kind == Nodetype.ARRAY else 'sequence'
            length, bound = (size, 0) if kind == Nodetype.ARRAY else (0, size)
            return (name, shape, *self.element(sub), length, bound, *self.element_sizes(sub))
        raise UnsupportedType(str(desc))

    def element(self, desc: tuple) -> tuple[str, Any]:
        """(element name, dtype or None) of a field's (or an array's element's) descriptor."""
        kind, detail = desc
        if kind == Nodetype.NAME:
            return 'message', None
        if kind == Nodetype.BASE and detail[0] == 'string':
            return 'string', None
        if kind == Nodetype.BASE and detail[0] in _ELEMENTS:
            return _ELEMENTS[detail[0]], _DTYPES[detail[0]]
        raise UnsupportedType(str(desc))

    def element_sizes(self, desc: tuple) -> tuple[int, int]:
        """(string bound, message layout) of an element."""
        kind, detail = desc
        if kind == Nodetype.NAME:
            return 0, self.layout(detail)
        return (detail[1] if detail[0] == 'string' else 0), 0


def layout_program(typename: str, fielddefs: dict, get_class: Callable[[str], type]) -> list[tuple[type, tuple]]:
    """The layouts of ``typename`` (first) and of the message types it reaches.

    Raises:
        UnsupportedType: a field type outside ROS 2's primitives, strings, arrays and messages.
    """
    program = _Program(fielddefs, get_class)
    program.layout(typename)
    return program.layouts


def make_accel_codec(typename: str, fielddefs: dict, get_class: Callable[[str], type],
                     other: Callable[[bytes], Any], python: Codec) -> Codec:
    """The compiled codec of ``typename``, with the interface of :func:`touch_graph.cdr.make_codec`'s.

    Args:
        other: decodes what is not little-endian CDR (big endian, or raises MessageError).
        python: the Python codec of the type: it explains the C codec's failures (the same
            MessageError text) and decodes other bytes-like types than ``bytes``.

    Raises:
        UnsupportedType: the type has a field the program cannot express (or the extension is not built).
    """
    if _cdr_accel is None:
        raise UnsupportedType(f'the compiled codec is not built: {IMPORT_ERROR}')
    program = layout_program(typename, fielddefs, get_class)
    compiled = _cdr_accel.Codec(typename, program, other, MessageError, python.encode, python.decode)
    source = '\n'.join(f'layout {i} {cls.__msgtype__}: {fields!r}' for i, (cls, fields) in enumerate(program))
    return Codec(typename, compiled.encode, compiled.decode, source)
