"""The generated CDR codec against rosbags, the reference: same bytes, same messages, same refusals.

Messages of every type the type store knows (ours, the services', ROS 2's standard ones, and
test-only types with the layouts no real type has yet) are generated with random field
values: empty, long and unicode strings, NaN and infinities, empty and long arrays, nested
messages and sequences of them.
"""

import array
import struct

import numpy as np
import pytest
from cdr_testing import EVERY, OURS, TEST_TYPES, damaged, message_of
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.serde import SerdeError
from rosbags.typesys import get_types_from_msg

from touch_graph import messages
from touch_graph.errors import MessageError
from touch_graph.messages import deserialize, get_message, serialize, typestore


def _rosbags_bytes(msg) -> bytes:
    return bytes(typestore.serialize_cdr(messages.for_rosbags(msg), msg.__msgtype__, little_endian=True))


def _rosbags_message(data: bytes, typename: str):
    """rosbags' decoding, as messages.deserialize did before the generated codec."""
    try:
        return typestore.deserialize_cdr(data, get_message(typename).__msgtype__)
    except (SerdeError, IndexError, ValueError, TypeError) as err:
        raise MessageError(str(err)) from err


def _same(a, b) -> None:
    """Equal messages (NaN equal to NaN), arrays of the same dtype."""
    assert a == b
    for name in a._fields:
        x, y = getattr(a, name), getattr(b, name)
        if isinstance(x, np.ndarray):
            assert x.dtype == y.dtype, name
        if isinstance(x, array.array):
            assert type(y) is array.array and x.typecode == y.typecode, name


def _check_against_rosbags(msg) -> None:
    typename = msg.__msgtype__
    data = serialize(msg)
    assert data == _rosbags_bytes(msg)
    decoded = deserialize(data, typename)
    _same(decoded, msg)
    _same(decoded, _rosbags_message(data, typename))
    assert serialize(decoded) == data
    padded = serialize(msg, pad=True)
    assert padded[:len(data)] == data and len(padded) % 4 == 0 and len(padded) - len(data) < 4
    assert not padded[len(data):].strip(b'\0')
    _same(deserialize(padded, typename), msg)


_OURS, _EVERY = OURS, EVERY


@pytest.mark.parametrize('typename', _OURS)
@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_our_types_encode_and_decode_as_rosbags_does(typename, data):
    _check_against_rosbags(data.draw(message_of(typename)))


@settings(max_examples=600, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_every_known_type_encodes_and_decodes_as_rosbags_does(data):
    _check_against_rosbags(data.draw(st.sampled_from(_EVERY).flatmap(message_of)))


def test_byte_fields_are_bytes_of_length_1_on_the_wire_and_back():
    # A byte is an octet 0-255 on the wire (rosbags packs it signed: its ints become the same bytes here).
    status = get_message('diagnostic_msgs/msg/DiagnosticStatus')(level=b'\xc8', name='n')
    data = serialize(status)
    assert data[4] == 200 and data == _rosbags_bytes(status)
    assert deserialize(data, 'diagnostic_msgs/msg/DiagnosticStatus').level == b'\xc8'
    assert _rosbags_message(data, 'diagnostic_msgs/msg/DiagnosticStatus').level == b'\xc8'
    octets = get_message('codec_test_msgs/msg/Octets')(
        one=b'\xff', fixed=[b'\x00', b'\x80', b'\xff'], blob=[b'\x01', b'\xfe'], few=[b'\x7f'],
        c=255, chars=[0, 200], pair=np.array([1, 2], np.uint8), after=7)
    data = serialize(octets)
    for back in (deserialize(data, 'codec_test_msgs/msg/Octets'), _rosbags_message(data, 'codec_test_msgs/msg/Octets')):
        _same(back, octets)
        assert back.one == b'\xff' and back.fixed == [b'\x00', b'\x80', b'\xff'] and back.blob == [b'\x01', b'\xfe']
        assert back.few == [b'\x7f'] and back.none == [] and back.after == 7
        assert back.c == 255 and type(back.chars) is array.array and back.chars.tolist() == [0, 200]
        assert back.pair.dtype == np.uint8 and back.pair.tolist() == [1, 2]   # char is IDL uint8, as in rclpy
    assert data == _rosbags_bytes(octets)


def test_big_endian_payloads_decode_through_rosbags():
    msg = get_message('GestureEvent')(gesture='pat', classes=['a', 'b'], posteriors=[0.25, 0.75], latency_s=0.5)
    data = bytes(typestore.serialize_cdr(messages.for_rosbags(msg), msg.__msgtype__, little_endian=False))
    assert data[:2] == b'\x00\x00'
    assert deserialize(data, 'GestureEvent') == msg


def test_any_bytes_like_decodes_and_arrays_are_read_only_views():
    frame = get_message('BearFrame')(level=np.linspace(0, 1, 64, dtype=np.float32))
    data = serialize(frame)
    for form in (data, bytearray(data), memoryview(data)):
        back = deserialize(form, 'BearFrame')
        assert back == frame
        assert not back.level.flags.writeable


@pytest.mark.parametrize(('field', 'value'), [
    ('raw', [1, 2, 3]),                           # another length
    ('raw', np.zeros(63, np.uint16)),             # another length
    ('raw', np.full(64, -1)),                     # out of uint16
    ('level', np.zeros((8, 8), np.float32)),      # not 1-D
    ('active', np.zeros(64, bool)),               # numpy bools where rclpy needs Python bools
    ('active', [np.True_] * 64),                  # the same, item by item
    ('sequence', 70000),                          # out of uint16
    ('sequence', 1.5),                            # not an int
    ('header', None),                             # not a message
])
def test_a_field_assigned_a_wrong_value_after_construction_gives_message_error(field, value):
    frame = get_message('BearFrame')()
    with pytest.raises(MessageError, match=f"field '{field}' of social_touch_msgs/msg/BearFrame expects"):
        setattr(frame, field, value)  # the property converts or refuses, as rclpy's (ROS_PYTHON_CHECK_FIELDS=1)


@pytest.mark.parametrize(('field', 'value', 'expected'), [
    ('raw', np.arange(64, dtype=np.int64), 'uint16'),   # another dtype: converted, as rclpy does
    ('raw', list(range(64)), 'uint16'),                  # a list where an array belongs
    ('level', np.zeros(64, '>f4'), 'float32'),           # another byte order
])
def test_a_field_assigned_a_convertible_value_after_construction_holds_the_fields_type(field, value, expected):
    frame = get_message('BearFrame')()
    setattr(frame, field, value)
    assert getattr(frame, field).dtype == np.dtype(expected)
    assert deserialize(serialize(frame), 'BearFrame') == frame


def test_strings_that_are_not_utf8_encodable_give_message_error():
    event = get_message('GestureEvent')(classes=['ok'])
    event.classes = ['\ud800']  # a lone surrogate
    with pytest.raises(MessageError):
        serialize(event)


def _outcome(fn):
    try:
        return fn()
    except MessageError:
        return MessageError


def _compare_on_bad_bytes(data: bytes, typename: str) -> None:
    ours = _outcome(lambda: deserialize(data, typename))  # anything but MessageError fails the test
    reference = _outcome(lambda: _rosbags_message(data, typename) if len(data) >= 4 else None)
    if reference is MessageError or reference is None:
        assert ours is MessageError or reference is None, 'ours decodes bytes rosbags refuses'
    else:
        assert ours is not MessageError, 'rosbags decodes these bytes, ours refuses them'
        _same(ours, reference)


_BAD_TYPES = [*messages.interface_names(), *TEST_TYPES,
              'rcl_interfaces/msg/ParameterEvent']


@pytest.mark.parametrize('typename', _BAD_TYPES)
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_damaged_bytes_are_refused_as_rosbags_refuses_them(typename, data):
    msg = data.draw(message_of(typename))
    good = serialize(msg)
    cut = data.draw(st.integers(0, len(good)))
    _compare_on_bad_bytes(good[:cut], typename)
    for bad in damaged(data, good):
        _compare_on_bad_bytes(bad, typename)


def test_a_huge_count_in_garbage_is_refused_without_allocating():
    good = serialize(get_message('GestureEvent')(gesture='g'))
    # the classes count sits after header (stamp 8, frame_id 4+1, pad 3), gesture (4+2, pad 2), probability 8
    offset = 4 + 8 + 8 + 8 + 8
    assert struct.unpack_from('<I', good, offset)[0] == 0
    huge = good[:offset] + struct.pack('<I', 2**31) + good[offset + 4:]
    with pytest.raises(MessageError, match='cannot fit'):
        deserialize(huge, 'GestureEvent')


def _strings_payload(tiny: list[bytes]) -> bytes:
    """CDR of codec_test_msgs/Strings written by hand: ``tiny`` as given, no words, no counts, f = 0."""
    out = bytearray(b'\x00\x01\x00\x00') + struct.pack('<I', len(tiny))
    for text in tiny:
        out += bytes(-(len(out) - 4) % 4) + struct.pack('<I', len(text) + 1) + text + b'\0'
    out += bytes(-(len(out) - 4) % 4)
    return bytes(out + struct.pack('<IIf', 0, 0, 0.0))


def test_bounds_are_enforced_on_decode():
    assert deserialize(_strings_payload([b'abc']), 'codec_test_msgs/msg/Strings').tiny == ['abc']
    assert _strings_payload([b'abc']) == serialize(get_message('codec_test_msgs/msg/Strings')(tiny=['abc']))
    with pytest.raises(MessageError, match='bound 3'):
        deserialize(_strings_payload([b'abcd']), 'codec_test_msgs/msg/Strings')
    with pytest.raises(MessageError, match='bound 2'):
        deserialize(_strings_payload([b'a', b'b', b'c']), 'codec_test_msgs/msg/Strings')


# ------------------------------------------------------------------ hard cases of the decoder's shortcuts
# Fixed arrays of one run are decoded as fields of one record view, a sequence of strings the same
# as the last one is taken from a memo, and arrays are joined into the output without a copy.
_RUNS_TYPES = {
    'codec_test_msgs/msg/Runs': ('string s\nuint8[3] a\nfloat64[2] d\nbool[5] f\nint16[1] i\nstring[] words\n'
                                 'float32[3] tail\nfloat64[] maybe\nuint16[2] last\n'),
}
for _name, _text in _RUNS_TYPES.items():
    typestore.register(get_types_from_msg(_text, _name))


def _runs(s: str = '', words: tuple = (), maybe: tuple = ()):
    return get_message('codec_test_msgs/msg/Runs')(
        s=s, a=np.array([0, 128, 255], np.uint8), d=np.array([np.nan, -np.inf]), f=[True, False, True, True, False],
        i=np.array([-32768], np.int16), words=list(words), tail=np.array([np.nan, 1.5, -0.0], np.float32),
        maybe=np.array(maybe, np.float64), last=np.array([0, 65535], np.uint16))


@pytest.mark.parametrize('length', range(9))  # every alignment of the arrays after the string
def test_runs_of_fixed_arrays_after_a_string_decode_as_rosbags_does(length):
    msg = _runs('x' * length, words=['', 'ab', 'abc', 'abcd'][:length % 5], maybe=[np.nan] * (length % 3))
    _check_against_rosbags(msg)
    back = deserialize(serialize(msg), 'codec_test_msgs/msg/Runs')
    for name in ('a', 'd', 'i', 'tail', 'last'):   # fixed-size numeric arrays: read-only views
        value = getattr(back, name)
        assert value.dtype is getattr(msg, name).dtype and not value.flags.writeable, name
    assert back.f == [True, False, True, True, False]                                  # bool[5]: a list
    assert type(back.maybe) is array.array and back.maybe.typecode == 'd'             # float64[]: array.array
    assert np.isnan(back.d[0]) and np.signbit(back.tail[2])


@settings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(data=st.data())
def test_the_runs_type_encodes_and_decodes_as_rosbags_does(data):
    _check_against_rosbags(data.draw(message_of('codec_test_msgs/msg/Runs')))


def test_a_truncated_run_of_arrays_is_refused():
    data = serialize(_runs('abc'))
    for cut in range(len(data) - 3):  # the last 3 bytes may be padding only
        with pytest.raises(MessageError):
            deserialize(data[:cut], 'codec_test_msgs/msg/Runs')


def test_arrays_that_are_not_contiguous_encode_as_their_copies():
    wide = np.linspace(0, 1, 128, dtype=np.float32)
    frame = get_message('BearFrame')(level=wide[::2])
    assert not frame.level.flags.c_contiguous
    expected = serialize(get_message('BearFrame')(level=wide[::2].copy()))
    assert serialize(frame) == expected
    frame.level = wide[::-2]
    assert serialize(frame) == serialize(get_message('BearFrame')(level=wide[::-2].copy()))
    event = get_message('GestureEvent')(posteriors=np.arange(6.0)[::3])
    assert deserialize(serialize(event), 'GestureEvent').posteriors.tolist() == [0.0, 3.0]


def test_a_repeated_sequence_of_strings_decodes_to_a_fresh_list_each_time():
    event = get_message('GestureEvent')(classes=['stroke', 'tickle', 'ü', ''])
    data = serialize(event)
    first, second = deserialize(data, 'GestureEvent'), deserialize(data, 'GestureEvent')
    assert first.classes == second.classes == ['stroke', 'tickle', 'ü', ''] and first.classes is not second.classes
    first.classes.append('changed')
    assert deserialize(data, 'GestureEvent').classes == ['stroke', 'tickle', 'ü', '']


@pytest.mark.parametrize('sequence', [
    [['a', 'b'], ['a'], ['a', 'b', 'c'], ['a', 'b'], []],  # prefixes of each other, and empty
    [['ab'], ['a'], ['ab'], ['abcd'], ['abc']],             # the same count, other bytes
    [['x'] * 3, ['x'] * 3, ['y'] * 3, ['x'] * 3],           # repeated, then changed, then back
])
def test_sequences_of_strings_in_turn_encode_and_decode_as_rosbags_does(sequence):
    for words in sequence:
        _check_against_rosbags(_runs('s', words=words))
        _check_against_rosbags(get_message('GestureEvent')(classes=words, posteriors=[0.5] * len(words)))


def test_a_list_changed_in_place_after_encoding_encodes_again():
    event = get_message('GestureEvent')(classes=['a', 'b'])
    before = serialize(event)
    event.classes.append('c')
    after = serialize(event)
    assert after != before and deserialize(after, 'GestureEvent').classes == ['a', 'b', 'c']
    event.classes[0] = 'z'
    assert deserialize(serialize(event), 'GestureEvent').classes == ['z', 'b', 'c']


def test_bounds_are_enforced_after_a_sequence_at_its_bound_decoded():
    assert deserialize(_strings_payload([b'abc', b'xyz']), 'codec_test_msgs/msg/Strings').tiny == ['abc', 'xyz']
    with pytest.raises(MessageError, match='bound 2'):
        deserialize(_strings_payload([b'abc', b'xyz', b'a']), 'codec_test_msgs/msg/Strings')
    with pytest.raises(MessageError, match='bound 3'):
        deserialize(_strings_payload([b'abc', b'xyzw']), 'codec_test_msgs/msg/Strings')


def test_threads_decoding_different_sequences_of_one_type_each_get_their_own():
    import threading
    payloads = {words: serialize(get_message('GestureEvent')(classes=list(words)))
                for words in (('a', 'b'), ('c', 'd'), ('e', 'f', 'g'))}
    wrong = []

    def decode_many(words: tuple) -> None:
        for _ in range(3000):
            if deserialize(payloads[words], 'GestureEvent').classes != list(words):
                wrong.append(words)

    threads = [threading.Thread(target=decode_many, args=(words,)) for words in payloads]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not wrong
