"""Service types: .srv files parsed by rosbags as ROS 2 requests and responses, imported the ROS way, exported with
the interface package; CDR identical to ROS 2's for the standard services."""

import importlib
import xml.etree.ElementTree as ET

import pytest

from touch_graph import messages, srv_definitions, srv_types
from touch_graph.cli import export_interfaces as export
from touch_graph.errors import MessageError

PING = '# asks a node whether it is there\nstring text  # echoed\n---\nstring text\nuint32 count\n'


@pytest.fixture
def own_srv(tmp_path, monkeypatch):
    """This package's srv/ directory holding one service (the package itself ships none yet)."""
    srv = tmp_path / 'srv'
    srv.mkdir()
    (srv / 'Ping.srv').write_text(PING)
    monkeypatch.setattr(srv_definitions, 'share_file', lambda *parts: tmp_path.joinpath(*parts))
    messages.typestore.register(srv_types.parse_srv(PING, 'social_touch_msgs/srv/Ping'))
    return srv


def test_a_srv_is_two_messages_named_as_rosidl_names_them():
    types = srv_types.parse_srv('int64 a\nint64 b\n---\nint64 sum\n', 'example_interfaces/srv/AddTwoInts')
    assert set(types) == {'example_interfaces/srv/AddTwoInts_Request', 'example_interfaces/srv/AddTwoInts_Response'}
    empty = srv_types.parse_srv('---\n', 'std_srvs/srv/Empty')
    assert empty['std_srvs/srv/Empty_Request'][1][0][0] == 'structure_needs_at_least_one_member'
    with pytest.raises(MessageError, match='separated by one line "---"; found 2'):
        srv_types.parse_srv('int64 a\n---\n---\n', 'x/srv/Y')
    with pytest.raises(MessageError, match='cannot parse the request'):
        srv_types.parse_srv('int64[ a\n---\n', 'x/srv/Y')


def test_standard_services_have_ros2_cdr():
    get = srv_types.get_service('rcl_interfaces/srv/GetParameters')
    # string[] names = ['ab']: length 1, then the string (length 3 with its NUL)
    assert messages.serialize(get.Request(names=['ab'])) == b'\x00\x01\x00\x00\x01\x00\x00\x00\x03\x00\x00\x00ab\x00'
    trigger = srv_types.get_service('std_srvs/srv/Trigger')
    assert messages.serialize(trigger.Request()) == b'\x00\x01\x00\x00\x00'  # the placeholder byte rosidl adds
    assert repr(trigger.Response(success=True)) == "std_srvs.srv.Trigger_Response(success=True, message='')"
    with pytest.raises(MessageError, match=r"type 'std_srvs/Trigerr' \(did you mean 'std_srvs/srv/Trigger'"):
        srv_types.get_service('std_srvs/Trigerr')


def test_own_services_import_the_ros_way_and_are_exported(own_srv, tmp_path):
    module = importlib.import_module('social_touch_msgs.srv')
    assert 'Ping' in dir(module)
    from social_touch_msgs.srv import Ping
    assert Ping.__srvtype__ == 'social_touch_msgs/srv/Ping'
    assert Ping.Response(text='hi', count=2).count == 2
    with pytest.raises(AttributeError, match="has no service 'Pong'; its services: Ping"):
        module.Pong  # noqa: B018
    assert srv_types.service_definition('social_touch_msgs/Ping') == PING
    package = export.export_interfaces(tmp_path / 'ws')
    assert (package / 'srv' / 'Ping.srv').read_text() == PING
    assert '  "srv/Ping.srv"' in (package / 'CMakeLists.txt').read_text()
    assert ET.parse(package / 'package.xml').getroot().findtext('member_of_group') == 'rosidl_interface_packages'
