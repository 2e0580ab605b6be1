"""The one place node code imports ROS names from: real rclpy when it is there, the shim otherwise.

::

    from touch_graph.compat import Node, QoSProfile, get_message, rclpy

On a ROS 2 machine (``import rclpy`` works and ``SOCIAL_TOUCH_SHIM`` is not ``1``) these are
rclpy's own, and ``get_message('social_touch_msgs/msg/SkinFrame')`` (``get_service('std_srvs/srv/Trigger')``)
returns the class generated from the interface package ``social-touch export-interfaces``
writes. Everywhere else they come from :mod:`touch_graph.runtime`, :mod:`touch_graph.messages`
and :mod:`touch_graph.srv_types`, built from the same ``.msg`` and ``.srv`` files.
"""

from __future__ import annotations

import os
from typing import Any

__all__ = [
    'USING_ROS', 'DurabilityPolicy', 'Duration', 'FloatingPointRange', 'IntegerRange', 'Node', 'Parameter',
    'ParameterDescriptor', 'QoSProfile', 'SetParametersResult', 'Time', 'get_message', 'get_service', 'latched_qos',
    'qos_profile_sensor_data', 'rclpy',
    'sensor_data_qos', 'stamp_now',
]


def _want_ros() -> bool:
    if os.environ.get('SOCIAL_TOUCH_SHIM') == '1':
        return False
    try:
        import rclpy  # noqa: F401
    except ImportError:
        return False
    return True


USING_ROS = _want_ros()

if USING_ROS:  # pragma: no cover - exercised on a ROS 2 machine
    import rclpy
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor, SetParametersResult
    from rclpy.duration import Duration
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
    from rclpy.time import Time
    from rosidl_runtime_py.utilities import get_message as _ros_get_message
    from rosidl_runtime_py.utilities import get_service as _ros_get_service

    def get_message(typename: str) -> type:
        """The generated class of ``pkg/msg/Type``."""
        return _ros_get_message(typename if typename.count('/') == 2 else typename.replace('/', '/msg/'))

    def get_service(typename: str) -> type:
        """The generated class of ``pkg/srv/Type`` (with ``Request`` and ``Response``)."""
        return _ros_get_service(typename if typename.count('/') == 2 else typename.replace('/', '/srv/'))
else:
    from . import runtime as rclpy
    from .messages import get_message
    from .runtime import (
        DurabilityPolicy,
        Duration,
        FloatingPointRange,
        IntegerRange,
        Node,
        Parameter,
        ParameterDescriptor,
        QoSProfile,
        SetParametersResult,
        Time,
        qos_profile_sensor_data,
    )
    from .srv_types import get_service


def sensor_data_qos(depth: int = 5) -> Any:
    """rclpy's ``qos_profile_sensor_data`` (best effort, keep last, volatile) with queue ``depth``.

    Sensor frames use it on both ends: a frame that comes too late is worth less than the
    next one, and a best-effort subscription also matches a reliable publisher.
    """
    return QoSProfile(depth=depth, reliability=qos_profile_sensor_data.reliability)


def latched_qos(depth: int = 1) -> Any:
    """Reliable, TRANSIENT_LOCAL, keep last ``depth``: a late subscriber gets the last ``depth`` messages.

    What ROS 2's static transform broadcaster uses for ``/tf_static`` (depth 1) and what a
    subscriber to a latched topic must ask for to receive them.
    """
    return QoSProfile(depth=depth, durability=DurabilityPolicy.TRANSIENT_LOCAL)


def stamp_now(node: Any) -> Any:
    """A ``builtin_interfaces/Time`` of the node's clock, for a header stamp."""
    return node.get_clock().now().to_msg()
