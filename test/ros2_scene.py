"""Run the shipped demo scene with every node on one backend and count what each topic carries.

::

    python test/ros2_scene.py --backend ours  --duration 8     # social_touch's runtime
    python test/ros2_scene.py --backend rclpy --duration 8     # real rclpy (a sourced ROS 2 with
                                                               # social_touch_msgs built: docs/ros2.md)

The scene is ``examples/touch_behaviour/launch/behaviour.launch.yaml`` (the demo: the three
drivers on their virtual devices, bearsim:// patchsim:// skinsim://, the recognisers,
bear_sensor_frames, touch_state, touch_monitor, and the example behaviour node) with the web view
and the Foxglove server on (any free ports). Its nodes are built in one process from the launch
file's node entries, as rclpy component containers build them, on the wall clock; a counting node
in the same process subscribes to every topic the scene's nodes publish (with each publisher's
reliability and durability) before anything spins. Prints (``--out``: writes) one JSON object:
the backend, the nodes, the messages per topic, each driver's counters (frames published...), and
the callbacks that raised (our runtime counts them and goes on; real rclpy's spin ends at the
first, which is then the ``error``).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import traceback
import types
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / 'examples' / 'touch_behaviour' / 'launch' / 'behaviour.launch.yaml'
SCENE_ARGUMENTS = {'view': 'true', 'foxglove': 'true', 'view_port': '0', 'foxglove_port': '0'}
#: Topics of the implementation, not of the scene (log lines, parameter declarations).
NOT_COUNTED = ('/rosout', '/parameter_events')


def _rclpy_runtime() -> types.SimpleNamespace:
    """What LaunchRunner needs of a runtime, from real rclpy; the context is rclpy's default one, which
    a node with rclpy's plain ``__init__(self)`` (the example behaviour node) joins."""
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.node import Node
    from rclpy.parameter import Parameter
    from rclpy.utilities import get_default_context
    return types.SimpleNamespace(Context=get_default_context, SingleThreadedExecutor=SingleThreadedExecutor,
                                 Node=Node, Parameter=Parameter)


class _Counter:
    """A subscription callback counting ``topic``'s messages into ``counts`` (one argument: the message)."""

    def __init__(self, counts: dict[str, int], topic: str) -> None:
        self.counts, self.topic = counts, topic

    def __call__(self, msg: object) -> None:
        self.counts[self.topic] += 1


def run_scene(backend: str, duration: float) -> dict:
    """Start the scene on ``backend`` ('ours' or 'rclpy'), spin ``duration`` wall seconds, count."""
    from touch_graph import compat
    if (backend == 'rclpy') != compat.USING_ROS:
        raise SystemExit(f'backend {backend}: touch_graph.compat chose {"rclpy" if compat.USING_ROS else "ours"} '
                         '(SOCIAL_TOUCH_SHIM=1 or an importable rclpy decides)')
    from touch_behaviour.node import TouchBehaviour

    from touch_graph.launch import LaunchRunner, entry_point_registry, evaluate_launch

    plan = evaluate_launch(SCENE, SCENE_ARGUMENTS)
    registry = dict(entry_point_registry())
    registry.setdefault(('touch_behaviour', 'touch_behaviour'), TouchBehaviour)
    if backend == 'rclpy':
        # Its launch entry gives it no arguments; on rclpy it joins the default context, the runner's.
        registry[('touch_behaviour', 'touch_behaviour')] = type(
            'TouchBehaviour', (TouchBehaviour,), {'__init__': lambda self, **_launch: TouchBehaviour.__init__(self)})
        runner = LaunchRunner(plan.nodes, registry=registry, runtime=_rclpy_runtime())
        from rclpy.node import Node as CounterNode
    else:
        runner = LaunchRunner(plan.nodes, registry=registry, network=False)
        from touch_graph.runtime import Node as CounterNode
    counts: dict[str, int] = {}
    error = None
    started = time.monotonic()
    runner.start()
    try:
        counter = CounterNode('scene_counter', context=runner.context)
        for node in runner.nodes:
            for pub in node.publishers:
                topic = pub.topic_name
                if topic in counts or topic in NOT_COUNTED:
                    continue
                counts[topic] = 0
                qos = compat.QoSProfile(depth=1000, reliability=pub.qos_profile.reliability,
                                        durability=pub.qos_profile.durability)
                counter.create_subscription(pub.msg_type, topic, _Counter(counts, topic), qos)
        runner.executor.add_node(counter)
        ready_s = time.monotonic() - started
        end = time.monotonic() + duration
        while time.monotonic() < end:
            try:
                runner.executor.spin_once(timeout_sec=0.05)
            except Exception:  # real rclpy: a callback raised; its spin ends here
                error = traceback.format_exc()
                break
        names = sorted(node.get_fully_qualified_name() for node in runner.nodes)
        drivers = {node.get_fully_qualified_name(): node.counters()
                   for node in runner.nodes if hasattr(node, 'counters')}
        callback_errors = getattr(runner.context, 'callback_errors', None)
        counter.destroy_node()
    finally:
        runner.shutdown()
    return {'backend': backend, 'duration_s': duration, 'start_s': round(ready_s, 2), 'nodes': names,
            'counts': dict(sorted(counts.items())), 'drivers': drivers, 'callback_errors': callback_errors,
            'error': error}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--backend', choices=('ours', 'rclpy'), required=True)
    parser.add_argument('--duration', type=float, default=8.0, help='wall seconds to spin (default 8)')
    parser.add_argument('--out', help='write the JSON report to this file (the monitor prints to stdout too)')
    args = parser.parse_args(argv)
    if args.backend == 'ours':
        os.environ['SOCIAL_TOUCH_SHIM'] = '1'
    else:
        os.environ.pop('SOCIAL_TOUCH_SHIM', None)
    sys.path[:0] = [str(ROOT), str(ROOT / 'examples' / 'touch_behaviour')]
    text = json.dumps(run_scene(args.backend, args.duration), indent=1)
    if args.out:
        Path(args.out).write_text(text + '\n', encoding='utf-8')
    else:
        print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
