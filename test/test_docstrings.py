"""Runtime docstrings and comments state contracts, not measurements (issue 24, item 5).

A measured figure (an accuracy, a rate of errors, a cost in microseconds) belongs to the report that
measures it, under docs/, with the command that regenerates it; in a docstring it goes stale the day
the code changes. This test reads every runtime module's docstrings and comments (``ast`` for the
docstrings, ``tokenize`` for the comments; string literals that are not docstrings are code, not
prose) and fails on every percentage or timing that is not a contract.

A *figure* is a number followed by ``%`` or by a time unit (``ns``, ``us``, ``µs``, ``ms``, ``s``).
It is a contract, and allowed, when one of these holds:

- it quotes or cites the specification: its line names a seed paper (``knight2009``,
  ``sympartner2018``, ``cirillo2017``), says "the paper", names one of its tables or sections
  (``Table II``, ``V.D``), or the figure sits inside double quotes;
- it states a setting or a bound: the few words just before it say ``default``, ``=``, ``every``,
  ``within``, ``up to``, ``at most``, ``at least``, ``timeout``, ``period``, ``budget``, ``goal``,
  ``time constant``, ``<=``/``>=``/``<``/``>``, ``rmw:``, or name a parameter (a ``double-backquoted``
  name);
- it converts units: it is followed by ``at <rate> Hz`` (``6.7 ms at 150 Hz``);
- it names a setting after it: ``budget``, ``limit``, ``timer``, ``gap``, ``lifespan``, ``period`` or
  ``timeout`` follows within two words not ``after``/``before``/``since``/``from`` ("the 200 us per
  cycle budget", "the 1 ms startup timer"; "0.2 ms after the gap" stays a measurement);
- it is on the small :data:`ALLOWED` list below, each with its reason.

Words that report an outcome (``about``, ``~``, ``costs``, ``took``, ``takes``, ``measured``,
``median``, ``mean``, ``average``, ``against``, ``reads``, ``runs``) just before the figure make it a
measurement even where a contract word is near: "costs about 15 us against 6-9 ms" is flagged,
"timeout in s" has no number and "(default 1 s)" is a setting.
"""
from __future__ import annotations

import ast
import io
import re
import tokenize
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent

#: The runtime: what a robot runs (docs/DEVELOPING.md); every module under these packages is read.
RUNTIME = ('touch_graph', 'touch_driver', 'touch_gestures', 'social_touch_msgs')

#: (path relative to the repo, text of the figure's line that must contain it, reason).
ALLOWED = (
    ('touch_gestures/monitor_node.py', '] bear      hug started', 'sample output: a stamp, not a figure'),
    ('touch_gestures/monitor_node.py', '] patch     stroke', 'sample output: a stamp and a latency field'),
    ('touch_gestures/monitor_node.py', '] skin      command', 'sample output: a stamp, not a figure'),
    ('touch_gestures/monitor_node.py', '] panels    someone', 'sample output: a stamp, not a figure'),
    ('touch_graph/subscriber_drops.py', 'dropped in the last', 'sample log line: its window is a setting'),
    ('touch_gestures/bear/sensor_level.py', 'activation state boolean', "the paper's words (V.A), quoted over lines"),
)

FIGURE = re.compile(r'(?<![\w.])(\d+(?:[.,]\d+)*)\s?(%|ns|us|µs|ms|s)(?![\w/])')
SEED = re.compile(r'knight2009|sympartner2018|cirillo2017|\bthe paper\b|\bTable [IVX]+\b|\b[IVX]+\.[A-H]\b',
                  re.IGNORECASE)
#: Looked for in the words just before a figure (same line, up to BEFORE characters).
BEFORE = 28
SETTING = re.compile(r'default|=|\bevery\b|\bwithin\b|\bup to\b|\bat most\b|\bat least\b|timeout|period|'
                     r'budget|\bgoal\b|time constant|[<>]|rmw:|``[\w.]+``', re.IGNORECASE)
OUTCOME = re.compile(r'\babout\b|~|\bcosts?\b|\btook\b|\btakes\b|measured|\bmedian\b|\bmean\b|average|'
                     r'against|\breads\b|\bruns?\b', re.IGNORECASE)
CONVERSION = re.compile(r'\s*at \d+(?:\.\d+)? Hz')
#: Looked for just after a figure, at most two words on: "the 200 us per cycle budget", "a 1 ms gap".
BOUND_AFTER = re.compile(r'\s+(?:(?!after\b|before\b|since\b|from\b)\w+\s+){0,2}'
                         r'(?:budget|limit|timer|gap|lifespan|period|timeout)\b')


def prose(source: str):
    """Yield ``(line number, text)`` for every line of a docstring and every comment of ``source``."""
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            doc = node.body[0] if node.body else None
            if (isinstance(doc, ast.Expr) and isinstance(doc.value, ast.Constant)
                    and isinstance(doc.value.value, str)):
                for offset, line in enumerate(doc.value.value.splitlines()):
                    yield doc.value.lineno + offset, line
    for token in tokenize.generate_tokens(io.StringIO(source).readline):
        if token.type == tokenize.COMMENT:
            yield token.start[0], token.string


def measured_figures(line: str) -> list[str]:
    """The figures of one line of prose that are not contracts (see the module docstring)."""
    if SEED.search(line):
        return []
    found = []
    for match in FIGURE.finditer(line):
        before = line[max(0, match.start() - BEFORE):match.start()]
        quoted = line[:match.start()].count('"') % 2 == 1
        contract = (quoted or SETTING.search(before) or CONVERSION.match(line, match.end())
                    or BOUND_AFTER.match(line, match.end()))
        if OUTCOME.search(before) or not contract:
            found.append(match.group(0))
    return found


def modules(part: str) -> list[Path]:
    """The Python files of a package of :data:`RUNTIME`."""
    paths = sorted((ROOT / part).rglob('*.py'))
    assert paths, f'{part}: no Python file (a renamed package? update RUNTIME)'
    return paths


def offenders(part: str) -> list[str]:
    """``path:line: figures | text`` for every measured figure in one part of the runtime."""
    out = []
    for path in modules(part):
        rel = path.relative_to(ROOT).as_posix()
        for lineno, line in prose(path.read_text(encoding='utf-8')):
            figures = measured_figures(line)
            if figures and not any(rel == p and text in line for p, text, _ in ALLOWED):
                out.append(f'{rel}:{lineno}: {", ".join(figures)} | {line.strip()}')
    return out


@pytest.mark.parametrize('part', RUNTIME)
def test_runtime_prose_quotes_no_measured_figure(part):
    found = offenders(part)
    assert not found, ('measured figures in runtime docstrings or comments; move them to the '
                       'generated report under docs/ that measures them:\n' + '\n'.join(found))


@pytest.mark.parametrize('line', [
    'reads 97 % on the unistroke file',
    'one prediction costs 61 us',
    'the command comes 0.2 ms after the gap',
    'a run took 1.3 s',
    'costs about 15 us, against 6-9 ms for a tree ensemble',
    'the cloud reads 97.09 % (default recogniser)',
    'random touches fire 12% of the time',
    '~1.5 against ~25 us',
])
def test_a_measurement_is_flagged(line):
    assert measured_figures(line)


@pytest.mark.parametrize('line', [
    'timeout: how long to wait, in s',
    'fsyncs the file every ``flush_period_s`` (default 1 s)',
    'waits up to 100 ms for the reply reader',
    '"If (amplitude < 30%) NoTouch" (knight2009 V.D)',
    'one more frame (6.7 ms at 150 Hz)',
    '``gap_s`` 0.15 s, ``max_strokes`` 1',
    'must stay within 50 ms of the gap',
    'the 200 us per cycle budget',
    'period_s = 0.5 s',
    'the 1 ms startup timer polls again',
])
def test_a_contract_is_not_flagged(line):
    assert measured_figures(line) == []


def test_allowed_entries_still_match_a_line():
    """An allow-list entry whose line is gone is stale: delete it."""
    for rel, text, reason in ALLOWED:
        assert reason and text in (ROOT / rel).read_text(encoding='utf-8'), (rel, text)
