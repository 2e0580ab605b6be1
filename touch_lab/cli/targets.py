"""Commands whose targets (bear, patch, skin) bring their own arguments: ``eval``, ``train``, ``codebook``.

A command module lists ``TARGETS = {name: (module, add_arguments_function, run_function)}`` and
calls :func:`add_target_arguments` / :func:`run_target`; only the chosen target's options are
shown by ``social-touch eval bear --help``.
"""

from __future__ import annotations

import argparse
import importlib

Targets = dict[str, tuple[str, str, str]]


def add_target_arguments(parser: argparse.ArgumentParser, targets: Targets) -> None:
    sub = parser.add_subparsers(dest='target', required=True, metavar='TARGET')
    for name, (module_name, add, _) in targets.items():
        module = importlib.import_module(module_name)
        doc = (module.__doc__ or name).strip()
        target = sub.add_parser(name, help=doc.splitlines()[0], description=doc.split('\n\n')[0])
        getattr(module, add)(target)


def run_target(args: argparse.Namespace, targets: Targets) -> int:
    module_name, _, run_name = targets[args.target]
    return int(getattr(importlib.import_module(module_name), run_name)(args) or 0)
