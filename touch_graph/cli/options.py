"""Options spelt the same in every ``social-touch`` command, and old spellings kept as hidden aliases.

``-o/--output`` names what a command writes (``--output-dir`` for several files); an old
spelling (``--out``, ``--out-dir``) still works, hidden, with a warning. Every number a command
takes is read by an argparse type here, so ``nan``, ``inf``, zero, a negative number or ``1e308``
is one ``error: argument --x: expected ...`` line (exit 2), never a traceback or an endless wait.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable
from typing import Any

__all__ = ['MAX_COUNT', 'MAX_SECONDS', 'add_output', 'clock_rate', 'count', 'deprecated_alias', 'non_negative_float',
           'non_negative_int', 'non_negative_seconds', 'number', 'port', 'positive_float', 'positive_int',
           'probability', 'rate_hz', 'seconds', 'seed', 'speed_factor']

#: Longest duration or timeout a command takes, s (a year: beyond it a timer's wait overflows in places).
MAX_SECONDS = 365 * 24 * 3600.0
#: Largest count (messages, repetitions, samples) a command takes.
MAX_COUNT = 10**9


def number(*, low: float | None = None, high: float | None = None, low_open: bool = False,
           integer: bool = False, allow_inf: bool = False, unit: str = '') -> Callable[[str], Any]:
    """An argparse type: a finite number (an integer if ``integer``) in ``[low, high]`` (``(low, high]``).

    ``allow_inf`` also accepts ``inf`` (e.g. a simulated clock's rate: as fast as possible).

    >>> rate = number(low=0, high=1000, low_open=True, unit='Hz')
    >>> rate('2.5')
    2.5
    >>> for text in ('0', 'nan', 'inf', '1e308', 'x'):
    ...     try:
    ...         rate(text)
    ...     except argparse.ArgumentTypeError as err:
    ...         print(err)
    expected a number > 0 and <= 1000 Hz, got '0'
    expected a number > 0 and <= 1000 Hz, got 'nan'
    expected a number > 0 and <= 1000 Hz, got 'inf'
    expected a number > 0 and <= 1000 Hz, got '1e308'
    expected a number > 0 and <= 1000 Hz, got 'x'
    >>> number(low=1, high=10, integer=True)('0')
    Traceback (most recent call last):
    ...
    argparse.ArgumentTypeError: expected an integer in [1, 10], got '0'
    """
    kind = 'an integer' if integer else 'a number'
    if low is not None and high is not None:
        where = f' > {low:g} and <= {high:g}' if low_open else f' in [{low:g}, {high:g}]'
    elif low is not None:
        where = f' >{"" if low_open else "="} {low:g}'
    else:
        where = f' <= {high:g}' if high is not None else ''
    where += f' {unit}' if unit and where else ''
    if allow_inf:
        where += ' (or inf)'
    message = f'expected {kind}{where}, got {{!r}}'

    def parse(text: str) -> Any:
        try:
            value = int(text) if integer else float(text)
        except (ValueError, TypeError):
            raise argparse.ArgumentTypeError(message.format(text)) from None
        if allow_inf and value == math.inf:
            return value
        if not math.isfinite(value) or (low is not None and (value <= low if low_open else value < low)) \
                or (high is not None and value > high):
            raise argparse.ArgumentTypeError(message.format(text))
        return value
    parse.__name__ = 'integer' if integer else 'number'  # argparse names the type in "invalid ... value"
    return parse


#: A finite number > 0 (a factor, a threshold), at most 1e9.
positive_float = number(low=0, high=1e9, low_open=True)
#: A finite number >= 0, at most 1e9.
non_negative_float = number(low=0, high=1e9)
#: A duration or timeout > 0, s, at most :data:`MAX_SECONDS`.
seconds = number(low=0, high=MAX_SECONDS, low_open=True, unit='s')
#: A duration >= 0 (a wait, an offset), s, at most :data:`MAX_SECONDS`.
non_negative_seconds = number(low=0, high=MAX_SECONDS, unit='s')
#: A rate > 0, Hz, at most 1 MHz.
rate_hz = number(low=0, high=1e6, low_open=True, unit='Hz')
#: A bag's replay speed factor: 1000 times slower to 1000 times faster (``--fast``: no waiting).
speed_factor = number(low=1e-3, high=1e3)
#: A simulated clock's rate, simulated seconds per wall second (``inf``: as fast as possible).
clock_rate = number(low=0, high=1e6, low_open=True, allow_inf=True)
#: An integer >= 1 (repetitions, messages, samples), at most :data:`MAX_COUNT`.
positive_int = count = number(low=1, high=MAX_COUNT, integer=True)
#: An integer >= 0, at most :data:`MAX_COUNT`.
non_negative_int = number(low=0, high=MAX_COUNT, integer=True)
#: A TCP port, 0 for any free one.
port = number(low=0, high=65535, integer=True)
#: A random seed, as numpy takes it.
seed = number(low=0, high=2**32 - 1, integer=True)
#: A probability or posterior threshold in (0, 1].
probability = number(low=0, high=1, low_open=True)


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
