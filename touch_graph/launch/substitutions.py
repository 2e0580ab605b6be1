"""ROS 2 launch substitutions: ``$(var x)``, ``$(env X default)``, ``$(eval ...)``, ...

A string in a launch file is a *template* of literal text and substitutions ``$(name args...)``,
parsed once (a syntax error names file and line before anything runs) and evaluated against
a :class:`Scope`. The grammar is ros2/launch's (``launch/frontend/grammar.lark``): arguments
separated by spaces, quoted with ``'`` or ``"`` to hold spaces and substitutions, nested
substitutions, a backslash escaping the next character. :data:`SUBSTITUTIONS` lists the
supported ones (those of ros2/launch and launch_ros, minus ``command``, which runs a program).

>>> t = parse_template("$(var ns)/skin_$(eval '2 * 3')")
>>> evaluate(t, Scope(configurations={'ns': '/robot'}), Location('demo.yaml', 3))
'/robot/skin_6'
>>> evaluate(parse_template('$(equals $(var mode) sim)'), Scope({'mode': 'sim'}), Location('x', 1))
'true'
>>> parse_template('$(vra x)')  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
touch_graph.launch.substitutions.TemplateSyntaxError: in '$(vra x)' at column 1: unknown substitution \
'$(vra ...)' (did you mean 'var'?); supported: all, and, ...
"""

from __future__ import annotations

import math
import os
import re
import secrets
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..errors import ConfigError, LaunchError
from ..paths import package_share
from ..yamlconf import YamlBoundsError, did_you_mean, safe_load
from .safe_eval import EvalError, safe_eval

__all__ = [
    'SUBSTITUTIONS', 'Call', 'Location', 'Scope', 'Template', 'TemplateSyntaxError', 'Text', 'evaluate',
    'evaluate_condition', 'literal_text', 'parse_template', 'to_bool',
]


@dataclass(frozen=True)
class Location:
    """Where something is in a launch file: the path and the 1-based line (if known)."""

    path: str
    line: int | None = None

    def error(self, message: str) -> LaunchError:
        return LaunchError(message, self.path, self.line)

    def __str__(self) -> str:
        return f'{self.path}:{self.line}' if self.line is not None else self.path


@dataclass(frozen=True)
class Text:
    """Literal text of a template."""

    text: str


@dataclass(frozen=True)
class Call:
    """A substitution ``$(name args...)``; each argument is itself a template."""

    name: str
    args: tuple[Template, ...] = ()


Template = tuple[Text | Call, ...]


class TemplateSyntaxError(ValueError):
    """A template does not parse: unbalanced ``$(``, an unknown substitution, wrong arity."""


@dataclass
class Scope:
    """What substitutions read while a launch file is evaluated.

    Attributes:
        configurations: launch configurations (``arg``/``let`` values, ``ros_namespace``), by name.
        launch_file: absolute path of the launch file being read, for ``$(dirname)``/``$(filename)``.
        environ: environment variables for ``$(env)``/``$(optenv)``.
        anon_names: names already given by ``$(anon NAME)``, so repeated uses agree.
        find_package_share: package name -> share directory.
    """

    configurations: dict[str, str] = field(default_factory=dict)
    launch_file: Path | None = None
    environ: Mapping[str, str] = field(default_factory=lambda: os.environ)
    anon_names: dict[str, str] = field(default_factory=dict)
    find_package_share: Callable[[str], Path] = package_share


# ------------------------------------------------------------------------------------ parsing

_IDENTIFIER = re.compile(r'[A-Za-z][A-Za-z0-9_-]*')


def parse_template(text: str) -> Template:
    """Parse ``text`` into literal :class:`Text` and :class:`Call` parts.

    Raises:
        TemplateSyntaxError: naming the column of the problem.
    """
    parts, _ = _parse_sequence(text, 0, stop='')
    return parts


def _syntax(text: str, i: int, message: str) -> TemplateSyntaxError:
    return TemplateSyntaxError(f'in {text!r} at column {i + 1}: {message}')


def _parse_sequence(text: str, i: int, stop: str, name: str = '') -> tuple[Template, int]:
    """Parts until ``stop``: a closing quote, '' for the end of the text, or ' )' for the end of the
    unquoted argument of ``$(name ...)``."""
    parts: list[Text | Call] = []
    buffer: list[str] = []

    def flush() -> None:
        if buffer:
            parts.append(Text(''.join(buffer)))
            buffer.clear()

    while i < len(text):
        char = text[i]
        if stop and char in stop:
            flush()
            return tuple(parts), i
        if char == '\\' and i + 1 < len(text):
            buffer.append(text[i + 1])  # ROS: a backslash escapes the next character
            i += 2
        elif text.startswith('$(', i):
            flush()
            call, i = _parse_call(text, i)
            parts.append(call)
        elif stop == ' )' and char in '(\'"':
            raise _syntax(text, i, f"{char!r} inside an unquoted argument of '$({name} ...)'; quote the whole "
                          "argument ('...' or \"...\") or escape it with a backslash")
        else:
            buffer.append(char)
            i += 1
    if stop and stop != ' )':
        raise _syntax(text, i, f'missing closing {stop} of a quoted substitution argument')
    flush()
    return tuple(parts), i


def _parse_call(text: str, i: int) -> tuple[Call, int]:
    start = i
    i += 2
    match = _IDENTIFIER.match(text, i)
    if not match:
        raise _syntax(text, i, "expected a substitution name after '$('")
    name = match.group()
    i = match.end()
    args: list[Template] = []
    while True:
        if i >= len(text):
            raise _syntax(text, start, f"'$({name}' is not closed; add ')'")
        char = text[i]
        if char == ')':
            i += 1
            break
        if char != ' ':
            raise _syntax(text, i, f"unexpected {char!r} in '$({name} ...)'; separate arguments with spaces")
        while i < len(text) and text[i] == ' ':
            i += 1
        if i < len(text) and text[i] == ')':
            continue
        arg, i = _parse_argument(text, i, name)
        args.append(arg)
    _check_call(name, len(args), text, start)
    return Call(name, tuple(args)), i


def _parse_argument(text: str, i: int, name: str) -> tuple[Template, int]:
    if i < len(text) and text[i] in '\'"':
        parts, i = _parse_sequence(text, i + 1, stop=text[i])
        return parts, i + 1
    return _parse_sequence(text, i, ' )', name)


def _check_call(name: str, n_args: int, text: str, i: int) -> None:
    if name not in SUBSTITUTIONS:
        raise _syntax(text, i, f"unknown substitution '$({name} ...)'{did_you_mean(name, SUBSTITUTIONS)}; "
                      f'supported: {", ".join(sorted(SUBSTITUTIONS))}')
    low, high, usage = SUBSTITUTIONS[name][:3]
    if not low <= n_args <= high:
        raise _syntax(text, i, f'$({name}) takes {_arity(low, high)}, got {n_args}; usage: $({usage})')


def _arity(low: int, high: float) -> str:
    if low == high:
        return f'{low} argument{"s" if low != 1 else ""}'
    if high == math.inf:
        return f'{low} or more arguments'
    return f'{low} to {high} arguments'


def literal_text(template: Template) -> str | None:
    """The text of a template without substitutions, else ``None``.

    >>> literal_text(parse_template('abc')), literal_text(parse_template('$(var x)'))
    ('abc', None)
    """
    if all(isinstance(part, Text) for part in template):
        return ''.join(part.text for part in template)  # type: ignore[union-attr]
    return None


# --------------------------------------------------------------------------------- evaluation

def evaluate(template: Template, scope: Scope, where: Location) -> str:
    """The text of ``template`` with every substitution performed.

    Raises:
        LaunchError: at ``where``, when a substitution fails (unset variable, bad boolean, ...).
    """
    out = []
    for part in template:
        if isinstance(part, Text):
            out.append(part.text)
        else:
            args = [evaluate(arg, scope, where) for arg in part.args]
            out.append(SUBSTITUTIONS[part.name][3](args, scope, where))
    return ''.join(out)


_TRUE = ('true', '1')
_FALSE = ('false', '0')


def evaluate_condition(text: str, attribute: str, where: Location) -> bool:
    """An ``if``/``unless`` value: ``true``/``1`` or ``false``/``0``, any case (as ros2/launch).

    >>> evaluate_condition('True', 'if', Location('x')), evaluate_condition('0', 'if', Location('x'))
    (True, False)
    """
    value = text.strip().lower()
    if value in _TRUE:
        return True
    if value in _FALSE:
        return False
    raise where.error(f"'{attribute}' must evaluate to true/false/1/0 (any case); got {text!r}")


def to_bool(text: str, what: str, where: Location) -> bool:
    """A boolean argument of ``not``/``and``/``or``: a YAML boolean (true/yes/on/...) or 1/0.

    >>> to_bool('on', 'x', Location('f')), to_bool('0', 'x', Location('f'))
    (True, False)
    """
    stripped = text.strip()
    if stripped in ('1', '0'):
        return stripped == '1'
    try:
        value = safe_load(stripped, what) if stripped else None
    except YamlBoundsError:
        raise
    except ConfigError:
        value = None
    if isinstance(value, bool):
        return value
    raise where.error(f'{what} expects a boolean (true/false, yes/no, on/off, 1/0); got {text!r}')


def _var(args: list[str], scope: Scope, where: Location) -> str:
    name = args[0]
    if name in scope.configurations:
        return scope.configurations[name]
    known = sorted(scope.configurations)
    raise where.error(f"$(var {name}): launch argument '{name}' is not declared or set here"
                      f'{did_you_mean(name, known)}; known: {", ".join(known) or "none"}. Declare it before '
                      f"use with '- arg: {{name: {name}, default: ...}}' or set it with '- let:'")


def _env(args: list[str], scope: Scope, where: Location) -> str:
    if args[0] in scope.environ:
        return scope.environ[args[0]]
    if len(args) == 2:
        return args[1]
    raise where.error(f"$(env {args[0]}): environment variable '{args[0]}' is not set; set it or give a "
                      f'default: $(env {args[0]} DEFAULT)')


def _optenv(args: list[str], scope: Scope, where: Location) -> str:
    return scope.environ.get(args[0], args[1] if len(args) == 2 else '')


def _find_pkg_share(args: list[str], scope: Scope, where: Location) -> str:
    try:
        return str(scope.find_package_share(args[0]))
    except ConfigError as err:
        raise where.error(f'$(find-pkg-share {args[0]}): {err.bare_message}') from err


def _launch_file(scope: Scope, where: Location, name: str) -> Path:
    if scope.launch_file is None:
        raise where.error(f'$({name}) is only defined while a launch file is read')
    return scope.launch_file


def _anon(args: list[str], scope: Scope, where: Location) -> str:
    if args[0] not in scope.anon_names:
        base = re.sub(r'[^A-Za-z0-9_]', '_', args[0]) or 'anon'
        scope.anon_names[args[0]] = f'{base}_{os.getpid()}_{secrets.randbits(48):012x}'
    return scope.anon_names[args[0]]


def _eval(args: list[str], scope: Scope, where: Location) -> str:
    try:
        return str(safe_eval(args[0]))
    except EvalError as err:
        raise where.error(f'$(eval {args[0]!r}): {err}') from err


def _equals(left: str, right: str) -> bool:
    booleans = ('true', 'false', '1', '0')
    if left.lower() in booleans and right.lower() in booleans:
        return (left.lower() in _TRUE) == (right.lower() in _TRUE)
    try:
        return math.isclose(float(left), float(right))
    except ValueError:
        return left == right


def _text_bool(value: bool) -> str:
    return 'true' if value else 'false'


# name -> (min args, max args, usage, implementation(args, scope, where) -> str)
SUBSTITUTIONS: dict[str, tuple[int, float, str, Callable[[list[str], Scope, Location], str]]] = {
    'var': (1, 1, 'var NAME', _var),
    'env': (1, 2, 'env NAME [DEFAULT]', _env),
    'optenv': (1, 2, 'optenv NAME [DEFAULT]', _optenv),
    'find-pkg-share': (1, 1, 'find-pkg-share PACKAGE', _find_pkg_share),
    'dirname': (0, 0, 'dirname', lambda a, s, w: str(_launch_file(s, w, 'dirname').parent)),
    'filename': (0, 0, 'filename', lambda a, s, w: str(_launch_file(s, w, 'filename'))),
    'anon': (1, 1, 'anon NAME', _anon),
    'eval': (1, 1, "eval 'EXPRESSION'", _eval),
    'not': (1, 1, 'not BOOL', lambda a, s, w: _text_bool(not to_bool(a[0], '$(not)', w))),
    'and': (2, 2, 'and BOOL BOOL',
            lambda a, s, w: _text_bool(to_bool(a[0], '$(and)', w) and to_bool(a[1], '$(and)', w))),
    'or': (2, 2, 'or BOOL BOOL',
           lambda a, s, w: _text_bool(to_bool(a[0], '$(or)', w) or to_bool(a[1], '$(or)', w))),
    'any': (1, math.inf, 'any BOOL [BOOL ...]', lambda a, s, w: _text_bool(any([to_bool(x, '$(any)', w) for x in a]))),
    'all': (1, math.inf, 'all BOOL [BOOL ...]', lambda a, s, w: _text_bool(all([to_bool(x, '$(all)', w) for x in a]))),
    'equals': (2, 2, 'equals A B', lambda a, s, w: _text_bool(_equals(a[0], a[1]))),
    'notequals': (2, 2, 'notequals A B', lambda a, s, w: _text_bool(not _equals(a[0], a[1]))),
}
