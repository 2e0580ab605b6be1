"""``social-touch eval bear|patch|skin ...``: score a recogniser on simulated people or recorded data."""

from __future__ import annotations

import argparse

from touch_lab.cli.targets import add_target_arguments, run_target

TARGETS = {
    'bear': ('touch_lab.bear.cli', 'add_arguments', 'run'),
    'patch': ('touch_lab.patch.cli', 'add_eval_arguments', 'run_eval'),
    'skin': ('touch_lab.skin.cli', 'add_eval_arguments', 'run_eval'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_target_arguments(parser, TARGETS)


def run(args: argparse.Namespace) -> int:
    return run_target(args, TARGETS)
