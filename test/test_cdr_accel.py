"""The compiled CDR codec against the Python codec and rosbags: the same bytes, values, types and errors.

Three codecs of each type are compared: the Python codec (touch_graph.cdr), the compiled one as
messages.py uses it (its failures explained by the Python codec, so the same MessageError text),
and the compiled one alone (no explainer: it must find every failure itself). Messages of every
type the type store knows are drawn at random (cdr_testing), and damaged bytes and wrong field
values are drawn around them.
"""

import math
import os
import struct
import subprocess
import sys
from functools import cache, partial

import numpy as np
import pytest
from cdr_testing import EVERY, OURS, damaged, message_of
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from leak_testing import assert_no_leak
from rosbags.interfaces import Nodetype

from touch_graph import cdr_accel, messages
from touch_graph.cdr import UnsupportedType, make_codec
from touch_graph.errors import MessageError
from touch_graph.messages import get_message, typestore

REQUIRED = os.environ.get('SOCIAL_TOUCH_REQUIRE_CDR_ACCEL') == '1'
_SETTINGS = {'deadline': None, 'suppress_health_check': [HealthCheck.too_slow, HealthCheck.data_too_large]}


def test_the_compiled_codec_is_built_where_required_and_chosen_unless_told_otherwise():
    if REQUIRED:  # CI sets it: a failed build must not leave only the Python codec tested
        assert cdr_accel.available(), f'the compiled CDR codec did not build: {cdr_accel.IMPORT_ERROR}'
    forced = os.environ.get('SOCIAL_TOUCH_CDR', '').lower() == 'python'
    expected = 'c' if cdr_accel.available() and not forced else 'python'
    assert messages.codec_implementation() == expected
    if expected == 'c':
        assert type(messages.encoder('GestureEvent')).__name__ == 'builtin_function_or_method'


needs_accel = pytest.mark.skipif(not cdr_accel.available() and not REQUIRED,
                                 reason=f'the compiled CDR codec was not built here: {cdr_accel.IMPORT_ERROR}')


@pytest.mark.parametrize(('value', 'expected'), [('python', 'python'), ('PYTHON', 'python'), ('', None)])
def test_the_environment_variable_chooses_the_codec(value, expected):
    code = 'from touch_graph import messages; print(messages.codec_implementation())'
    env = {**os.environ, 'SOCIAL_TOUCH_CDR': value}
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True, check=True)
    assert out.stdout.strip() == (expected or ('c' if cdr_accel.available() else 'python'))


def test_an_unknown_codec_name_is_refused_clearly():
    code = 'from touch_graph import messages'
    env = {**os.environ, 'SOCIAL_TOUCH_CDR': 'fortran'}
    out = subprocess.run([sys.executable, '-c', code], env=env, capture_output=True, text=True)
    assert out.returncode != 0 and "SOCIAL_TOUCH_CDR='fortran': expected 'c'" in out.stderr


@cache
def _codecs(typename: str) -> tuple:
    """(Python codec, compiled codec explained by it, compiled codec alone) of a type."""
    full = get_message(typename).__msgtype__
    other = partial(messages._rosbags_decode, full)
    python = make_codec(full, typestore.fielddefs, get_message, other)
    compiled = cdr_accel.make_accel_codec(full, typestore.fielddefs, get_message, other, python)
    program = cdr_accel.layout_program(full, typestore.fielddefs, get_message)
    alone = cdr_accel._cdr_accel.Codec(full, program, other, MessageError)
    return python, compiled, alone


def _outcome(fn, *args):
    """What ``fn(*args)`` returns, or the MessageError it raises (anything else fails the test)."""
    try:
        return fn(*args)
    except MessageError as err:
        return err


def _identical(a, b, where: str = 'message') -> None:
    """Equal values of the same Python types: floats bit for bit, arrays of one dtype, read-only."""
    assert type(a) is type(b), where
    if isinstance(a, messages.Message):
        for name in a._fields:
            _identical(getattr(a, name), getattr(b, name), f'{where}.{name}')
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), where
        assert not a.flags.writeable and not b.flags.writeable, where
    elif isinstance(a, list):
        assert len(a) == len(b), where
        for i, (x, y) in enumerate(zip(a, b, strict=True)):
            _identical(x, y, f'{where}[{i}]')
    elif isinstance(a, float):
        assert struct.pack('<d', a) == struct.pack('<d', b), where
    else:
        assert a == b, where


def _views_of(value, data: bytes) -> None:
    """Every array of a decoded message is a view of ``data`` (no copy)."""
    if isinstance(value, messages.Message):
        for name in value._fields:
            _views_of(getattr(value, name), data)
    elif isinstance(value, np.ndarray):
        assert value.base is data
    elif isinstance(value, list):
        for item in value:
            _views_of(item, data)


def _check_message(msg) -> None:
    python, compiled, alone = _codecs(msg.__msgtype__)
    data = python.encode(msg)
    assert compiled.encode(msg) == data == alone.encode(msg)
    assert data == bytes(typestore.serialize_cdr(msg, msg.__msgtype__, little_endian=True))
    for pad in (True, 1, 0, None):
        assert compiled.encode(msg, pad) == python.encode(msg, pad) == compiled.encode(msg, pad=pad)
    decoded = compiled.decode(data)
    _identical(decoded, python.decode(data))
    _identical(alone.decode(data), decoded)
    _views_of(decoded, data)
    padded = python.encode(msg, True)
    _identical(compiled.decode(padded), python.decode(padded))


@needs_accel
@pytest.mark.parametrize('typename', OURS)
@settings(max_examples=40, **_SETTINGS)
@given(data=st.data())
def test_our_types_encode_and_decode_as_the_python_codec_and_rosbags_do(typename, data):
    _check_message(data.draw(message_of(typename)))


@needs_accel
@settings(max_examples=400, **_SETTINGS)
@given(data=st.data())
def test_every_known_type_encodes_and_decodes_as_the_python_codec_and_rosbags_do(data):
    _check_message(data.draw(st.sampled_from(EVERY).flatmap(message_of)))


def _check_bad_bytes(data: bytes, typename: str) -> None:
    """The Python codec's outcome, exactly: the same message, or the same MessageError text."""
    python, compiled, alone = _codecs(typename)
    expected = _outcome(python.decode, data)
    got, own = _outcome(compiled.decode, data), _outcome(alone.decode, data)
    if isinstance(expected, MessageError):
        assert isinstance(got, MessageError) and str(got) == str(expected)
        assert isinstance(own, MessageError), 'the compiled codec alone decodes what the Python codec refuses'
        if data[:2] == b'\x00\x01':
            assert str(own).startswith(f'cannot deserialise {len(data)} bytes as {python.typename}: ')
    else:
        _identical(got, expected)
        _identical(own, expected)


_COUNTS = st.sampled_from([0, 1, 3, 5, 255, 2**16, 2**31, 2**32 - 1])


@needs_accel
@pytest.mark.parametrize('typename', [*OURS, 'rcl_interfaces/msg/ParameterEvent',
                                      'diagnostic_msgs/msg/DiagnosticArray'])
@settings(max_examples=25, **_SETTINGS)
@given(data=st.data())
def test_damaged_bytes_get_the_python_codecs_outcome(typename, data):
    good = _codecs(typename)[0].encode(data.draw(message_of(typename)))
    for cut in range(len(good)):  # every truncation
        _check_bad_bytes(good[:cut], typename)
    words = bytearray(good)
    for _ in range(data.draw(st.integers(1, 3))):  # counts and lengths replaced, aligned as CDR puts them
        at = 4 + 4 * data.draw(st.integers(0, max(0, (len(good) - 8) // 4)))
        words[at:at + 4] = struct.pack('<I', data.draw(_COUNTS))
    _check_bad_bytes(bytes(words), typename)
    for bad in damaged(data, good):
        _check_bad_bytes(bad, typename)
    _check_bad_bytes(b'\x00\x01\x00\x00' + data.draw(st.binary(max_size=64)), typename)


@needs_accel
def test_a_huge_count_is_refused_before_anything_is_allocated():
    python, compiled, alone = _codecs('GestureEvent')
    good = python.encode(get_message('GestureEvent')(gesture='g'))
    offset = 4 + 8 + 8 + 8 + 8  # the classes count (see test_graph_cdr)
    for count in (2**31, 2**32 - 1):
        huge = good[:offset] + struct.pack('<I', count) + good[offset + 4:]
        with pytest.raises(MessageError, match='cannot fit'):
            compiled.decode(huge)
        with pytest.raises(MessageError, match='cannot fit'):
            alone.decode(huge)


_WRONG_VALUES = [None, 'text', '\ud800', b'bytes', 1.5, 2**70, -1, 256, True, float('nan'), 1e300, object(),
                 [1, 2], ['a', 'b'], (), np.float64(2.5), np.int16(-3), np.zeros(3, '>f8'), np.zeros((2, 2)),
                 np.zeros(0, np.int8), np.arange(6, dtype=np.float32)[::2]]


@needs_accel
@settings(max_examples=400, **_SETTINGS)
@given(typename=st.sampled_from(EVERY), data=st.data())
def test_wrong_field_values_give_the_python_codecs_outcome(typename, data):
    msg = data.draw(message_of(typename))
    name = data.draw(st.sampled_from(msg._fields))
    setattr(msg, name, data.draw(st.sampled_from(_WRONG_VALUES)))  # past the checking constructor
    python, compiled, alone = _codecs(typename)
    expected = _outcome(python.encode, msg)
    got, own = _outcome(compiled.encode, msg), _outcome(alone.encode, msg)
    if isinstance(expected, MessageError):
        assert isinstance(got, MessageError) and str(got) == str(expected)
        assert isinstance(own, MessageError) and str(own).startswith(f'cannot serialise {python.typename}: ')
    else:
        assert got == own == expected


@needs_accel
def test_a_pad_without_a_truth_value_gives_message_error():
    python, compiled, _ = _codecs('std_msgs/msg/String')
    msg = get_message('std_msgs/msg/String')(data='abc')
    with pytest.raises(MessageError) as expected:
        python.encode(msg, np.array([1, 2]))
    with pytest.raises(MessageError) as got:
        compiled.encode(msg, np.array([1, 2]))
    assert str(got.value) == str(expected.value)
    with pytest.raises(TypeError):
        compiled.encode(msg, False, True)
    with pytest.raises(TypeError):
        compiled.encode(msg, padding=True)


@needs_accel
def test_other_byte_orders_and_bytes_like_inputs_go_where_the_python_codec_sends_them():
    msg = get_message('GestureEvent')(gesture='pat', classes=['a', 'b'], posteriors=[0.25, 0.75], latency_s=0.5)
    python, compiled, _ = _codecs('GestureEvent')
    big = bytes(typestore.serialize_cdr(msg, msg.__msgtype__, little_endian=False))
    assert compiled.decode(big) == python.decode(big) == msg  # rosbags decodes both (its arrays are writeable)
    data = python.encode(msg)
    assert compiled.decode(bytearray(data)) == msg  # the Python codec decodes it (as writeable views)


@needs_accel
def test_arrays_that_are_not_contiguous_encode_as_their_copies():
    python, compiled, alone = _codecs('BearFrame')
    wide = np.linspace(0, 1, 128, dtype=np.float32)
    for level in (wide[::2], wide[::-2], wide[64:]):
        frame = get_message('BearFrame')(level=level)
        assert compiled.encode(frame) == alone.encode(frame) == python.encode(frame)


@needs_accel
def test_the_program_lists_each_message_type_once_with_its_slots():
    program = cdr_accel.layout_program('diagnostic_msgs/msg/DiagnosticArray', typestore.fielddefs, get_message)
    names = [cls.__msgtype__ for cls, _ in program]
    assert names[0] == 'diagnostic_msgs/msg/DiagnosticArray' and len(names) == len(set(names))
    assert {'std_msgs/msg/Header', 'builtin_interfaces/msg/Time', 'diagnostic_msgs/msg/KeyValue'} <= set(names)
    fields = dict((f[0], f) for f in program[0][1])
    assert fields['status'][1:3] == ('sequence', 'message') and program[fields['status'][7]][0].__msgtype__ == (
        'diagnostic_msgs/msg/DiagnosticStatus')


def test_a_type_the_program_cannot_express_is_unsupported():
    fielddefs = {'x/msg/Wide': ([], [('w', (Nodetype.BASE, ('wstring', 0)))])}
    with pytest.raises(UnsupportedType):
        cdr_accel.layout_program('x/msg/Wide', fielddefs, lambda name: object)


@needs_accel
def _one_field(*spec):
    return [(object, (spec,))]


@pytest.mark.parametrize('program', [
    [], 'no', [(object, (('a',),))],
    _one_field('a', 'one', 'nonsense', None, 0, 0, 0, 0),               # no such element
    _one_field('a', 'weird', 'bool', None, 0, 0, 0, 0),                 # no such shape
    _one_field('a', 'one', 'message', None, 0, 0, 0, 5),                # no layout 5
    _one_field('a', 'array', 'float64', None, 2, 0, 0, 0),              # an array without its dtype
    _one_field('a', 'array', 'float64', np.dtype(np.int8), 2, 0, 0, 0), # a dtype of another size
    _one_field('a', 'array', 'float64', np.dtype(np.float64), -2, 0, 0, 0),
])
def test_a_malformed_program_is_refused_at_construction(program):
    with pytest.raises((TypeError, ValueError)):
        cdr_accel._cdr_accel.Codec('x/msg/T', program, len, MessageError)


@needs_accel
def test_no_references_or_blocks_leak_on_success_and_on_failure():
    python, compiled, alone = _codecs('GestureEvent')
    cls = get_message('GestureEvent')
    msg = cls(gesture='stroke', classes=['a', 'ü'], posteriors=[0.5, 0.5], latency_s=0.25)
    data = python.encode(msg)
    bad = msg.__class__(gesture='g')
    bad.posteriors = np.zeros(2, np.float32)
    watched = [cls, get_message('std_msgs/msg/Header'), data, msg.posteriors, msg.classes, msg.header, MessageError,
               np.dtype(np.float64), compiled.decode, alone.decode]

    def run(times: int) -> None:
        for _ in range(times):
            compiled.decode(compiled.encode(msg, True))
            alone.decode(data)
            for codec in (compiled, alone):
                for fn, arg in ((codec.decode, data[:-9]), (codec.decode, data + b'garbage'), (codec.encode, bad)):
                    with pytest.raises(MessageError):
                        fn(arg)

    assert_no_leak(run, watched, warm=200, times=3000)


@needs_accel
def test_float32_values_round_as_struct_rounds_them():
    python, compiled, _ = _codecs('codec_test_msgs/msg/Strings')
    msg = get_message('codec_test_msgs/msg/Strings')()
    for value in (1e-46, 3.4028235e38, -0.0, math.inf, 0.1):
        msg.f = value
        assert compiled.encode(msg) == python.encode(msg)
    msg.f = 3.5e38  # finite beyond float32: refused by both
    with pytest.raises(MessageError):
        compiled.encode(msg)


@needs_accel
def test_a_list_emptied_while_it_is_encoded_gives_message_error_not_a_crash():
    statuses = [get_message('diagnostic_msgs/msg/DiagnosticStatus')(name=str(i)) for i in range(3)]

    class Emptying:
        def __index__(self) -> int:
            statuses.clear()
            return 1

    statuses[0].level = Emptying()
    msg = get_message('diagnostic_msgs/msg/DiagnosticArray')(status=list(statuses))
    msg.status = statuses
    _, _, alone = _codecs('diagnostic_msgs/msg/DiagnosticArray')
    with pytest.raises(MessageError, match='changed size'):
        alone.encode(msg)
