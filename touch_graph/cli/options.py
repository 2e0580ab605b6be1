"""Options spelt the same in every ``social-touch`` command, and old spellings kept as hidden aliases.

``-o/--output`` names the file or directory a command writes (``--output-dir`` where it writes
several files); ``--json`` prints one JSON object; ``--repeats`` is how many runs a median is
taken of; ``--timeout`` is in seconds. An old spelling (``--out``, ``--out-dir``) still works,
is left out of ``--help`` and warns on stderr.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

__all__ = ['add_output', 'deprecated_alias']


class _DeprecatedAlias(argparse.Action):
    """Stores like the option it is an old spelling of, with a warning."""

    def __init__(self, option_strings: list[str], dest: str, use: str = '', **kwargs: Any) -> None:
        super().__init__(option_strings, dest, **kwargs)
        self.use = use

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace, values: Any,
                 option_string: str | None = None) -> None:
        print(f'{parser.prog}: warning: {option_string} is deprecated; use {self.use}', file=sys.stderr)
        setattr(namespace, self.dest, values)


def deprecated_alias(parser: Any, old: str, action: argparse.Action) -> argparse.Action:
    """Add ``old`` as a hidden, warning spelling of ``action`` (to ``parser`` or a group of it)."""
    return parser.add_argument(old, dest=action.dest, action=_DeprecatedAlias, help=argparse.SUPPRESS,
                               use='/'.join(action.option_strings), metavar=action.metavar, type=action.type,
                               choices=action.choices)


def add_output(parser: argparse.ArgumentParser, help: str, *, required: bool = False, default: str | None = None,
               directory: bool = False) -> argparse.Action:
    """``-o/--output`` (or ``-o/--output-dir``), with the old ``--out`` (``--out-dir``) as a hidden alias.

    >>> parser = argparse.ArgumentParser(prog='x')
    >>> _ = add_output(parser, 'file to write', required=True)
    >>> parser.parse_args(['-o', 'a.md']).output
    'a.md'
    >>> import contextlib, io
    >>> with contextlib.redirect_stderr(io.StringIO()) as err:
    ...     parser.parse_args(['--out', 'b.md']).output
    'b.md'
    >>> err.getvalue()
    'x: warning: --out is deprecated; use -o/--output\\n'
    """
    new, old = ('--output-dir', '--out-dir') if directory else ('--output', '--out')
    # A required option cannot count its alias as given; a required group of the two can.
    where: Any = parser.add_mutually_exclusive_group(required=True) if required else parser
    action = where.add_argument('-o', new, default=default, help=help)
    deprecated_alias(where, old, action)
    return action
