"""Message fields have rclpy's Python types on our runtime: made, assigned and received.

rclpy's rule (Jazzy's generated classes, checked by the ros2-marked test below): a fixed-size numeric
array is a ``numpy.ndarray`` of the field's dtype; a numeric sequence is an ``array.array``; ``bool``
arrays and sequences, and arrays of strings or messages, are lists. ``get_fields_and_field_types()``
names the types as rclpy does, in IDL (``float[144]``, ``sequence<double>``, ``octet`` for ``byte``).
test/field_types_probe.py lists each field's type in the three situations on either backend.
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
#: IDL numeric type -> (numpy dtype of a fixed-size array, array.array typecode of a sequence).
_NUMERIC = {'float': ('float32', 'f'), 'double': ('float64', 'd'), 'uint8': ('uint8', 'B'), 'int8': ('int8', 'b'),
            'uint16': ('uint16', 'H'), 'int16': ('int16', 'h'), 'uint32': ('uint32', 'I'), 'int32': ('int32', 'i'),
            'uint64': ('uint64', 'Q'), 'int64': ('int64', 'q')}


def rclpy_rule(type_str: str) -> set[str]:
    """The Python types rclpy gives a field of IDL type ``type_str`` (``float[144]``, ``sequence<double>``...)."""
    if type_str.startswith('sequence<'):
        item, sequence = type_str[len('sequence<'):-1], True
        head, _, bound = item.rpartition(', ')
        item = head if bound.isdigit() else item
    elif type_str.endswith(']'):
        item, sequence = type_str.rpartition('[')[0], False
    else:
        return set()  # scalars and nested messages: not about arrays
    if item in _NUMERIC:
        return {f'array.array[{_NUMERIC[item][1]}]'} if sequence else {f'ndarray[{_NUMERIC[item][0]}]'}
    if item == 'boolean':
        return {'list[bool]', 'list[]'}
    if item.startswith('string'):
        return {'list[str]', 'list[]'}
    return {f'list[{item.rpartition("/")[2]}]', 'list[]'}


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


#: ``facts(cls)``: a class's ``get_fields_and_field_types()``, the repr of each constant, and the repr and
#: type of the default of each ``octet`` (byte) and ``uint8`` (char, uint8) field or array, on either runtime.
_FACTS = """
def facts(cls):
    made = cls()
    small = [f for f, t in cls.get_fields_and_field_types().items() if 'octet' in t or 'uint8' in t]
    return {'fields': cls.get_fields_and_field_types(),
            'constants': {a: repr(getattr(cls, a)) for a in dir(cls) if a.isupper() and not a.startswith('_')
                          and a != 'SLOT_TYPES' and not a.endswith('__DEFAULT')},
            'defaults': {f: [repr(getattr(made, f)), type(getattr(made, f)).__name__] for f in small}}
"""
#: Prints ``{type name: facts(class)}`` of the rosidl-generated classes it can import (argv[1]: JSON list of
#: type names).
_REAL_FACTS = _FACTS + """
import importlib, json, sys
out = {}
for name in json.loads(sys.argv[1]):
    pkg, kind, short = name.split('/')
    try:
        out[name] = facts(getattr(importlib.import_module(pkg + '.' + kind), short))
    except (ImportError, AttributeError):  # a package the ROS 2 venv does not have
        pass
print(json.dumps(out))
"""


@pytest.mark.ros2
def test_field_type_names_constants_and_byte_defaults_are_rclpys():
    require_ros2()
    from touch_graph.messages import typestore
    names = sorted(name for name in typestore.fielddefs if '/msg/' in name and not name.startswith('codec_test'))
    result = subprocess.run([sys.executable, '-c', _REAL_FACTS, json.dumps(names)], env=ros2_env(),
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    real = json.loads(result.stdout)
    scope: dict = {}
    exec(_FACTS, scope)  # the same facts, of our classes
    ours = {name: json.loads(json.dumps(scope['facts'](get_message(name)))) for name in real}
    assert [(name, real[name], ours[name]) for name in real if real[name] != ours[name]] == []
    assert set(interface_names()) <= set(real) and len(real) > 100  # ours, and the standard types rclpy has
    assert real['diagnostic_msgs/msg/DiagnosticStatus']['constants']['WARN'] == repr(b'\x01')


def test_field_type_names_are_idl_names():
    assert get_message('GestureEvent').get_fields_and_field_types() == {
        'header': 'std_msgs/Header', 'gesture': 'string', 'probability': 'double', 'classes': 'sequence<string>',
        'posteriors': 'sequence<double>', 'latency_s': 'float'}
    assert get_message('std_msgs/msg/ByteMultiArray').get_fields_and_field_types()['data'] == 'sequence<octet>'
    assert get_message('std_msgs/msg/Char').get_fields_and_field_types() == {'data': 'uint8'}
    descriptor = get_message('rcl_interfaces/msg/ParameterDescriptor').get_fields_and_field_types()
    assert descriptor['floating_point_range'] == 'sequence<rcl_interfaces/FloatingPointRange, 1>'
