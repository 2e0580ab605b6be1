"""Message fields have rclpy's Python types on our runtime: made, assigned and received.

rclpy's rule (Jazzy's generated classes, checked by the ros2-marked test below): a fixed-size numeric
array is a ``numpy.ndarray`` of the field's dtype; a numeric sequence is an ``array.array``; ``bool``
arrays and sequences, and arrays of strings or messages, are lists. test/field_types_probe.py lists
each field's type in the three situations on either backend.
"""

import json
import subprocess
import sys
from pathlib import Path

import pytest
from field_types_probe import run
from ros2_testing import require_ros2, ros2_env

from touch_graph.messages import get_message, interface_names

PROBE = Path(__file__).with_name('field_types_probe.py')
_DTYPES = {'float32': 'float32', 'float64': 'float64', 'uint8': 'uint8', 'int8': 'int8', 'uint16': 'uint16',
           'int16': 'int16', 'uint32': 'uint32', 'int32': 'int32', 'uint64': 'uint64', 'int64': 'int64'}
_TYPECODES = {'float32': 'f', 'float64': 'd', 'uint8': 'B', 'int8': 'b', 'uint16': 'H', 'int16': 'h',
              'uint32': 'I', 'int32': 'i', 'uint64': 'Q', 'int64': 'q'}


def rclpy_rule(type_str: str) -> set[str]:
    """The Python types rclpy gives a field of ``type_str`` (ours: ``float32[144]``, ``float64[]``...)."""
    if '[' not in type_str:
        return set()  # scalars and nested messages: not about arrays
    base, _, size = type_str.partition('[')
    base = base.split('<=')[0]
    if base in _DTYPES and size[:-1].isdigit():
        return {f'ndarray[{_DTYPES[base]}]'}
    if base in _TYPECODES:
        return {f'array.array[{_TYPECODES[base]}]'}
    if base == 'bool':
        return {'list[bool]', 'list[]'}
    if base == 'string':
        return {'list[str]', 'list[]'}
    return {f'list[{base.rpartition("/")[2]}]', 'list[]'}


def test_every_array_field_of_ours_has_rclpys_type_made_assigned_and_received():
    types = run('ours')
    checked = 0
    for name in interface_names():
        short = name.rpartition('/')[2]
        for field, type_str in get_message(name).get_fields_and_field_types().items():
            allowed = rclpy_rule(type_str)
            if not allowed:
                continue
            for situation, found in types[short][field].items():
                assert found in allowed, (short, field, type_str, situation, found)
                checked += 1
    assert checked >= 3 * 20  # every array field of the 17 types, in the three situations


def test_a_numeric_sequence_is_an_array_array_however_it_is_given():
    import array

    import numpy as np
    GestureEvent = get_message('GestureEvent')
    for given in ([0.25, 0.75], (0.25, 0.75), np.array([0.25, 0.75]), array.array('d', [0.25, 0.75])):
        event = GestureEvent(posteriors=given)
        assert type(event.posteriors) is array.array and event.posteriors.tolist() == [0.25, 0.75]
        event.posteriors = given
        assert type(event.posteriors) is array.array and event.posteriors.typecode == 'd'


def test_real_rclpy_gives_every_field_the_type_our_runtime_gives():
    require_ros2()
    result = subprocess.run([sys.executable, str(PROBE), 'rclpy'], env=ros2_env(), capture_output=True, text=True,
                            timeout=120)
    assert result.returncode == 0, result.stderr
    real = json.loads(result.stdout)
    ours = run('ours')
    different = [(t, f, real[t][f], ours[t][f]) for t in real for f in real[t] if real[t][f] != ours[t][f]]
    assert not different
    assert sum(len(fields) for fields in real.values()) == sum(len(fields) for fields in ours.values()) > 100


test_real_rclpy_gives_every_field_the_type_our_runtime_gives = pytest.mark.ros2(
    test_real_rclpy_gives_every_field_the_type_our_runtime_gives)
