"""The one place node code imports ROS names from: real rclpy when it is there, the shim otherwise.

::

    from touch_graph.compat import Node, QoSProfile, get_message, rclpy

Real rclpy when ``import rclpy`` works and ``SOCIAL_TOUCH_SHIM`` is not ``1``; ``get_message`` and
``get_service`` then import the rosidl-generated class from ``pkg.msg``/``pkg.srv`` (PyPI's Jazzy
wheels lack rosidl_runtime_py). Otherwise :mod:`touch_graph.runtime`, :mod:`touch_graph.messages`
and :mod:`touch_graph.srv_types`, built from the same ``.msg`` and ``.srv`` files.
"""

from __future__ import annotations

import importlib
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
        import rclpy  # noqa: F401  (the probe: is real ROS 2 here?)
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

    def get_message(typename: str) -> type:
        """The generated class of ``pkg/msg/Type`` (``pkg/Type`` too)."""
        return _generated(typename, 'msg')

    def get_service(typename: str) -> type:
        """The generated class of ``pkg/srv/Type`` (with ``Request`` and ``Response``; ``pkg/Type`` too)."""
        return _generated(typename, 'srv')
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


def _generated(typename: str, kind: str) -> type:
    """The class rosidl generated for ``typename`` (``pkg/kind/Type`` or ``pkg/Type``), imported from
    ``pkg.kind`` as rosidl_runtime_py does (which PyPI's Jazzy wheels do not bring)."""
    parts = typename.split('/')
    if len(parts) == 2:
        parts.insert(1, kind)
    if len(parts) != 3 or parts[1] != kind or not all(parts):
        raise ValueError(f"'{typename}' is not a {kind} type name (pkg/{kind}/Type)")
    package, _, name = parts
    try:
        module = importlib.import_module(f'{package}.{kind}')
    except ImportError as err:
        cure = (' (build it: social-touch export-interfaces ws/src, colcon build in ws, source '
                'ws/install/setup.bash; docs/ros2.md)' if package == 'social_touch_msgs' else '')
        raise ImportError(f'{typename} needs the ROS 2 interface package {package}, which this '
                          f'Python cannot import{cure}: {err}') from err
    cls = getattr(module, name, None)
    if cls is None:
        raise ImportError(f'{package}.{kind} has no type {name} ({typename})')
    if not hasattr(cls, '__import_type_support__'):  # the source tree's stand-in, not rosidl's
        raise ImportError(f'{typename} came from {module.__file__}, not from the package rosidl generates: '
                          f'rclpy cannot send it. Build {package} (social-touch export-interfaces ws/src, '
                          'colcon build in ws, source ws/install/setup.bash; docs/ros2.md)')
    return cls


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
