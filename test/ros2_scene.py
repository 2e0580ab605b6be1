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

The virtual devices play their scripted people in step: the node processes start with
``SOCIAL_TOUCH_SIM_EPOCH`` far ahead (the devices send nothing), and once every node is up and
matched the counter sends them one device time zero (``epoch T`` on their stdin,
:func:`touch_sim.virtual_port.set_wall_epoch`) ``EPOCH_LEAD_S`` ahead and one end ``--duration``
seconds after it (``end T``, :func:`touch_sim.virtual_port.set_wall_end`). The window opens before
the time zero, while the graph is idle, and closes once the graph has drained: no message on any
topic but the timers' for ``QUIET_S``. So every run counts what the graph made of the same stretch
of every scene, however far behind a starved node ran, and their events compare topic by topic;
the timers' topics (status, /diagnostics) count over the wall seconds of the window.

``--drivers BACKEND`` runs the three drivers on another backend than the rest (a mixed graph),
and ``--graph-checks N`` runs ``social-touch node list``, ``topic list`` and ``topic info -v
/skin/frame`` N times each after the window and counts the runs that show every rclpy node.

Prints (``--out``: writes) one JSON object: the backend, the nodes, the messages per topic in the
window (a latched topic: every message received), each driver's counters over the window (and the
``/touch/state`` messages touch_state published in it), each recogniser's input frames over the
window (``inputs``: taken, and missed: its driver's sequence skipped them), which nodes publish each
topic, and the
callbacks that raised (our runtime counts them and goes on; real rclpy's spin ends at the first,
which is then the ``error``).

``--node N`` runs the N-th node of the scene alone (what this script starts per node): it writes
one JSON line when the node is up (its name and publishers), snapshots its counters on each
``mark`` line of its stdin, stops on ``stop`` or the end of its stdin, and writes its report.
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
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
#: Wall seconds from the counter's ``epoch`` line to the devices' time zero: every node process reads it and
#: marks the window's start before its first frame.
EPOCH_LEAD_S = 2.0
#: The devices' time zero until the counter sends one: far ahead (they send nothing).
HELD_S = 1e6
#: The graph has drained when no topic but the timers' carried a message for this many wall seconds: longer than
#: the bear recogniser's watchdog, which ends what is under way within 1.5 max_gap_s (5 s) of the last frame.
QUIET_S = 8.0
#: Wall seconds after the devices' end within which the graph must drain.
DRAIN_TIMEOUT_S = 60.0


def timed(topic: str) -> bool:
    """A topic a timer publishes (a driver's status, /diagnostics, touch_state's ``rate_hz``): it never drains."""
    return topic in ('/diagnostics', '/touch/state') or topic.endswith('/status')
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
    """Read ``epoch T``, ``end T``, ``mark`` and ``stop`` lines from the counter process (end of input: stop)."""
    from touch_sim.virtual_port import set_wall_end, set_wall_epoch
    for line in sys.stdin:
        command = line.strip()
        if command.startswith('epoch '):
            set_wall_epoch(float(command.split()[1]))
        elif command.startswith('end '):
            set_wall_end(float(command.split()[1]))
        elif command == 'mark':
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
                snapshots.append(_node_counters(node))
        stop.wait()  # after an error: still answer the counter at its end
        # The counter sends the last 'mark' and then 'stop': both may arrive during one spin, and the loop above
        # then ends before taking the last snapshot. The counts are the window's end either way.
        while len(snapshots) < sum(event.is_set() for event in marks):
            snapshots.append(_node_counters(node))
        callback_errors = getattr(runner.context, 'callback_errors', None)
        window = None
        if len(snapshots) == 2 and snapshots[0]:
            window = {key: snapshots[1][key] - snapshots[0][key] for key in snapshots[0]}
        # The counts are final here: report before the middleware's teardown, whose time is not the scene's
        # (a Fast DDS participant's deletion can take long on a busy machine; the counter kills what lingers).
        print(REPORT + json.dumps({'driver': window, 'callback_errors': callback_errors, 'error': error}), flush=True)
    finally:
        runner.shutdown()
    return 0


def _node_counters(node: object) -> dict[str, int]:
    """A driver's counters (frames published...), touch_state's ``/touch/state`` messages published, a
    recogniser's input frames (taken, and missed: sent by its driver, never handed to it), or nothing."""
    if hasattr(node, 'counters'):
        return node.counters()
    if hasattr(node, 'published'):
        return {'published': node.published}
    screen = getattr(node, 'screen', None)
    if screen is not None:
        return {'frames_admitted': screen.admitted, 'frames_missed': screen.missed}
    return {}


# ---------------------------------------------------------------------------------------------- the counter
class _Counter:
    """A subscription callback counting ``topic``'s messages into ``counts`` (one argument: the message, CDR bytes);
    with ``kept`` a list, it keeps ``(wall s, topic, CDR bytes)`` of each too (``--dump``)."""

    def __init__(self, counts: dict[str, int], topic: str, kept: list | None = None) -> None:
        self.counts, self.topic, self.kept = counts, topic, kept

    def __call__(self, msg: object) -> None:
        self.counts[self.topic] += 1
        if self.kept is not None:
            self.kept.append((time.time(), self.topic, bytes(msg)))


def plain(msg: object) -> object:
    """A message as JSON-able Python (nested dicts, lists, numbers, strings), on either backend."""
    if hasattr(msg, 'get_fields_and_field_types'):
        return {name: plain(getattr(msg, name)) for name in msg.get_fields_and_field_types()}
    if isinstance(msg, (bytes, bytearray)):
        return list(msg)
    if isinstance(msg, (str, int, float, bool)) or msg is None:
        return msg
    if hasattr(msg, 'tolist'):
        return msg.tolist()
    return [plain(item) for item in msg]


def decoded(kept: list, types: dict[str, str], backend: str) -> list:
    """``[wall s, topic, message as plain Python]`` of the kept CDR samples (after the window: no time pressure)."""
    from touch_graph import compat
    if backend == 'rclpy':
        from rclpy.serialization import deserialize_message

        def decode(data: bytes, typename: str) -> object:
            return deserialize_message(data, compat.get_message(typename))
    else:
        from touch_graph.messages import deserialize as decode
    return [[round(at, 4), topic, plain(decode(data, types[topic]))] for at, topic, data in kept]


def backend_env(backend: str, **extra: str) -> dict[str, str]:
    """This process's environment for a process on ``backend`` (SOCIAL_TOUCH_SHIM=1 for ours), plus ``extra``."""
    env = {k: v for k, v in os.environ.items() if k != 'SOCIAL_TOUCH_SHIM'}
    if backend == 'ours':
        env['SOCIAL_TOUCH_SHIM'] = '1'
    env.update(extra)
    return env


class _NodeProcess:
    """A node process and the report lines it writes (its other output, the monitor's, goes to stderr)."""

    def __init__(self, backend: str, index: int) -> None:
        self.index, self.backend = index, backend
        self.proc = subprocess.Popen([sys.executable, __file__, '--backend', backend, '--node', str(index)],
                                     stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, cwd=ROOT,
                                     env=backend_env(backend, SOCIAL_TOUCH_SIM_EPOCH=repr(time.time() + HELD_S)))
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


def _drain(executor: object, counts: dict[str, int]) -> float | None:
    """Spin until no topic but the timers' has carried a message for :data:`QUIET_S`: the wall seconds that
    took, or None when the graph kept publishing for :data:`DRAIN_TIMEOUT_S`."""
    start = last_change = time.monotonic()
    seen = {topic: n for topic, n in counts.items() if not timed(topic)}
    while time.monotonic() - last_change < QUIET_S:
        if time.monotonic() - start > DRAIN_TIMEOUT_S:
            return None
        executor.spin_once(timeout_sec=0.05)
        now = {topic: n for topic, n in counts.items() if not timed(topic)}
        if now != seen:
            seen, last_change = now, time.monotonic()
    return round(last_change - start, 2)


def is_driver(spec: object) -> bool:
    return spec.exec.endswith('_driver')


def run_scene(backend: str, duration: float, drivers: str | None = None, graph_checks: int = 0,
              dump: tuple[str, ...] = ()) -> dict:
    """Start every node of the scene in its own process on ``backend`` (the drivers on ``drivers``, default the
    same), count ``duration`` wall seconds from the devices' common time zero; the messages of the ``dump``
    topics in the window are in the report's ``messages``."""
    _check_backend(backend)
    from touch_graph import compat
    specs = _plan_nodes()
    drivers = drivers or backend
    started = time.monotonic()
    procs = [_NodeProcess(drivers if is_driver(spec) else backend, index) for index, spec in enumerate(specs)]
    checks: dict[str, list[int]] = {}
    counts: dict[str, int] = {}
    latched: set[str] = set()
    ups: list[dict] = []
    reports: list[dict] = []
    kept: list = []
    types: dict[str, str] = {}
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
                # Raw: counted, not decoded (a Python executor decoding 150 Hz frames falls behind on a busy machine).
                types[topic] = typename
                counter.create_subscription(compat.get_message(typename), topic,
                                            _Counter(counts, topic, kept if topic in dump else None), qos, raw=True)
        deadline = time.monotonic() + MATCH_TIMEOUT_S
        while any(counter.count_publishers(topic) < n for topic, n in publishers.items()):
            if time.monotonic() > deadline:
                raise RuntimeError('the counter did not match every publisher: ' + ', '.join(
                    f'{topic} {counter.count_publishers(topic)} of {n}' for topic, n in publishers.items()))
            executor.spin_once(timeout_sec=0.05)
        ready_s = time.monotonic() - started
        executor.spin_once(timeout_sec=0.0)  # take what arrived while matching, before the window
        epoch = time.time() + EPOCH_LEAD_S
        # The window opens now, before the devices' time zero (the graph idle), for the counter and the nodes.
        for proc in procs:
            proc.tell(f'epoch {epoch!r}', f'end {epoch + duration!r}', 'mark')
        for topic in counts:
            if topic not in latched:  # a latched message comes once per subscription, whenever it matched
                counts[topic] = 0
        kept.clear()
        while time.time() < epoch + duration:
            executor.spin_once(timeout_sec=0.05)
        drained = _drain(executor, counts)
        for proc in procs:
            proc.tell('mark')
        kept = decoded(list(kept), types, backend)
        rclpy_nodes = sorted(up['node'] for proc, up in zip(procs, ups, strict=True) if proc.backend == 'rclpy')
        if graph_checks:
            checks = graph_tool_checks(rclpy_nodes, graph_checks)
        for proc in procs:
            proc.tell('stop')
        counter.destroy_node()
        if context is None:
            rclpy.shutdown()
        else:
            context.shutdown()
        deadline = time.monotonic() + START_TIMEOUT_S
        reports = [proc.report(deadline) for proc in procs]
    except Exception:
        error = traceback.format_exc()
        ready_s = drained = None
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
    windows = {up['node']: report['driver'] for up, report in zip(ups, reports, strict=False)
               if report['driver'] is not None}
    drivers = {node: window for node, window in windows.items() if 'frames' in window}
    published = {node: window['published'] for node, window in windows.items() if 'published' in window}
    inputs = {node: window for node, window in windows.items() if 'frames_admitted' in window}
    publishers_of: dict[str, list[str]] = {}
    for up in ups:
        for topic, *_ in up['publishers']:
            publishers_of.setdefault(topic, []).append(up['node'])
    errors = [report['callback_errors'] for report in reports]
    error = error or next((report['error'] for report in reports if report['error']), None)
    return {'backend': backend, 'duration_s': duration, 'start_s': None if ready_s is None else round(ready_s, 2),
            'drained_s': drained,
            'nodes': names, 'counts': dict(sorted(counts.items())), 'drivers': drivers, 'published': published,
            'inputs': inputs, 'publishers': {topic: sorted(nodes) for topic, nodes in sorted(publishers_of.items())},
            'callback_errors': None if None in errors else sum(errors), 'graph_checks': checks, 'error': error,
            **({'messages': kept} if dump else {})}


#: The graph tools checked (``--graph-checks``), as ``social-touch`` argument lists.
GRAPH_TOOLS = (('node', 'list'), ('topic', 'list'), ('topic', 'info', '-v', '/skin/frame'))


def graph_tool_checks(rclpy_nodes: list[str], tries: int) -> dict[str, list[int]]:
    """Each of :data:`GRAPH_TOOLS` run ``tries`` times on our runtime: ``[runs that showed every rclpy node's
    part, runs]`` per tool (node list: the nodes; topic list: every topic; topic info -v: the rclpy nodes
    among /skin/frame's endpoints, by name and namespace)."""
    env = backend_env('ours')
    out = {}
    for argv in GRAPH_TOOLS:
        good = 0
        for _ in range(tries):
            run = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', *argv], capture_output=True, text=True,
                                 timeout=120, env=env, cwd=ROOT)
            good += run.returncode == 0 and _shows(argv, run.stdout, rclpy_nodes)
        out[' '.join(argv)] = [good, tries]
    return out


_SKIN_FRAME_ENDPOINTS = ('/skin/skin_driver', '/skin/haptic_commands', '/touch_view', '/foxglove_server')


def _shows(argv: tuple[str, ...], stdout: str, rclpy_nodes: list[str]) -> bool:
    words = stdout.split()
    if argv[:2] == ('node', 'list'):
        return all(node in words for node in rclpy_nodes)
    if argv[:2] == ('topic', 'list'):
        return all(topic in words for topic in ('/skin/frame', '/touch/state', '/diagnostics', '/tf_static'))
    # topic info -v: 'Node name: X' and 'Node namespace: /ns' per endpoint.
    lines = [line.strip() for line in stdout.splitlines()]
    shown = {f"{ns.split(': ', 1)[1].rstrip('/')}/{name.split(': ', 1)[1]}"
             for name, ns in itertools.pairwise(lines)
             if name.startswith('Node name: ') and ns.startswith('Node namespace: ')}
    return all(node in shown for node in rclpy_nodes if node in _SKIN_FRAME_ENDPOINTS)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--backend', choices=('ours', 'rclpy'), required=True)
    parser.add_argument('--duration', type=float, default=8.0,
                        help='seconds of the scenes to play and count (default 8)')
    parser.add_argument('--out', help='write the JSON report to this file (the monitor prints to stdout too)')
    parser.add_argument('--node', type=int, help='run only the N-th node of the scene (the script starts these)')
    parser.add_argument('--drivers', choices=('ours', 'rclpy'), help='the drivers\' backend (default: --backend)')
    parser.add_argument('--graph-checks', type=int, default=0, metavar='N',
                        help='run node list, topic list and topic info -v N times each after the window')
    parser.add_argument('--dump', default='', metavar='TOPIC,...',
                        help="the messages of these topics in the window, decoded, in the report's 'messages'")
    args = parser.parse_args(argv)
    if args.backend == 'ours':
        os.environ['SOCIAL_TOUCH_SHIM'] = '1'
    else:
        os.environ.pop('SOCIAL_TOUCH_SHIM', None)
    sys.path[:0] = [str(ROOT), str(ROOT / 'examples' / 'touch_behaviour')]
    if args.node is not None:
        return run_node(args.backend, args.node)
    text = json.dumps(run_scene(args.backend, args.duration, args.drivers, args.graph_checks,
                                tuple(filter(None, args.dump.split(',')))),
                      indent=1)
    if args.out:
        Path(args.out).write_text(text + '\n', encoding='utf-8')
    else:
        print(text)
    return 0


if __name__ == '__main__':
    sys.exit(main())
