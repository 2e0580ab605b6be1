"""``social-touch train patch ...``: train a recogniser from recordings or simulated people."""

from __future__ import annotations

import argparse

from touch_lab.cli.targets import add_target_arguments, run_target

TARGETS = {
    'patch': ('touch_lab.patch.cli', 'add_train_arguments', 'run_train'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_target_arguments(parser, TARGETS)


def run(args: argparse.Namespace) -> int:
    return run_target(args, TARGETS)
