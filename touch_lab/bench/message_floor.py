"""``social-touch bench message-floor``: what carrying the skin's frames costs a node, on ours and on rclpy.

The floor under ``bench wall-clock``'s figures: a publisher timer builds a ``SkinFrame`` (the
skin driver's message: 144 raw counts, 144 pressures, 108 forces, the contact) at the skin's
150 Hz and a subscription in the same process takes each one, with no driver and no recogniser.
Each run is a process of its own on the wall clock, a DDS participant in its own domain, as a
launched node lives; its CPU (user + system, ``getrusage``) over ``seconds`` after a warm-up is
given as % of one core, with the frames published and received (a starved process has fewer). With
one pair and with two, the difference is what one more skin patch's frames cost, the process's
own share (its DDS participant, its executor) taken out.

Two clients, run alternately so both see the same machine: this project's runtime
(``SOCIAL_TOUCH_SHIM=1``) and real rclpy, in the Python named by ``SOCIAL_TOUCH_ROS2_PYTHON`` (one
where ``import rclpy`` and ``social_touch_msgs`` work: a sourced ROS 2 environment with this package
installed; ``.ci/ros2-jazzy`` builds one). Without it only ours is measured, and the output says so.
"""

from __future__ import annotations

import json
import os
import random
import resource
import statistics
import subprocess
import sys
import time
from typing import Any

import numpy as np

__all__ = ['DEPTH', 'RATE_HZ', 'bench_message_floor', 'child_main', 'measure']

#: The skin's frame rate, Hz (cirillo2017).
RATE_HZ = 150.0
#: s of publishing before the CPU window opens (DDS matching, first allocations).
WARMUP_S = 2.0
#: Each subscription's and publisher's queue depth: at most this many frames per pair are in flight.
DEPTH = 10
#: What a measuring child runs (``python -c CHILD SECONDS PAIRS``).
CHILD = 'import sys; from touch_lab.bench.message_floor import child_main; sys.exit(child_main(sys.argv[1:]))'


def child_main(argv: list[str]) -> int:
    """In the measuring process: ``pairs`` publisher/subscriber pairs at :data:`RATE_HZ` for ``seconds``;
    prints one JSON line (``percent_of_core``, ``received``, ``published``, ``expected`` at the nominal
    rate, ``client``)."""
    # Here, not at the top: the measuring process's environment chooses rclpy or ours at this import.
    from touch_graph.compat import USING_ROS, Node, get_message, rclpy

    seconds, pairs = float(argv[0]), int(argv[1])
    skin_frame = get_message('social_touch_msgs/msg/SkinFrame')
    raw = np.arange(144, dtype=np.uint16)
    pressure = np.linspace(0.0, 1.0, 144, dtype=np.float32)
    force = np.zeros(108, dtype=np.float32)
    rclpy.init()
    received, published = [0], [0]

    def count(_message: Any) -> None:
        received[0] += 1

    nodes = []
    for k in range(pairs):
        talker, listener = Node(f'floor_talker_{k}'), Node(f'floor_listener_{k}')
        publisher = talker.create_publisher(skin_frame, f'/floor{k}/frame', DEPTH)
        listener.create_subscription(skin_frame, f'/floor{k}/frame', count, DEPTH)
        sequence = [0]

        def tick(talker: Any = talker, publisher: Any = publisher, sequence: list = sequence) -> None:
            message = skin_frame()
            message.header.stamp = talker.get_clock().now().to_msg()
            message.header.frame_id = 'skin_link'
            message.sequence = sequence[0] & 0xFFFF
            sequence[0] += 1
            message.raw, message.pressure, message.force = raw, pressure, force
            message.contact, message.contact_x, message.contact_y, message.total_force = True, 23.5, 23.5, 0.5
            publisher.publish(message)
            published[0] += 1

        talker.create_timer(1.0 / RATE_HZ, tick)
        nodes += [talker, listener]
    executor = rclpy.executors.SingleThreadedExecutor()
    for node in nodes:
        executor.add_node(node)

    def spin(until: float) -> None:
        while time.monotonic() < until:
            executor.spin_once(timeout_sec=0.1)

    spin(time.monotonic() + WARMUP_S)
    before, start, received0, published0 = (resource.getrusage(resource.RUSAGE_SELF), time.monotonic(),
                                             received[0], published[0])
    spin(start + seconds)
    after, wall = resource.getrusage(resource.RUSAGE_SELF), time.monotonic() - start
    cpu_s = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    print(json.dumps({'client': 'rclpy' if USING_ROS else 'ours', 'percent_of_core': 100.0 * cpu_s / wall,
                      'received': received[0] - received0, 'published': published[0] - published0,
                      'expected': round(pairs * RATE_HZ * wall)}), flush=True)
    executor.shutdown()
    rclpy.shutdown()
    return 0


def measure(python: str, shim: bool, seconds: float, pairs: int) -> dict[str, Any]:
    """One run in a fresh process of ``python`` (``shim``: this project's runtime), in a domain of its own."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.randint(1, 99)), PYTHONUNBUFFERED='1')
    if shim:
        env['SOCIAL_TOUCH_SHIM'] = '1'
    else:
        env.pop('SOCIAL_TOUCH_SHIM', None)
    done = subprocess.run([python, '-c', CHILD, str(seconds), str(pairs)], env=env, capture_output=True, text=True,
                          timeout=WARMUP_S + seconds + 120)
    lines = [line for line in done.stdout.splitlines() if line.startswith('{')]
    if done.returncode != 0 or not lines:
        raise RuntimeError(f'the measuring process ({python}) failed with {done.returncode}:\n{done.stderr[-2000:]}')
    return {**json.loads(lines[-1]), 'load_average_1min': os.getloadavg()[0]}


def bench_message_floor(repeats: int = 3, seconds: float = 8.0, pairs: tuple[int, ...] = (1, 2),
                        ros2_python: str | None = None) -> dict:
    """Medians over ``repeats`` alternating runs of ours and rclpy (module doc), for each count of
    publisher/subscriber ``pairs`` in one process; with two counts or more, ``per_extra_pair``: the
    slope between the first and the last (what one more skin patch's frames cost, the process's own
    share taken out)."""
    if repeats < 1 or not seconds > 0 or not pairs or min(pairs) < 1:
        raise ValueError(f'repeats >= 1, seconds > 0 and pair counts >= 1 are required; '
                         f'got {repeats}, {seconds}, {pairs}')
    pairs = tuple(sorted(set(pairs)))
    ros2_python = ros2_python or os.environ.get('SOCIAL_TOUCH_ROS2_PYTHON') or None
    clients = [('ours', sys.executable, True)] + ([('rclpy', ros2_python, False)] if ros2_python else [])
    runs: dict[tuple[str, int], list[dict]] = {(name, n): [] for name, _, _ in clients for n in pairs}
    for _ in range(repeats):
        for n in pairs:
            for name, python, shim in clients:
                run = measure(python, shim, seconds, n)
                if run['client'] != name:
                    raise RuntimeError(f'{python} ran {run["client"]}, not {name}: is rclpy importable there?')
                runs[name, n].append(run)
    out: dict[str, Any] = {'message': 'social_touch_msgs/msg/SkinFrame', 'rate_hz': RATE_HZ,
                           'seconds': seconds, 'repeats': repeats}
    for name, _, _ in clients:
        curve: dict[Any, Any] = {}
        for n in pairs:
            rows = runs[name, n]
            curve[n] = {'percent_of_core': round(statistics.median(r['percent_of_core'] for r in rows), 2),
                        'runs': [round(r['percent_of_core'], 2) for r in rows],
                        'received': [r['received'] for r in rows], 'published': [r['published'] for r in rows],
                        'expected': [r['expected'] for r in rows],
                        'load_average_1min': [round(r['load_average_1min'], 2) for r in rows]}
        if len(pairs) >= 2:
            curve['per_extra_pair'] = round((curve[pairs[-1]]['percent_of_core'] - curve[pairs[0]]['percent_of_core'])
                                            / (pairs[-1] - pairs[0]), 2)
        out[name] = curve
    if 'rclpy' not in out:
        out['rclpy'] = 'not measured: set SOCIAL_TOUCH_ROS2_PYTHON to a Python with rclpy and social_touch_msgs'
    return out
