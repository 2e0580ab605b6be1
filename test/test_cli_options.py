"""One spelling per option across the ``social-touch`` commands; old spellings still work, hidden, with a warning."""

from __future__ import annotations

import argparse
import contextlib
import io

import pytest

from touch_graph.cli.main import load
from touch_lab.cli.main import COMMANDS
from touch_lab.cli.targets import CODEBOOK_TARGETS, EVAL_TARGETS, REPORT_TARGETS, TRAIN_TARGETS

#: Old spelling -> the one every command uses now.
RENAMED = {'--out': '--output', '--out-dir': '--output-dir', '--reps': '--repetitions',
           '--suggest-out': '--suggest-output'}


def _parsers():
    """(name, parser) of every command and target that adds its own options."""
    tables = {'': {n: c for n, c in COMMANDS.items() if n not in ('eval', 'train', 'codebook', 'report')},
              'eval ': EVAL_TARGETS, 'train ': TRAIN_TARGETS, 'codebook ': CODEBOOK_TARGETS, 'report ': REPORT_TARGETS}
    for prefix, table in tables.items():
        for name, command in table.items():
            parser = argparse.ArgumentParser(prog=f'social-touch {prefix}{name}')
            load(command.target).add_arguments(parser)
            yield prefix + name, parser


def _options(parser: argparse.ArgumentParser):
    """Every (option string, shown in --help) of ``parser`` and its subparsers."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                yield from _options(sub)
        for option in action.option_strings:
            yield option, action.help != argparse.SUPPRESS


def test_no_command_shows_an_old_spelling():
    shown = {(name, option) for name, parser in _parsers() for option, visible in _options(parser)
             if visible and option in RENAMED}
    assert shown == set()


def test_output_is_dash_o_wherever_a_command_writes_one_file():
    for name, parser in _parsers():
        options = dict(_options(parser))
        if '--output' in options:
            assert '-o' in options, name


@pytest.mark.parametrize('command, argv, dest', [
    ('report skin', ['--traces', 't', '--out', 'x.md'], 'output'),
    ('report robustness', ['--out', 'x.md'], 'output'),
    ('report bear', ['--out-dir', 'd'], 'output_dir'),
    ('eval bear', ['--reps', '3'], 'repetitions'),
])
def test_an_old_spelling_still_works_and_warns(command, argv, dest):
    parser = dict(_parsers())[command]
    with contextlib.redirect_stderr(io.StringIO()) as err:
        args = parser.parse_args(argv)
    old, value = argv[-2:]
    assert getattr(args, dest) == (int(value) if value.isdigit() else value)   # converted as the new spelling is
    assert f'warning: {old} is deprecated; use' in err.getvalue()
