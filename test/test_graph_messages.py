"""Messages generated from msg/*.msg: fields, errors, CDR bytes as ROS 2 writes them."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from touch_graph import messages
from touch_graph.errors import MessageError
from touch_graph.messages import deserialize, from_dict, get_message, serialize, to_dict


def test_every_msg_file_is_a_type_with_a_header_or_used_nested():
    names = messages.interface_names()
    assert 'social_touch_msgs/msg/SkinFrame' in names
    nested_only = {'social_touch_msgs/msg/SensorState'}
    for name in names:
        cls = get_message(name)
        if name not in nested_only:
            assert cls._fields[0] == 'header', name


def test_defaults_follow_ros_semantics():
    skin = get_message('SkinFrame')()
    assert skin.pressure.dtype == np.float32 and skin.pressure.shape == (144,)
    assert skin.raw.dtype == np.uint16 and skin.header.frame_id == ''
    assert skin.contact is False and skin.total_force == 0.0
    level = get_message('SensorLevel')()
    assert level.sensors == []


def test_constants_are_class_attributes():
    cls = get_message('social_touch_msgs/SymbolicGesture')
    assert (cls.START, cls.END) == (1, 2)


def test_cdr_bytes_match_ros2_layout():
    # uint8, then three strings (each 4-aligned uint32 length incl. NUL), then a 4-aligned float32.
    state = get_message('SensorState')(channel=3, name='ab', location='', region='', level=0.5)
    expected = bytes.fromhex(
        '00010000'              # CDR little endian encapsulation
        '03' '000000'           # channel, pad to 4
        '03000000' '616200'     # name 'ab\0'
        '00' '01000000' '00'    # pad, location ''
        '000000' '01000000' '00'  # pad, region ''
        '000000' '0000003f'     # pad, level 0.5
        + '00' * 24)            # position: geometry_msgs/Point (0, 0, 0), three float64, 8-aligned already
    assert serialize(state) == expected
    assert deserialize(expected, 'SensorState') == state


def test_round_trip_keeps_nan_and_nested_lists():
    skin = get_message('SkinFrame')(contact_x=math.nan, contact_y=1.5, pressure=np.full(144, 0.25, np.float32))
    assert deserialize(serialize(skin), 'SkinFrame') == skin
    state = get_message('SensorState')
    level = get_message('SensorLevel')(sensors=[state(name='head2', level=0.7), state(channel=63)])
    assert deserialize(serialize(level), 'SensorLevel') == level


@pytest.mark.parametrize(('kwargs', 'fragment'), [
    ({'pressure': np.zeros((12, 12), np.float32)}, 'flatten'),
    ({'pressure': np.zeros(143, np.float32)}, '144 float32 values'),
    ({'raw': np.full(144, 1.5)}, 'uint16'),
    ({'raw': np.full(144, 70000)}, 'in [0, 65535]'),
    ({'contact': 1}, "field 'contact'"),
    ({'contact_x': 'left'}, 'a float'),
    ({'sequence': -1}, 'in [0, 65535]'),
    ({'header': 'now'}, 'std_msgs/msg/Header message'),
    ({'pressur': np.zeros(144)}, "did you mean 'pressure'"),
])
def test_mistyped_fields_give_one_clear_error(kwargs, fragment):
    with pytest.raises(MessageError) as err:
        get_message('SkinFrame')(**kwargs)
    assert fragment in str(err.value)
    assert 'SkinFrame' in str(err.value)


def test_truncated_bytes_raise_message_error():
    data = serialize(get_message('SkinFrame')())
    with pytest.raises(MessageError, match='cannot deserialise'):
        deserialize(data[:100], 'SkinFrame')
    with pytest.raises(MessageError):
        deserialize(b'\x07\x07garbage', 'SkinFrame')


def test_from_dict_names_missing_and_unknown_fields():
    data = to_dict(get_message('HapticCommand')(gesture='line', command='stop'))
    assert from_dict('HapticCommand', data, strict=True).command == 'stop'
    del data['margin']
    with pytest.raises(MessageError, match="missing field 'margin'"):
        from_dict('HapticCommand', data, strict=True)
    data['comand'] = 'go'
    with pytest.raises(MessageError, match="did you mean 'command'"):
        from_dict('HapticCommand', data)
    with pytest.raises(MessageError, match='header'):
        from_dict('HapticCommand', {'header': 5})


def test_unknown_type_suggests_a_known_one():
    with pytest.raises(MessageError, match='SkinFrame'):
        get_message('social_touch_msgs/msg/SkinFrames')


def test_interface_show_expands_nested_types():
    text = messages.message_definition('social_touch_msgs/msg/SensorLevel')
    assert 'SensorState[] sensors' in text and '\tstring name' in text and '\t\tint32 sec' in text


@settings(max_examples=60, deadline=None)
# 256 float32 drawn as one array: drawn as a list of 256 floats, generating them took long enough on a
# loaded machine for hypothesis's health checks to fail the test.
@given(arrays(np.float32, 256, elements=st.floats(width=32, allow_nan=True)),
       st.integers(0, 65535), st.text(max_size=20))
def test_cdr_round_trip_property(values, seq, frame_id):
    header = get_message('std_msgs/msg/Header')(frame_id=frame_id)
    frame = get_message('PatchFrame')(header=header, sequence=seq, activation=values)
    assert deserialize(serialize(frame), 'PatchFrame') == frame


def test_big_endian_payloads_decode_to_the_field_types_little_endian_ones_have():
    """rosbags decodes big-endian CDR; deserialize gives a sequence the type it gives little-endian ones."""
    from rosbags.typesys import Stores, get_typestore
    store = get_typestore(Stores.ROS2_HUMBLE)
    msg = messages.get_message('std_msgs/msg/Float32MultiArray')(data=np.array([1.5, -2.0], dtype=np.float32))
    big = bytes(store.serialize_cdr(store.types['std_msgs/msg/Float32MultiArray'](
        layout=store.types['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0), data=np.asarray(msg.data)),
        'std_msgs/msg/Float32MultiArray', little_endian=False))
    assert big[:2] == b'\x00\x00'
    decoded = messages.deserialize(big, 'std_msgs/msg/Float32MultiArray')
    assert decoded.data.tolist() == [1.5, -2.0] and decoded.data.typecode == 'f'  # float32[]: rclpy's array.array
