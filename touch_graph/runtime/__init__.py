"""An in-process ROS 2 graph with rclpy's names (the shim).

Node code should not import this package directly but :mod:`touch_graph.compat`, which
hands out real rclpy when it is importable and this shim otherwise. The module-level
functions mirror rclpy's::

    from touch_graph.compat import rclpy
    rclpy.init()
    node = MyNode()
    rclpy.spin(node)
    rclpy.shutdown()
"""

from __future__ import annotations

from .clock import Clock, ClockType, Duration, SimTimeSource, Time, WallTimeSource
from .context import Context, ExternalShutdownException, get_default_context, reset_default_context
from .endpoints import Publisher, Subscription, Timer
from .executors import Executor, MultiThreadedExecutor, SingleThreadedExecutor
from .logging import LoggingSeverity, get_logger
from .node import Node
from .parameters import (
    FloatingPointRange,
    IntegerRange,
    InvalidParameterValueException,
    Parameter,
    ParameterDescriptor,
    ParameterNotDeclaredException,
    ParameterType,
    SetParametersResult,
)
from .qos import (
    DurabilityPolicy,
    HistoryPolicy,
    QoSProfile,
    ReliabilityPolicy,
    qos_profile_parameter_events,
    qos_profile_sensor_data,
    qos_profile_services_default,
    qos_profile_system_default,
)
from .services import Client, Service
from .task import Future

__all__ = [
    'Client', 'Clock', 'ClockType', 'Context', 'DurabilityPolicy', 'Duration', 'Executor',
    'ExternalShutdownException', 'FloatingPointRange', 'Future', 'HistoryPolicy', 'IntegerRange',
    'InvalidParameterValueException', 'LoggingSeverity',
    'MultiThreadedExecutor', 'Node', 'Parameter', 'ParameterDescriptor', 'ParameterNotDeclaredException',
    'ParameterType', 'Publisher', 'QoSProfile', 'ReliabilityPolicy', 'Service', 'SetParametersResult',
    'SimTimeSource', 'SingleThreadedExecutor', 'Subscription', 'Time', 'Timer', 'WallTimeSource', 'create_node',
    'get_default_context', 'get_global_executor', 'get_logger', 'init', 'ok', 'qos_profile_parameter_events',
    'qos_profile_sensor_data', 'qos_profile_services_default', 'qos_profile_system_default',
    'reset_default_context', 'shutdown', 'spin', 'spin_once', 'spin_until_future_complete', 'try_shutdown',
]

_global_executor: Executor | None = None


def init(*, args: list[str] | None = None, context: Context | None = None, **_ignored: object) -> None:
    """Initialise ``context`` (default: the process-wide one) with optional ``--ros-args``."""
    (context or get_default_context()).init(args)


def ok(*, context: Context | None = None) -> bool:
    return (context or get_default_context()).ok()


def shutdown(*, context: Context | None = None) -> None:
    global _global_executor
    ctx = context or get_default_context()
    ctx.shutdown()
    if _global_executor is not None and _global_executor.context is ctx:
        _global_executor.shutdown()
        _global_executor = None


def try_shutdown(*, context: Context | None = None) -> None:
    ctx = context or get_default_context()
    if ctx.ok():
        shutdown(context=ctx)


def create_node(node_name: str, **kwargs: object) -> Node:
    return Node(node_name, **kwargs)


def get_global_executor() -> Executor:
    global _global_executor
    if _global_executor is None or not _global_executor.context.ok():
        _global_executor = SingleThreadedExecutor(context=get_default_context())
    return _global_executor


def spin(node: Node, executor: Executor | None = None) -> None:
    """Spin ``node`` until the context shuts down (Ctrl-C raises KeyboardInterrupt, as in rclpy)."""
    executor = executor or get_global_executor()
    executor.add_node(node)
    try:
        executor.spin()
    finally:
        executor.remove_node(node)


def spin_once(node: Node, *, executor: Executor | None = None, timeout_sec: float | None = None) -> None:
    executor = executor or get_global_executor()
    executor.add_node(node)
    executor.spin_once(timeout_sec)


def spin_until_future_complete(node: Node, future: Future, executor: Executor | None = None,
                               timeout_sec: float | None = None) -> None:
    """Spin ``node`` until ``future`` is done or ``timeout_sec`` (wall time) passes, as rclpy's."""
    executor = executor or get_global_executor()
    executor.add_node(node)
    executor.spin_until_future_complete(future, timeout_sec)
