"""``social-touch bench TARGET [--json]``: medians of repeated runs on this machine.

Every target is a function ``bench(repeats=N) -> dict``, one line of :data:`BENCHES` with what
it measures (``social-touch bench --help`` lists them). Each prints a table, or with ``--json``
one JSON object, so figures in the docs can be regenerated and compared.
"""

from __future__ import annotations

import argparse
import json
import platform

from touch_graph.cli.main import Command, load
from touch_graph.cli.options import positive_int

__all__ = ['BENCHES', 'add_arguments', 'run']

#: name -> (``module:function``, what it measures).
BENCHES: dict[str, Command] = {
    'runtime': Command('touch_lab.bench.runtime:bench_runtime', 'pub/sub throughput, latency, CDR'),
    'drivers': Command('touch_lab.bench.drivers:bench_drivers', 'the driver nodes on recorded bytes, per frame'),
    'transport': Command('touch_lab.bench.transport:bench_transport',
                         'our DDS path against raw cyclonedds, across processes'),
    'stack': Command('touch_lab.bench.stack:bench_stack', 'drivers and recognisers at real sensor rates, CPU share'),
    'training': Command('touch_lab.bench.training:bench_training',
                        'training on an hour of sessions, per sensor (SYNTHETIC)'),
    'framing': Command('touch_lab.bench.framing:bench_framing', "the drivers' frame parsers"),
    'codec': Command('touch_lab.bench.codec:bench_codec', 'the CDR codec'),
    'cli': Command('touch_lab.bench.cli:bench_cli',
                   'social-touch --help against python -c pass; topic list and node list, graph daemon or not'),
    'view': Command('touch_view.bench:bench_view', "the web view's extra CPU with five pages connected"),
    'view-live': Command('touch_view.bench_live:bench_live',
                         'frames the view and foxglove get from the skin in another process'),
    'bear': Command('touch_lab.bear.bench:bench_cycle', 'one cycle of the bear recognisers'),
    'patch': Command('touch_lab.patch.bench:bench_frame', 'one frame of the patch recogniser'),
    'patch-node': Command('touch_lab.patch.bench:bench_node', 'the patch recogniser node'),
    'skin': Command('touch_lab.skin.bench:bench_recognition', 'one recognition of the skin'),
    'skin-node': Command('touch_lab.skin.session_eval:bench_node', 'the skin nodes on simulated sessions'),
    'node-memory': Command('touch_lab.bench.node_memory:bench_node_memory',
                           'RSS of each node process as launched (--processes) and of its imports'),
    'wall-clock': Command('touch_lab.bench.wall_clock:bench_wall_clock',
                          'the graph as launched on the wall clock, sensors fed through ptys: CPU share'),
    'frame-steps': Command('touch_lab.bench.frame_steps:bench_frame_steps',
                           "one skin frame's CPU per step (decode ... recognise), back to back and at 150 Hz"),
    'message-floor': Command('touch_lab.bench.message_floor:bench_message_floor',
                             "a SkinFrame at 150 Hz to a subscriber in one process, ours against rclpy: CPU share"),
    'skin-latency': Command('touch_lab.skin.latency:bench_latency', "the skin's decision after the gesture's end"),
    'skin-acceptance': Command('touch_lab.skin.bench:bench_acceptance',
                               'one recognition with thresholds, the product score, the logistic score '
                               'with and without context'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('target', choices=list(BENCHES), metavar='TARGET',
                        help='what to measure: ' + '; '.join(f'{name} ({b.help})' for name, b in BENCHES.items()))
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--repeats', type=positive_int, default=5, help='runs to take the median of (default 5)')


def run(args: argparse.Namespace) -> int:
    if args.repeats < 1:
        raise SystemExit('social-touch bench: --repeats must be >= 1')
    result = load(BENCHES[args.target].target)(repeats=args.repeats)
    result = {'target': args.target, **result,
              'machine': {'python': platform.python_version(), 'processor': platform.machine()}}
    if args.json:
        print(json.dumps(result, indent=2))
    else:
        _print_table(result)
    return 0


def _print_table(result: dict, indent: str = '') -> None:
    for key, value in result.items():
        if isinstance(value, dict):
            print(f'{indent}{key}:')
            _print_table(value, indent + '  ')
        else:
            print(f'{indent}{key:<24} {value}')
