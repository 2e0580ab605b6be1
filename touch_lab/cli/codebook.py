"""``social-touch codebook record ...``: record m repetitions per gesture from the skin into a codebook."""

from __future__ import annotations

import argparse

from touch_lab.cli.targets import add_target_arguments, run_target

TARGETS = {
    'record': ('touch_lab.skin.record_cli', 'add_arguments', 'run'),
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_target_arguments(parser, TARGETS)


def run(args: argparse.Namespace) -> int:
    return run_target(args, TARGETS)
