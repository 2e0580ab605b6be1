"""``social-touch bench TARGET [--json]``: medians of repeated runs on this machine, one core.

Targets: ``runtime`` (pub/sub throughput, latency, CDR), ``drivers`` (decode + calibrate per
frame). Each prints a table, or with ``--json`` one JSON object, so figures in the docs can
be regenerated and compared.
"""

from __future__ import annotations

import argparse
import importlib
import json
import platform

# target -> (module, function); each function takes repeats= and returns a dict.
TARGETS = {
    'runtime': ('touch_lab.bench.runtime', 'bench_runtime'),
    'drivers': ('touch_lab.bench.drivers', 'bench_drivers'),
    'bridge': ('touch_graph.bridge.bench', 'bench_bridge'),
    'bear': ('touch_lab.bear.bench', 'bench_cycle'),
    'patch': ('touch_lab.patch.bench', 'bench_frame'),
    'skin': ('touch_lab.skin.bench', 'bench_recognition'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('target', choices=sorted(TARGETS), help='what to measure')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--repeats', type=int, default=5, help='runs to take the median of (default 5)')


def run(args: argparse.Namespace) -> int:
    if args.repeats < 1:
        raise SystemExit('social-touch bench: --repeats must be >= 1')
    module_name, function = TARGETS[args.target]
    result = getattr(importlib.import_module(module_name), function)(repeats=args.repeats)
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
