"""``byte`` fields on our runtime are what rclpy (Jazzy) makes them: ``bytes`` of length 1.

What real rclpy does (ROS 2 Jazzy from PyPI, diagnostic_msgs 5.3.6, std_msgs 5.3.6, rcl_interfaces;
checked with /work/ros2-venv/bin/python; the ros2-marked test in test/test_field_types.py compares the
constants and byte defaults of every type both runtimes have):

- A ``byte`` field (IDL ``octet``: ``DiagnosticStatus.level``, ``std_msgs/Byte.data``) defaults to
  ``b'\\x00'``; its constants are ``bytes`` (``DiagnosticStatus.OK == b'\\x00'``, ``WARN == b'\\x01'``,
  ``ERROR == b'\\x02'``, ``STALE == b'\\x03'``); ``repr`` shows ``level=b'\\x00'``; equal bytes compare
  equal and order as the levels do (``max([OK, ERROR]) == ERROR``).
- Its setter, with field checks on (``ROS_PYTHON_CHECK_FIELDS=1``), takes ``bytes`` or a ``bytearray`` of
  length 1 and raises ``AssertionError`` ("must be of type 'bytes' or 'ByteString' with length 1") for an
  int, ``b''``, ``b'ab'``, a str, a float or None. With checks off (Jazzy's default) it takes anything,
  and then publishing an int writes a wrong octet (``level = 1`` went out as ``0x5d``; ``bytearray(b'\\x01')``
  as ``0x00``): our runtime refuses what the checks refuse, so the fast suite catches it.
- ``byte[]`` (``sequence<octet>``: ``ByteMultiArray.data``, ``ParameterValue.byte_array_value``) and
  ``byte[N]`` are lists of ``bytes``; ``byte[]`` defaults to ``[]`` and ``byte[N]`` to ``N`` times ``b'\\x00'``
  (rosidl_generator_py's template). The checks take a list or tuple of ``bytes`` and refuse a ``bytes``,
  a ``bytearray``, an ``array.array``, a numpy array or a list of ints; a subscriber receives a list.
- ``char`` is IDL ``uint8``: an int 0-255 (``Char().data == 0``), ``char[N]`` a uint8 numpy array,
  ``char[]`` an ``array.array('B')``; 300, -1, 'a' and b'a' are refused.
- ``get_fields_and_field_types()`` names a byte ``octet`` (``sequence<octet>``) and a char ``uint8``.
"""

import array
import copy

import cdr_testing  # noqa: F401  (registers the test-only type codec_test_msgs/msg/Octets)
import numpy as np
import pytest

from touch_graph.errors import MessageError
from touch_graph.messages import deserialize, from_dict, get_message, serialize, to_dict, typestore

DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')
Byte = get_message('std_msgs/msg/Byte')
ByteMultiArray = get_message('std_msgs/msg/ByteMultiArray')
Char = get_message('std_msgs/msg/Char')


def test_a_byte_defaults_to_a_zero_octet_and_constants_are_bytes():
    assert DiagnosticStatus().level == b'\x00' and Byte().data == b'\x00'
    assert (DiagnosticStatus.OK, DiagnosticStatus.WARN, DiagnosticStatus.ERROR, DiagnosticStatus.STALE) == (
        b'\x00', b'\x01', b'\x02', b'\x03')
    assert max([DiagnosticStatus.OK, DiagnosticStatus.ERROR, DiagnosticStatus.WARN]) == DiagnosticStatus.ERROR
    assert repr(DiagnosticStatus()) == ("diagnostic_msgs.msg.DiagnosticStatus(level=b'\\x00', name='', message='', "
                                        "hardware_id='', values=[])")  # rclpy's repr, character for character
    assert DiagnosticStatus(level=b'\x02') == DiagnosticStatus(level=DiagnosticStatus.ERROR) != DiagnosticStatus()
    assert get_message('rcl_interfaces/msg/Log').WARN == 30  # a uint8 constant stays an int, as in rclpy


@pytest.mark.parametrize('value', [1, 0, b'', b'ab', 'a', 1.0, None, np.uint8(1), [b'\x01'], memoryview(b'\x01')])
def test_a_byte_refuses_what_rclpys_checks_refuse_with_their_exception(value):
    status = DiagnosticStatus()
    with pytest.raises(AssertionError, match=r"field 'level'.*bytes of length 1"):
        status.level = value
    with pytest.raises(MessageError):  # the project's own error too
        Byte().data = value


def test_a_byte_takes_bytes_and_a_bytearray_of_length_1():
    status = DiagnosticStatus(level=bytearray(b'\x03'))
    assert status.level == b'\x03' and type(status.level) is bytes  # held as bytes, so it serialises right
    status.level = b'\xff'
    assert status.level == b'\xff'


def test_byte_arrays_are_lists_of_bytes():
    assert ByteMultiArray().data == [] and get_message('rcl_interfaces/msg/ParameterValue')().byte_array_value == []
    octets = get_message('codec_test_msgs/msg/Octets')()  # byte[3], byte[], byte[<=2], byte[0]
    assert (octets.fixed, octets.blob, octets.few, octets.none) == ([b'\x00'] * 3, [], [], [])
    assert ByteMultiArray(data=(b'\x01', b'\xff')).data == [b'\x01', b'\xff']
    for bad in (b'\x01\x02', bytearray(b'\x01'), [1, 2], array.array('B', [1]), np.array([1], np.uint8),
                [b'ab'], [b''], [bytearray(b'\x01')], 'ab'):
        with pytest.raises(AssertionError, match="field 'data'"):
            ByteMultiArray(data=bad)


def test_char_is_an_int_as_rclpy_has_it():
    assert Char().data == 0 and Char(data=255).data == 255
    assert Char.get_fields_and_field_types() == {'data': 'uint8'}
    assert Byte.get_fields_and_field_types() == {'data': 'octet'}
    for bad in (300, -1, 'a', b'a', 1.0):
        with pytest.raises(AssertionError):
            Char(data=bad)


def test_byte_fields_survive_cdr_copies_and_the_cli_dict_form():
    status = DiagnosticStatus(level=DiagnosticStatus.STALE, name='n')
    blob = ByteMultiArray(data=[b'\x00', b'\x80', b'\xff'])
    for msg in (status, blob):
        back = deserialize(serialize(msg), msg.__msgtype__)
        assert back == msg and copy.copy(msg) == msg and copy.deepcopy(msg) == msg
        # rosbags' decoder (bags read with rosbags, big-endian payloads) gives ints: the class makes them bytes
        assert typestore.deserialize_cdr(serialize(msg), msg.__msgtype__) == msg
    assert serialize(status)[4] == 3 and serialize(blob).endswith(b'\x03\x00\x00\x00\x00\x80\xff')
    # topic echo writes a byte as its int; topic pub takes that back (or bytes)
    assert to_dict(status)['level'] == 3 and to_dict(blob)['data'] == [0, 128, 255]
    assert from_dict(status.__msgtype__, to_dict(status)) == status
    assert from_dict(blob.__msgtype__, to_dict(blob)) == blob
    assert from_dict(status.__msgtype__, {'level': b'\x01'}).level == DiagnosticStatus.WARN
    with pytest.raises(MessageError, match=r'level is a byte: expects an int in \[0, 255\]'):
        from_dict(status.__msgtype__, {'level': 256})
