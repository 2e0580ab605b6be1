"""Every number a ``social-touch`` command takes is read by one shared argparse type (issue 25).

``nan``, ``inf``, a negative number, ``1e308`` or text is one usage error naming the option, never a
traceback, an endless wait or a timer that overflows.
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys

import pytest
from test_cli_options import _parsers

from touch_graph.cli import options

HELPERS = {getattr(options, name) for name in options.__all__ if callable(getattr(options, name))}


def _numeric_actions():
    """(command, option, action) of every option of every command, subcommand and target."""
    def walk(name, parser):
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for sub_name, sub in action.choices.items():
                    yield from walk(f'{name} {sub_name}', sub)
            elif action.type is not None and action.option_strings:
                yield name, action.option_strings[-1], action
    for name, parser in _parsers():
        yield from walk(name, parser)


ACTIONS = list(_numeric_actions())


def test_no_option_reads_a_bare_int_or_float():
    bare = [f'{name} {option}' for name, option, action in ACTIONS if action.type in (int, float)]
    assert not bare, f'options read with int()/float() (nan, inf, -1 pass): {bare}'


@pytest.mark.parametrize('text', ['nan', '-inf', '-1', '1e308', 'abc', ''])
def test_every_numeric_option_refuses_what_can_never_work(text):
    numeric = [(n, o, a) for n, o, a in ACTIONS if a.type.__module__ == options.__name__]
    assert len(numeric) > 40
    accepted = []
    for name, option, action in numeric:
        try:
            value = action.type(text)
        except argparse.ArgumentTypeError as err:
            assert str(err).startswith('expected ') and repr(text) in str(err)
        else:
            accepted.append(f'{name} {option} -> {value}')
    assert not accepted


def test_inf_only_where_it_means_as_fast_as_possible():
    takes_inf = set()
    for name, option, action in ACTIONS:
        if action.type.__module__ != options.__name__:
            continue
        try:
            if math.isinf(action.type('inf')):
                takes_inf.add(f'{name} {option}')
        except argparse.ArgumentTypeError:
            pass
    assert takes_inf == {'launch --rate', 'demo --rate'}


@pytest.mark.parametrize('argv', [
    ['play', 'nowhere', '--rate', '1e308'], ['play', 'nowhere', '--rate', 'nan'], ['play', 'nowhere', '--rate', '-1'],
    ['play', 'nowhere', '--start-offset', 'nan'], ['topic', 'pub', '/x', 'std_msgs/msg/String', '--rate', '0'],
    ['topic', 'pub', '/x', 'std_msgs/msg/String', '--rate', 'inf'], ['topic', 'echo', '/x', '-n', '0'],
    ['topic', 'hz', '/x', '--window', '0'], ['service', 'call', '/x', 'std_srvs/srv/Trigger', '--timeout', '1e308'],
    ['view', '--port', '70000'], ['foxglove', '--port', '-1'], ['launch', 'x.launch.yaml', '--rate', 'nan'],
    ['record', '-a', '--duration', '1e308'], ['param', 'list', '--timeout', 'nan'],
])
def test_a_command_with_such_a_number_exits_2_with_one_line(argv, tmp_path):
    run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                          *argv], capture_output=True, text=True, timeout=60, cwd=tmp_path)
    assert run.returncode == 2, run.stderr
    assert 'Traceback' not in run.stderr and 'error: argument' in run.stderr and 'expected' in run.stderr
    assert not any(tmp_path.iterdir())
