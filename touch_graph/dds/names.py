"""ROS 2's names on DDS: topic prefixes and type names, as rmw_cyclonedds mangles them.

A ROS topic ``/touch/symbolic`` is the DDS topic ``rt/touch/symbolic``; a service
``/node/get_parameters`` is the pair ``rq/node/get_parametersRequest`` (requests) and
``rr/node/get_parametersReply`` (replies). A ROS type ``pkg/msg/Name`` is the DDS type
``pkg::msg::dds_::Name_``; a service's request and reply types are
``pkg::srv::dds_::Name_Request_`` and ``pkg::srv::dds_::Name_Response_``.

>>> dds_topic_name('/touch/symbolic')
'rt/touch/symbolic'
>>> ros_topic_name('rt/touch/symbolic')
'/touch/symbolic'
>>> ros_topic_name('ros_discovery_info') is None
True
>>> dds_type_name('social_touch_msgs/msg/SkinFrame')
'social_touch_msgs::msg::dds_::SkinFrame_'
>>> ros_type_name('std_msgs::msg::dds_::String_')
'std_msgs/msg/String'
>>> dds_service_topics('/bear/driver/get_parameters')
('rq/bear/driver/get_parametersRequest', 'rr/bear/driver/get_parametersReply')
>>> ros_service_name('rq/bear/driver/get_parametersRequest')
('/bear/driver/get_parameters', 'request')
>>> dds_type_name('rcl_interfaces/srv/GetParameters', part='Request')
'rcl_interfaces::srv::dds_::GetParameters_Request_'
>>> ros_type_name('rcl_interfaces::srv::dds_::GetParameters_Response_')
'rcl_interfaces/srv/GetParameters_Response'
"""

from __future__ import annotations

__all__ = [
    'REPLY_PREFIX',
    'REQUEST_PREFIX',
    'TOPIC_PREFIX',
    'dds_service_topics',
    'dds_topic_name',
    'dds_type_name',
    'ros_service_name',
    'ros_topic_name',
    'ros_type_name',
]

#: rmw's prefixes (rmw_dds_common / rmw_cyclonedds ``ros_topic_prefix`` and friends).
TOPIC_PREFIX = 'rt'
REQUEST_PREFIX = 'rq'
REPLY_PREFIX = 'rr'


def dds_topic_name(ros_name: str) -> str:
    """``/a/b`` -> ``rt/a/b`` (``ros_name`` is fully qualified, as a node resolves it)."""
    if not ros_name.startswith('/'):
        raise ValueError(f'expected a fully qualified topic name starting with /, got {ros_name!r}')
    return TOPIC_PREFIX + ros_name


def ros_topic_name(dds_name: str) -> str | None:
    """``rt/a/b`` -> ``/a/b``; None for a DDS topic that is no ROS topic (services, discovery)."""
    if dds_name.startswith(TOPIC_PREFIX + '/'):
        return dds_name[len(TOPIC_PREFIX):]
    return None


def dds_service_topics(ros_service: str) -> tuple[str, str]:
    """The request and reply DDS topics of a fully qualified service name."""
    if not ros_service.startswith('/'):
        raise ValueError(f'expected a fully qualified service name starting with /, got {ros_service!r}')
    return f'{REQUEST_PREFIX}{ros_service}Request', f'{REPLY_PREFIX}{ros_service}Reply'


def ros_service_name(dds_name: str) -> tuple[str, str] | None:
    """``rq/x/yRequest`` -> ``('/x/y', 'request')``, ``rr/x/yReply`` -> ``('/x/y', 'reply')``; else None."""
    for prefix, suffix, kind in ((REQUEST_PREFIX, 'Request', 'request'), (REPLY_PREFIX, 'Reply', 'reply')):
        if dds_name.startswith(prefix + '/') and dds_name.endswith(suffix):
            return dds_name[len(prefix):-len(suffix)], kind
    return None


def dds_type_name(ros_type: str, part: str = '') -> str:
    """``pkg/msg/T`` -> ``pkg::msg::dds_::T_``; for ``pkg/srv/T`` give ``part`` 'Request' or 'Response'."""
    pkg, kind, name = _split(ros_type)
    if part:
        name = f'{name}_{part}'
    return f'{pkg}::{kind}::dds_::{name}_'


def ros_type_name(dds_type: str) -> str | None:
    """``pkg::msg::dds_::T_`` -> ``pkg/msg/T``; None for a DDS type name that is not ROS 2's."""
    parts = dds_type.split('::')
    if len(parts) != 4 or parts[2] != 'dds_' or not parts[3].endswith('_') or len(parts[3]) < 2:
        return None
    return f'{parts[0]}/{parts[1]}/{parts[3][:-1]}'


def _split(ros_type: str) -> tuple[str, str, str]:
    parts = ros_type.split('/')
    if len(parts) != 3 or not all(parts):
        raise ValueError(f"expected a type name 'pkg/msg/Name' or 'pkg/srv/Name', got {ros_type!r}")
    return parts[0], parts[1], parts[2]
