"""Writes docs/compiled-code.md: what each compiled twin saves at the robot's real message rates.

``python -m touch_lab.bench.compiled_code [SECTION ...]`` measures the named sections (all by default),
keeps their figures in docs/compiled-code.json and renders docs/compiled-code.md from every section
there. The design rule it serves: compiled code stays only where it saves >= 0.5 % of one core (or a
latency a user feels) at the robot's real rates.

One section per compiled twin, in :data:`SECTIONS`: ``measure(repeats) -> dict`` (JSON-able figures)
and ``render(figures) -> str`` (markdown). A section measures what this tree has; where the twin has
been removed, its section keeps the figures measured before (with their commit) and adds the ones it
can still take, so the report says both what the twin saved and what runs now.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

__all__ = ['SECTIONS', 'main']

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / 'docs' / 'compiled-code.md'
FIGURES = ROOT / 'docs' / 'compiled-code.json'
#: The design rule's threshold, % of one core.
THRESHOLD_PERCENT = 0.5
#: Decodes per message counted in the ceiling: the recogniser, the recorder and the view all subscribe.
CEILING_DECODES = 3


def _commit() -> str:
    try:
        return subprocess.run(['git', 'rev-parse', '--short', 'HEAD'], cwd=ROOT, capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return 'unknown'


def _stack_percent(codec: str, duration_s: float) -> float:
    """``bench stack``'s total (% of one core) in a child process with ``SOCIAL_TOUCH_CDR=codec``."""
    code = ('import json, sys; from touch_lab.bench.stack import bench_stack; '
            'print(json.dumps(bench_stack(repeats=1, duration_s=float(sys.argv[1]))["total"]["percent_of_core"]))')
    env = {**os.environ, 'SOCIAL_TOUCH_CDR': codec}
    out = subprocess.run([sys.executable, '-c', code, str(duration_s)], env=env, capture_output=True, text=True,
                         check=True)
    return float(out.stdout.strip().splitlines()[-1])


# --- the CDR codec (touch_graph.cdr; its compiled twin was touch_graph/_cdr_accel.c) ------------------------

def _message_rates(duration_s: float) -> dict[str, float]:
    """Messages per second of each kind at the sensors' real rates (the demo's people scenes, synthetic)."""
    from touch_lab.bench.replay import record_scene
    from touch_lab.bench.stack import run_stack
    recordings = {sensor: record_scene(sensor, duration_s) for sensor in ('bear', 'patch', 'skin')}
    outputs = run_stack(list(recordings.values()))['outputs']
    rates = {f'{sensor}_frame': 1.0 / rec.period for sensor, rec in recordings.items()}
    rates['gesture_event'] = sum(outputs.values()) / duration_s  # what the recognisers perceive, all sensors
    return rates


def _percent_of_core(kinds: dict[str, Any], rates: dict[str, float], codec: str, decodes: int) -> float:
    """% of one core that ``codec`` spends at ``rates`` (messages/s per kind), each message encoded once."""
    us_per_s = sum(rate * (kinds[kind][f'{codec}_encode_us'] + decodes * kinds[kind][f'{codec}_decode_us'])
                   for kind, rate in rates.items())
    return round(us_per_s / 1e4, 4)


def measure_cdr(repeats: int) -> dict[str, Any]:
    """Both codecs per message kind (``bench codec``), the stack with each, the cost at the real rates."""
    from touch_graph import messages
    from touch_lab.bench.codec import bench_codec
    codec = bench_codec(repeats=repeats, leak_calls=0)
    duration_s = 20.0
    rates = _message_rates(duration_s)
    out: dict[str, Any] = {'commit': _commit(), 'date': datetime.date.today().isoformat(),
                           'command': 'python -m touch_lab.bench.compiled_code cdr', 'rounds': repeats,
                           'rates_hz': {k: round(v, 3) for k, v in rates.items()}, 'kinds': codec['kinds']}
    codecs = ['python'] + (['c'] if codec['compiled_available'] else [])
    stack: dict[str, list[float]] = {name: [] for name in codecs}
    for _ in range(repeats):  # in turns, so a busy moment of the machine hits both
        for name in codecs:
            stack[name].append(_stack_percent(name, duration_s))
    out['stack_percent'] = {name: round(statistics.median(v), 3) for name, v in stack.items()}
    out['stack_runs'] = repeats
    for name in codecs:
        out[f'{name}_percent_of_core'] = _percent_of_core(codec['kinds'], rates, name, 1)
        out[f'{name}_ceiling_percent_of_core'] = _percent_of_core(codec['kinds'], rates, name, CEILING_DECODES)
    out['in_use'] = messages.codec_implementation()
    if 'c' not in codecs:  # removed: keep what it saved, measured while it was here
        previous = _load().get('cdr', {})
        out['compiled_measured'] = previous.get('compiled_measured') or previous
    return out


def render_cdr(f: dict[str, Any]) -> str:
    before = f if 'c_percent_of_core' in f else f.get('compiled_measured', {})
    lines = ['## The CDR codec (touch_graph/cdr.py; compiled twin touch_graph/_cdr_accel.c)', '',
             'Every message that crosses processes is encoded once and decoded once per subscribing process. '
             'Per message kind, the median us per call over the rounds (`bench codec`: both codecs in one '
             'process, in turns, synthetic messages of the real sizes), then the cost at the real message '
             'rates (frames at each sensor\'s rate; gesture events at the rate the recognisers perceive them '
             'in the demo\'s people scenes, synthetic) as % of one core: one encode and one decode per message, '
             f'and a ceiling with {CEILING_DECODES} decodes (recogniser, recorder, view).', '']
    if before:
        lines += [f'Measured at commit `{before["commit"]}` ({before["date"]}), `{before["command"]}`, '
                  f'{before["rounds"]} rounds, while the compiled codec was built:', '',
                  '| kind | rate, Hz | bytes | Python encode + decode, us | compiled encode + decode, us |',
                  '|---|---:|---:|---:|---:|']
        for kind, k in before['kinds'].items():
            lines.append(f'| {kind} | {before["rates_hz"][kind]} | {k["bytes"]} | {k["python_encode_us"]} + '
                         f'{k["python_decode_us"]} | {k["c_encode_us"]} + {k["c_decode_us"]} |')
        saving = before['python_percent_of_core'] - before['c_percent_of_core']
        ceiling = before['python_ceiling_percent_of_core'] - before['c_ceiling_percent_of_core']
        lines += ['', '| | Python codec | compiled codec | saving |', '|---|---:|---:|---:|',
                  f'| % of one core, 1 decode | {before["python_percent_of_core"]:.3f} | '
                  f'{before["c_percent_of_core"]:.3f} | {saving:.3f} |',
                  f'| % of one core, {CEILING_DECODES} decodes | {before["python_ceiling_percent_of_core"]:.3f} | '
                  f'{before["c_ceiling_percent_of_core"]:.3f} | {ceiling:.3f} |',
                  f'| `bench stack` total, % of one core (median of {before["stack_runs"]}, '
                  '`SOCIAL_TOUCH_CDR` set in each run) | '
                  f'{before["stack_percent"]["python"]:.2f} | {before["stack_percent"]["c"]:.2f} | '
                  f'{before["stack_percent"]["python"] - before["stack_percent"]["c"]:.2f} |', '',
                  f'Saving at the real rates: {ceiling:.3f} % of one core at most, '
                  f'{"under" if ceiling < THRESHOLD_PERCENT else "over"} the {THRESHOLD_PERCENT} % threshold. '
                  '`bench stack` runs the graph in one process (no message is encoded), so its two figures '
                  'differ by the machine\'s noise only.', '']
    if 'c_percent_of_core' not in f:
        lines += [f'Now (commit `{f["commit"]}`, {f["date"]}): the compiled codec is removed; the Python codec '
                  f'costs {f["python_percent_of_core"]:.3f} % of one core at the real rates '
                  f'({f["python_ceiling_percent_of_core"]:.3f} % with {CEILING_DECODES} decodes); `bench stack` '
                  f'total {f["stack_percent"]["python"]:.2f} % of one core.', '']
    return '\n'.join(lines)


#: section name -> (measure(repeats) -> figures, render(figures) -> markdown).
SECTIONS: dict[str, tuple[Callable[[int], dict[str, Any]], Callable[[dict[str, Any]], str]]] = {
    'cdr': (measure_cdr, render_cdr),
}


def _load() -> dict[str, Any]:
    return json.loads(FIGURES.read_text()) if FIGURES.exists() else {}


def render(figures: dict[str, Any]) -> str:
    """The whole report from every section's figures."""
    head = ['# Compiled code: what each compiled twin saves', '',
            'Generated by `python -m touch_lab.bench.compiled_code` (figures in docs/compiled-code.json); do '
            'not edit by hand. The design rule: compiled code only where it saves at least '
            f'{THRESHOLD_PERCENT} % of one core, or a latency a user feels, at the robot\'s real rates.', '']
    body = [SECTIONS[name][1](figures[name]) for name in SECTIONS if name in figures]
    return '\n'.join(head + body).rstrip() + '\n'


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m touch_lab.bench.compiled_code', description=__doc__.split('\n')[0])
    parser.add_argument('sections', nargs='*', help=f'what to measure, of {", ".join(SECTIONS)} (default: all)')
    parser.add_argument('--repeats', type=int, default=5, help='rounds to take the median of (default 5)')
    parser.add_argument('--render-only', action='store_true', help='rewrite the .md from the .json')
    args = parser.parse_args(argv)
    unknown = set(args.sections) - set(SECTIONS)
    if unknown:
        parser.error(f'unknown section(s) {", ".join(sorted(unknown))}; known: {", ".join(SECTIONS)}')
    figures = _load()
    if not args.render_only:
        for name in args.sections or list(SECTIONS):
            figures[name] = SECTIONS[name][0](args.repeats)
        FIGURES.write_text(json.dumps(figures, indent=1, sort_keys=True) + '\n')
    REPORT.write_text(render(figures))
    print(REPORT)
    return 0


if __name__ == '__main__':
    sys.exit(main())
