"""``social-touch bench TARGET [--json]``: medians of repeated runs on this machine.

Every target is a function ``bench(repeats=N) -> dict`` registered in the ``social_touch.bench``
entry point group (setup.py): ``runtime`` (pub/sub throughput, latency, CDR), ``drivers`` (the
driver nodes on recorded bytes, per frame), ``stack`` (drivers and recognisers at real sensor
rates, CPU share), ``transport`` (our DDS path against raw cyclonedds, across processes),
``view`` (the web view's extra CPU with five pages connected), the recognisers (``bear``,
``patch``, ``skin``) and their nodes. Each prints a table, or with ``--json`` one JSON object,
so figures in the docs can be regenerated and compared.
"""

from __future__ import annotations

import argparse
import json
import platform

from touch_lab.cli.targets import targets

HELP = 'measure speed: runtime, drivers, the whole stack at sensor rates, recognisers'
GROUP = 'social_touch.bench'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('target', choices=list(targets(GROUP)), help='what to measure')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--repeats', type=int, default=5, help='runs to take the median of (default 5)')


def run(args: argparse.Namespace) -> int:
    if args.repeats < 1:
        raise SystemExit('social-touch bench: --repeats must be >= 1')
    result = targets(GROUP)[args.target].load()(repeats=args.repeats)
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
