"""Run the shipped demo scene with every node on one backend and count what each topic carries.

::

    python test/ros2_scene.py --backend ours  --duration 8     # social_touch's runtime
    python test/ros2_scene.py --backend rclpy --duration 8     # real rclpy (a sourced ROS 2 with
                                                               # social_touch_msgs built: docs/ros2.md)

The scene is ``examples/touch_behaviour/launch/behaviour.launch.yaml`` (the demo: the three
drivers on their virtual devices, bearsim:// patchsim:// skinsim://, the recognisers,
bear_sensor_frames, touch_state, touch_monitor, and the example behaviour node) with the web view
and the Foxglove server on (any free ports). As a robot deploys it (``ros2 launch``, or
``social-touch launch --processes``), every node runs in a process of its own, built from its
launch entry and spun by its own executor on the wall clock; they meet on the DDS domain
(``ROS_DOMAIN_ID``). This process is the counter: once every node is up, it subscribes to every
topic the nodes publish (with each publisher's reliability and durability), waits until each
subscription has matched all of that topic's publishers, then counts for ``--duration`` wall
seconds; the node processes mark the same window on their own counters (frames published...).

Prints (``--out``: writes) one JSON object: the backend, the nodes, the messages per topic in the
window (a latched topic: every message received), each driver's counters over the window, and the
callbacks that raised (our runtime counts them and goes on; real rclpy's spin ends at the first,
which is then the ``error``).

``--node N`` runs the N-th node of the scene alone (what this script starts per node): it writes
one JSON line when the node is up (its name and publishers), snapshots its counters on each
``mark`` line of its stdin, stops on ``stop`` or the end of its stdin, and writes its report.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import queue
import subprocess
import sys
import threading
import time
import traceback
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCENE = ROOT / 'examples' / 'touch_behaviour' / 'launch' / 'behaviour.launch.yaml'
SCENE_ARGUMENTS = {'view': 'true', 'foxglove': 'true', 'view_port': '0', 'foxglove_port': '0'}
#: Topics of the implementation, not of the scene (log lines, parameter declarations).
NOT_COUNTED = ('/rosout', '/parameter_events')
#: Wall seconds for every node process to come up, and for the counter to match every publisher.
START_TIMEOUT_S = 120.0
MATCH_TIMEOUT_S = 60.0
#: Wall seconds the counter spins after matching, before the window (messages that arrived while it matched).
SETTLE_S = 1.0
#: The start of a node process's report lines on its stdout.
REPORT = 'scene-report '


def _check_backend(backend: str) -> None:
    from touch_graph import compat
    if (backend == 'rclpy') != compat.USING_ROS:
        raise SystemExit(f'backend {backend}: touch_graph.compat chose {"rclpy" if compat.USING_ROS else "ours"} '
                         '(SOCIAL_TOUCH_SHIM=1 or an importable rclpy decides)')


def _plan_nodes() -> list:
    from touch_graph.launch import evaluate_launch
    return evaluate_launch(SCENE, SCENE_ARGUMENTS).nodes


def _type_name(cls: type) -> str:
    """``pkg/msg/Name`` of a message class (rosidl's or ours)."""
    return f'{cls.__module__.split(".")[0]}/msg/{cls.__name__}'


# ---------------------------------------------------------------------------------------------- one node
def _stdin_commands(marks: list[threading.Event], stop: threading.Event) -> None:
    """Read ``mark`` and ``stop`` lines from the counter process (end of input: stop)."""
    for line in sys.stdin:
        command = line.strip()
        if command == 'mark':
            next(event for event in marks if not event.is_set()).set()
        elif command == 'stop':
            break
    stop.set()


def run_node(backend: str, index: int) -> int:
    """Run the scene's ``index``-th node in this process until told to stop (see the module doc)."""
    _check_backend(backend)
    from touch_behaviour.node import TouchBehaviour

    from touch_graph.launch import LaunchRunner, entry_point_registry
    from touch_graph.launch.runner import rclpy_runtime

    spec = _plan_nodes()[index]
    registry = dict(entry_point_registry())
    registry.setdefault(('touch_behaviour', 'touch_behaviour'), TouchBehaviour)
    if backend == 'rclpy':
        # Its launch entry gives it no arguments; on rclpy it joins the default context, the runner's.
        registry[('touch_behaviour', 'touch_behaviour')] = type(
            'TouchBehaviour', (TouchBehaviour,), {'__init__': lambda self, **_launch: TouchBehaviour.__init__(self)})
        runner = LaunchRunner([spec], registry=registry, runtime=rclpy_runtime())
    else:
        runner = LaunchRunner([spec], registry=registry, network=True)
    marks, stop = [threading.Event(), threading.Event()], threading.Event()
    snapshots: list[dict] = []
    error = None
    runner.start()
    try:
        node = runner.nodes[0]
        publishers = sorted({(pub.topic_name, _type_name(pub.msg_type), pub.qos_profile.reliability.name,
                              pub.qos_profile.durability.name) for pub in node.publishers
                             if pub.topic_name not in NOT_COUNTED})
        print(REPORT + json.dumps({'node': node.get_fully_qualified_name(), 'publishers': publishers}), flush=True)
        threading.Thread(target=_stdin_commands, args=(marks, stop), daemon=True).start()
        while not stop.is_set():
            try:
                runner.executor.spin_once(timeout_sec=0.05)
            except Exception:  # real rclpy: a callback raised; its spin ends here
                error = traceback.format_exc()
                break
            if len(snapshots) < sum(event.is_set() for event in marks):
                snapshots.append(node.counters() if hasattr(node, 'counters') else {})
        stop.wait()  # after an error: still answer the counter at its end
        callback_errors = getattr(runner.context, 'callback_errors', None)
    finally:
        runner.shutdown()
    window = None
    if len(snapshots) == 2 and hasattr(node, 'counters'):
        window = {key: snapshots[1][key] - snapshots[0][key] for key in snapshots[0]}
    print(REPORT + json.dumps({'driver': window, 'callback_errors': callback_errors, 'error': error}), flush=True)
    return 0


# ---------------------------------------------------------------------------------------------- the counter
class _Counter:
    """A subscription callback counting ``topic``'s messages into ``counts`` (one argument: the message)."""

    def __init__(self, counts: dict[str, int], topic: str) -> None:
        self.counts, self.topic = counts, topic

    def __call__(self, msg: object) -> None:
        self.counts[self.topic] += 1


class _NodeProcess:
    """A node process and the report lines it writes (its other output, the monitor's, goes to stderr)."""

    def __init__(self, backend: str, index: int) -> None:
        self.index = index
        self.proc = subprocess.Popen([sys.executable, __file__, '--backend', backend, '--node', str(index)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT)
        self.reports: queue.Queue[str] = queue.Queue()
        threading.Thread(target=self._relay, daemon=True).start()

    def _relay(self) -> None:
        for line in self.proc.stdout:
            if line.startswith(REPORT):
                self.reports.put(line[len(REPORT):])
            else:
                sys.stderr.write(line)
        self.reports.put('')

    def tell(self, *commands: str) -> None:
        with contextlib.suppress(OSError):  # it ended: its report says why
            self.proc.stdin.write(''.join(f'{command}\n' for command in commands))
            self.proc.stdin.flush()

    def report(self, deadline: float) -> dict:
        """Its next report (it is up, or its counts at the end), or an error naming it."""
        try:
            line = self.reports.get(timeout=max(0.0, deadline - time.monotonic()))
        except queue.Empty:
            line = ''
        if not line:
            raise RuntimeError(f'node process {self.index} ({" ".join(self.proc.args[-4:])}) gave no report '
                               f'(exit code {self.proc.poll()})')
        return json.loads(line)


def run_scene(backend: str, duration: float) -> dict:
    """Start every node of the scene in its own process on ``backend``, count ``duration`` wall seconds."""
    _check_backend(backend)
    from touch_graph import compat
    specs = _plan_nodes()
    started = time.monotonic()
    procs = [_NodeProcess(backend, index) for index in range(len(specs))]
    counts: dict[str, int] = {}
    latched: set[str] = set()
    ups: list[dict] = []
    reports: list[dict] = []
    error = None
    try:
        deadline = time.monotonic() + START_TIMEOUT_S
        ups = [proc.report(deadline) for proc in procs]
        if backend == 'rclpy':
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
            rclpy.init()
            context = None
        else:
            from touch_graph.runtime import Context, SingleThreadedExecutor
            context = Context(network=True)
            context.init()
        kwargs = {} if context is None else {'context': context}
        counter = compat.Node('scene_counter', **kwargs)
        executor = SingleThreadedExecutor(**kwargs)
        executor.add_node(counter)
        policies = compat.QoSProfile(depth=1)
        publishers: dict[str, int] = {}
        for up in ups:
            for topic, typename, reliability, durability in up['publishers']:
                publishers[topic] = publishers.get(topic, 0) + 1
                if topic in counts:
                    continue
                counts[topic] = 0
                if durability == 'TRANSIENT_LOCAL':
                    latched.add(topic)
                qos = compat.QoSProfile(depth=1000, reliability=type(policies.reliability)[reliability],
                                        durability=type(policies.durability)[durability])
                counter.create_subscription(compat.get_message(typename), topic, _Counter(counts, topic), qos)
        deadline = time.monotonic() + MATCH_TIMEOUT_S
        while any(counter.count_publishers(topic) < n for topic, n in publishers.items()):
            if time.monotonic() > deadline:
                raise RuntimeError('the counter did not match every publisher: ' + ', '.join(
                    f'{topic} {counter.count_publishers(topic)} of {n}' for topic, n in publishers.items()))
            executor.spin_once(timeout_sec=0.05)
        ready_s = time.monotonic() - started
        settled = time.monotonic() + SETTLE_S
        while time.monotonic() < settled:  # take what arrived while matching, before the window
            executor.spin_once(timeout_sec=0.05)
        # The window: the same wall seconds for the counter and the node processes' counters.
        for proc in procs:
            proc.tell('mark')
        for topic in counts:
            if topic not in latched:  # a latched message comes once per subscription, whenever it matched
                counts[topic] = 0
        end = time.monotonic() + duration
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        for proc in procs:
            proc.tell('mark', 'stop')
        counter.destroy_node()
        if context is None:
            rclpy.shutdown()
        else:
            context.shutdown()
        deadline = time.monotonic() + START_TIMEOUT_S
        reports = [proc.report(deadline) for proc in procs]
    except Exception:
        error = traceback.format_exc()
        ready_s = None
    finally:
        for proc in procs:
            with contextlib.suppress(OSError):
                proc.proc.stdin.close()  # the end of its input: it stops
        for proc in procs:
            try:
                proc.proc.wait(30)
            except subprocess.TimeoutExpired:
                proc.proc.kill()
                proc.proc.wait()
    names = sorted(up['node'] for up in ups) if error is None else []
    drivers = {up['node']: report['driver'] for up, report in zip(ups, reports, strict=False)
               if report['driver'] is not None}
    errors = [report['callback_errors'] for report in reports]
    error = error or next((report['error'] for report in reports if report['error']), None)
    return {'backend': backend, 'duration_s': duration, 'start_s': None if ready_s is None else round(ready_s, 2),
            'nodes': names, 'counts': dict(sorted(counts.items())), 'drivers': drivers,
            'callback_errors': None if None in errors else sum(errors), 'error': error}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--backend', choices=('ours', 'rclpy'), required=True)
    parser.add_argument('--duration', type=float, default=8.0, help='wall seconds to count (default 8)')
    parser.add_argument('--out', help='write the JSON report to this file (the monitor prints to stdout too)')
    parser.add_argument('--node', type=int, help='run only the N-th node of the scene (the script starts these)')
    args = parser.parse_args(argv)
    if args.backend == 'ours':
        os.environ['SOCIAL_TOUCH_SHIM'] = '1'
    else:
        os.environ.pop('SOCIAL_TOUCH_SHIM', None)
    sys.path[:0] = [str(ROOT), str(ROOT / 'examples' / 'touch_behaviour')]
    if args.node is not None:
        return run_node(args.backend, args.node)
    text = json.dumps(run_scene(args.backend, args.duration), indent=1)
    if args.out:
        Path(args.out).write_text(text + '\n', encoding='utf-8')
    else:
        print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
