"""Commands whose targets bring their own arguments: ``eval``, ``train``, ``codebook``, ``report``.

Each command has an entry point group (``social_touch.eval``, ``social_touch.train``, ...) in
which every target registers ``name = module`` or ``name = module:OBJECT``: something with
``add_arguments(parser)``, ``run(args) -> int`` and a one-line ``HELP`` (a module's docstring
serves otherwise). A new evaluation is one entry point in setup.py, not an edit here; only the
chosen target's options are shown by ``social-touch eval bear --help``.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from importlib.metadata import EntryPoint, entry_points
from typing import Any

__all__ = ['CODEBOOK', 'EVAL', 'REPORT', 'TRAIN', 'Target', 'TargetCommand', 'targets']


def targets(group: str) -> dict[str, EntryPoint]:
    """``name -> entry point`` of the targets installed in ``group``, sorted by name."""
    return {ep.name: ep for ep in sorted(entry_points(group=group), key=lambda ep: ep.name)}


def _help(target: Any) -> tuple[str, str]:
    """(one line, description) of a target: its ``HELP`` and the first paragraph of its docstring."""
    doc = (getattr(target, '__doc__', None) or '').strip()
    line = getattr(target, 'HELP', None) or (doc.splitlines()[0] if doc else '')
    return line, doc.split('\n\n')[0] if doc else line


@dataclass(frozen=True)
class Target:
    """A target that is not a module of its own (e.g. ``train patch`` and ``eval patch`` share one)."""

    HELP: str
    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    __doc__: str = ''


@dataclass(frozen=True)
class TargetCommand:
    """A ``social-touch`` command whose targets are the entry points of ``group``."""

    HELP: str
    group: str

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """One subparser per installed target, each with the target's own options."""
        sub = parser.add_subparsers(dest='target', required=True, metavar='TARGET')
        for name, ep in targets(self.group).items():
            target = ep.load()
            line, description = _help(target)
            target.add_arguments(sub.add_parser(name, help=line, description=description))

    def run(self, args: argparse.Namespace) -> int:
        """Run the chosen target."""
        return int(targets(self.group)[args.target].load().run(args) or 0)


EVAL = TargetCommand('evaluate recognisers on simulated people or recorded data', 'social_touch.eval')
TRAIN = TargetCommand('train a recogniser from recordings or simulated people', 'social_touch.train')
CODEBOOK = TargetCommand('record, inspect and edit haptic-command codebooks of the skin (record, info, add, remove, '
                          'merge)', 'social_touch.codebook')
REPORT = TargetCommand('regenerate the evaluation reports in docs/ (bear, patch, skin) from measurements',
                       'social_touch.report')
