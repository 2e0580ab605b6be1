"""Every message type of ours, and the standard ones our nodes publish, from one backend to the other.

::

    python test/ros2_cross_types.py --backend rclpy --peer ours     # (and the other way, at once)

A process on ``--backend`` (real rclpy, or our runtime with ``SOCIAL_TOUCH_SHIM=1``) publishes a
known message of every type of :data:`TYPES` (:func:`sample`: every field set, away from its
default, integers at the ends of their ranges, non-ASCII strings, arrays and sequences full) on
``/cross/<backend>/<pkg>/<Name>`` (reliable, transient local: a peer that joins later gets it),
subscribes to the peer's, and once it has one of each (or after ``--timeout`` wall seconds)
writes one line ``cross-received {type: the message as plain data}``; it stays on the graph
until its stdin ends, so the peer gets ours however late it is.
"""

from __future__ import annotations

import argparse
import array
import json
import os
import sys
import threading
import time
from typing import Any

#: The standard types our nodes publish (diagnostics, tf, the behaviour's strings and points, and the runtime's
#: /rosout and /parameter_events).
STANDARD = ('diagnostic_msgs/msg/DiagnosticArray', 'tf2_msgs/msg/TFMessage', 'std_msgs/msg/String',
            'geometry_msgs/msg/PointStamped', 'rcl_interfaces/msg/Log', 'rcl_interfaces/msg/ParameterEvent')
REPORT = 'cross-received '
#: Elements of a sample's unbounded sequences.
SEQUENCE_LENGTH = 3


def types() -> list[str]:
    from touch_graph.messages import interface_names
    return [*interface_names(), *STANDARD]


# ---------------------------------------------------------------------------------------------- known values
def _scalar(base: str, k: int, bound: int = 0, item: int | None = None) -> Any:
    """A value of ``base`` that differs from its default, at an end of its range for integers (``k``: the index;
    ``item``: the index in an array, whose bools alternate)."""
    if base == 'bool':
        return True if item is None else item % 2 == 0
    if base in ('byte', 'char', 'uint8'):
        return 255 - k % 200
    if base.startswith('uint'):
        return 2 ** int(base[4:]) - 1 - k
    if base.startswith('int'):
        return -2 ** (int(base[3:]) - 1) + k
    if base == 'float32':
        return (k + 1) * -0.375  # exact in float32
    if base == 'float64':
        return (k + 1) / 3.0
    if base == 'string':
        text = f'é{k} ünï ✓'
        return text[:bound] if bound else text
    raise ValueError(f'no sample for {base}')


def sample(typename: str, seed: int = 1) -> dict[str, Any]:
    """The known message of ``typename`` as plain data (dict, list, int, float, str, bool)."""
    from rosbags.typesys.base import Nodetype

    from touch_graph.messages import typestore
    out: dict[str, Any] = {}
    for index, (name, (kind, detail)) in enumerate(typestore.fielddefs[typename][1]):
        k = seed + index
        if kind == Nodetype.BASE:
            out[name] = _scalar(detail[0], k, detail[1])
        elif kind == Nodetype.NAME:
            out[name] = sample(detail, k + 1)
        else:
            (sub_kind, sub_detail), size = detail
            n = size if kind == Nodetype.ARRAY else (min(size, SEQUENCE_LENGTH) if size else SEQUENCE_LENGTH)
            if sub_kind == Nodetype.NAME:
                out[name] = [sample(sub_detail, k + 1 + i) for i in range(n)]
            else:
                out[name] = [_scalar(sub_detail[0], k + i, sub_detail[1], i) for i in range(n)]
    return out


# ---------------------------------------------------------------------------------------------- either backend
def build(typename: str, plain: dict[str, Any]) -> Any:
    """The message of ``plain`` on this process's backend."""
    from touch_graph import compat
    if not compat.USING_ROS:
        from touch_graph.messages import from_dict
        return from_dict(typename, plain)
    from rosbags.typesys.base import Nodetype

    from touch_graph.messages import typestore
    msg = compat.get_message(typename)()
    for name, (kind, detail) in typestore.fielddefs[typename][1]:
        value = plain[name]
        if kind == Nodetype.BASE:
            value = bytes([value]) if detail[0] == 'byte' else value
        elif kind == Nodetype.NAME:
            value = build(detail, value)
        else:
            (sub_kind, sub_detail), _ = detail
            if sub_kind == Nodetype.NAME:
                value = [build(sub_detail, item) for item in value]
            elif sub_detail[0] == 'byte':
                value = [bytes([item]) for item in value]
        setattr(msg, name, value)
    return msg


def to_plain(value: Any) -> Any:
    """A message of either backend (and its fields) as plain data, for comparison."""
    if hasattr(value, 'get_fields_and_field_types'):
        return {name: to_plain(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if hasattr(value, 'tolist'):  # numpy arrays and scalars
        return to_plain(value.tolist())
    if isinstance(value, (list, tuple, array.array)):
        return [to_plain(item) for item in value]
    if isinstance(value, bytes):  # rclpy's byte: bytes of length 1
        return value[0] if len(value) == 1 else list(value)
    return value


# ---------------------------------------------------------------------------------------------- the process
def run(backend: str, peer: str, timeout: float) -> int:
    from touch_graph import compat
    if backend == 'rclpy':
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        rclpy.init(args=[])
        kwargs: dict[str, Any] = {}
        context = None
    else:
        from touch_graph.runtime import Context, SingleThreadedExecutor
        context = Context(network=True)
        context.init([])
        kwargs = {'context': context}
    node = compat.Node(f'cross_{backend}', **kwargs)
    executor = SingleThreadedExecutor(**kwargs)
    executor.add_node(node)
    qos = compat.QoSProfile(depth=1)
    qos = compat.QoSProfile(depth=1, reliability=type(qos.reliability).RELIABLE,
                            durability=type(qos.durability).TRANSIENT_LOCAL)
    received: dict[str, Any] = {}
    keep = []
    for typename in types():
        cls = compat.get_message(typename)
        publisher = node.create_publisher(cls, f'/cross/{backend}/{typename.replace("/msg/", "/")}', qos)
        publisher.publish(build(typename, sample(typename)))
        keep.append(publisher)

        def store(msg: Any, typename: str = typename) -> None:
            received[typename] = to_plain(msg)
        keep.append(node.create_subscription(cls, f'/cross/{peer}/{typename.replace("/msg/", "/")}', store, qos))
    done = threading.Event()
    threading.Thread(target=lambda: (sys.stdin.read(), done.set()), daemon=True).start()
    deadline = time.monotonic() + timeout
    reported = False
    while not done.is_set():
        executor.spin_once(timeout_sec=0.05)
        if not reported and (len(received) == len(keep) // 2 or time.monotonic() > deadline):
            print(REPORT + json.dumps(received), flush=True)
            reported = True
    node.destroy_node()
    if context is None:
        rclpy.shutdown()
    else:
        context.shutdown()
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--backend', choices=('ours', 'rclpy'), required=True)
    parser.add_argument('--peer', choices=('ours', 'rclpy'), required=True)
    parser.add_argument('--timeout', type=float, default=60.0)
    args = parser.parse_args(argv)
    if args.backend == 'ours':
        os.environ['SOCIAL_TOUCH_SHIM'] = '1'
    else:
        os.environ.pop('SOCIAL_TOUCH_SHIM', None)
    return run(args.backend, args.peer, args.timeout)


if __name__ == '__main__':
    sys.exit(main())
