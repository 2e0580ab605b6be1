"""Type hashes: ours against real rosidl's (``rosidl_generator_type_description`` of ROS 2 Jazzy).

Needs a Python with ROS 2 Jazzy's rosidl generators (``SOCIAL_TOUCH_ROS2_PYTHON``, as the
real-ROS 2 CI step sets it); skipped without one. Two sources of truth, both real rosidl:

- our ``.msg`` and ``.srv`` files, converted to IDL by ``rosidl_adapter`` and hashed by
  ``rosidl_generator_type_description`` in that Python;
- the ``.json`` type descriptions the ``ros-jazzy-*`` wheels install for the standard types
  (``share/<pkg>/{msg,srv}/*.json``), every one our type store knows.
"""

from __future__ import annotations

import json
import os
import subprocess
import textwrap

import pytest

from touch_graph import type_description
from touch_graph.messages import interface_names, typestore
from touch_graph.paths import INTERFACE_PACKAGE, share_file
from touch_graph.srv_types import service_names

ROS2_PYTHON = os.environ.get('SOCIAL_TOUCH_ROS2_PYTHON', '')
needs_ros2 = pytest.mark.skipif(not ROS2_PYTHON, reason='SOCIAL_TOUCH_ROS2_PYTHON (a ROS 2 Jazzy Python) is not set')

#: Run in the ROS 2 Python: IDL from our .msg/.srv, rosidl's hashes of them, and the installed standard ones.
_ROSIDL_SCRIPT = textwrap.dedent('''
    import glob, json, pathlib, sys, tempfile
    from rosidl_adapter.msg import convert_msg_to_idl
    from rosidl_adapter.srv import convert_srv_to_idl
    from rosidl_generator_type_description import generate_type_hash
    pkg, pkg_dir = sys.argv[1], pathlib.Path(sys.argv[2])
    share = pathlib.Path(sys.prefix) / 'share'
    out = pathlib.Path(tempfile.mkdtemp())
    tuples = []
    for kind, convert in (('msg', convert_msg_to_idl), ('srv', convert_srv_to_idl)):
        for f in sorted((pkg_dir / kind).glob('*.' + kind)):
            idl = convert(pkg_dir, pkg, pathlib.Path(kind) / f.name, out / 'idl')
            tuples.append(f"{out / 'idl'}:{idl.relative_to(out / 'idl')}")
    args = out / 'args.json'
    includes = [f'{p.name}:{p}' for p in share.iterdir() if p.is_dir()]
    args.write_text(json.dumps({'package_name': pkg, 'output_dir': str(out / 'json'), 'idl_tuples': tuples,
                                'include_paths': includes}))
    hashes = {}
    for path in generate_type_hash(str(args)):
        for h in json.loads(pathlib.Path(path).read_text())['type_hashes']:
            hashes[h['type_name']] = h['hash_string']
    standard = {}
    for path in glob.glob(str(share / '*' / 'msg' / '*.json')) + glob.glob(str(share / '*' / 'srv' / '*.json')):
        for h in json.loads(pathlib.Path(path).read_text())['type_hashes']:
            standard[h['type_name']] = h['hash_string']
    print(json.dumps({'ours': hashes, 'standard': standard}))
''')


@pytest.fixture(scope='module')
def rosidl_hashes() -> dict[str, dict[str, str]]:
    if not ROS2_PYTHON:
        pytest.skip('SOCIAL_TOUCH_ROS2_PYTHON is not set')
    package_dir = share_file('msg').parent
    done = subprocess.run([ROS2_PYTHON, '-c', _ROSIDL_SCRIPT, INTERFACE_PACKAGE, str(package_dir)],
                          capture_output=True, text=True, timeout=300, check=False)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def _mismatches(expected: dict[str, str]) -> list[str]:
    return [f'{name}: ours {type_description.type_hash(name)}, rosidl {value}'
            for name, value in sorted(expected.items()) if type_description.type_hash(name) != value]


@needs_ros2
@pytest.mark.ros2
def test_every_type_of_ours_hashes_as_rosidl_does(rosidl_hashes: dict[str, dict[str, str]]) -> None:
    ours = rosidl_hashes['ours']
    expected_names = set(interface_names()) | set(service_names())
    assert expected_names <= set(ours), sorted(expected_names - set(ours))
    assert _mismatches(ours) == []  # messages, services, their _Request/_Response/_Event, referenced types


@needs_ros2
@pytest.mark.ros2
def test_every_standard_type_we_know_hashes_as_rosidl_does(rosidl_hashes: dict[str, dict[str, str]]) -> None:
    standard = rosidl_hashes['standard']
    known = {n: h for n, h in standard.items()
             if n in typestore.fielddefs or f'{n}_Request' in typestore.fielddefs}
    # the ones the runtime announces on every participant, and the services every node serves
    for name in ('rmw_dds_common/msg/ParticipantEntitiesInfo', 'rcl_interfaces/msg/Log',
                 'rcl_interfaces/srv/GetParameters', 'std_msgs/msg/Char', 'std_srvs/srv/Trigger'):
        assert name in known, name
    assert len(known) > 100
    assert _mismatches(known) == []


def test_char_is_hashed_as_uint8() -> None:
    """rosidl maps a .msg ``char`` to IDL ``uint8`` (std_msgs/msg/Char.json: type_id 3)."""
    field = type_description.type_description('std_msgs/msg/Char')['type_description']['fields'][0]
    assert field['type']['type_id'] == type_description.FIELD_TYPE_IDS['uint8']


def test_a_service_is_described_with_its_three_messages() -> None:
    described = type_description.type_description('std_srvs/srv/Trigger')
    assert [f['name'] for f in described['type_description']['fields']] == [
        'request_message', 'response_message', 'event_message']
    names = [t['type_name'] for t in described['referenced_type_descriptions']]
    assert names == sorted(names)
    assert 'service_msgs/msg/ServiceEventInfo' in names and 'std_srvs/srv/Trigger_Event' in names
