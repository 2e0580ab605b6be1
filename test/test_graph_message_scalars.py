"""Scalar message fields: a value of the exact Python type takes the short path and still meets every rule."""

from __future__ import annotations

import math

import numpy as np
import pytest

from touch_graph.errors import MessageError
from touch_graph.messages import get_message

SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
Point = get_message('geometry_msgs/msg/Point')
Time = get_message('builtin_interfaces/msg/Time')
Header = get_message('std_msgs/msg/Header')


def test_a_python_int_is_kept_within_its_range_and_refused_outside() -> None:
    assert SkinFrame(sequence=65535).sequence == 65535
    assert Time(sec=-(2**31), nanosec=2**32 - 1).nanosec == 2**32 - 1
    for bad in (65536, -1):
        with pytest.raises(MessageError, match=r'in \[0, 65535\]'):
            SkinFrame(sequence=bad)


def test_a_bool_is_no_int_and_an_int_is_no_bool() -> None:
    with pytest.raises(MessageError, match="field 'sequence'"):
        SkinFrame(sequence=True)
    with pytest.raises(MessageError, match="field 'contact'"):
        SkinFrame(contact=1)
    assert SkinFrame(contact=True).contact is True and SkinFrame(contact=np.bool_(False)).contact is False


def test_float64_keeps_the_value_and_float32_rounds_it() -> None:
    assert Point(x=0.1).x == 0.1
    assert SkinFrame(contact_x=0.1).contact_x == float(np.float32(0.1)) != 0.1
    assert math.isnan(SkinFrame(contact_x=math.nan).contact_x)
    assert Point(x=3).x == 3.0 and type(Point(x=3).x) is float
    with pytest.raises(MessageError, match='a float'):
        Point(x='1.0')


def test_strings_and_the_setters_follow_the_same_rules() -> None:
    header = Header(frame_id='skin')
    assert header.frame_id == 'skin'
    with pytest.raises(MessageError, match='a str'):
        Header(frame_id=b'skin')
    point = Point()
    point.y = 2.5
    assert point.y == 2.5
    with pytest.raises(MessageError):
        point.y = None
