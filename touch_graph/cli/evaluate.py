"""``social-touch eval bear|patch|skin ...``: each target's evaluation, from its own module.

The targets' arguments differ, so this only dispatches: ``social-touch eval bear --help``
shows the bear's options.
"""

from __future__ import annotations

import argparse
import importlib

# target -> (module, add-arguments function, run function)
TARGETS = {
    'bear': ('touch_gestures.bear.cli', 'add_arguments', 'run'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='target', required=True, metavar='TARGET')
    for name, (module_name, add, _) in TARGETS.items():
        module = importlib.import_module(module_name)
        target = sub.add_parser(name, help=(module.__doc__ or '').strip().splitlines()[0],
                                description=(module.__doc__ or '').strip().split('\n\n')[0])
        getattr(module, add)(target)


def run(args: argparse.Namespace) -> int:
    module_name, _, run_name = TARGETS[args.target]
    return int(getattr(importlib.import_module(module_name), run_name)(args) or 0)
