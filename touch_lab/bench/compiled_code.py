"""``social-touch report compiled-code``: what each compiled twin saves at the robot's real message rates.

Measures the named sections (all by default), keeps their figures in docs/compiled-code.json and renders
docs/compiled-code.md from them. One section per compiled twin (:data:`SECTIONS`): ``measure(repeats)
-> dict`` and ``render(figures) -> str``; a removed twin's section keeps the figures measured before
(with their commit) beside what runs now.
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

from touch_graph.cli.options import positive_int
from touch_graph.errors import ConfigError
from touch_graph.files import write_text
from touch_lab.bench.codec import bench_codec
from touch_lab.bench.replay import record_scene
from touch_lab.bench.stack import run_stack

__all__ = ['SECTIONS', 'add_arguments', 'render', 'run']


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


def _stack_percent(duration_s: float) -> float:
    """``bench stack``'s total (% of one core), in a child process of its own as the command runs it."""
    code = ('import json, sys; from touch_lab.bench.stack import bench_stack; '
            'print(json.dumps(bench_stack(repeats=1, duration_s=float(sys.argv[1]))["total"]["percent_of_core"]))')
    out = subprocess.run([sys.executable, '-c', code, str(duration_s)], capture_output=True, text=True, check=True)
    return float(out.stdout.strip().splitlines()[-1])


# --- the CDR codec (touch_graph.cdr; its compiled twin was touch_graph/_cdr_accel.c) ------------------------

def _message_rates(duration_s: float) -> dict[str, float]:
    """Messages per second of each kind at the sensors' real rates (the demo's people scenes, synthetic)."""
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
    """The codec per message kind (``bench codec``), ``bench stack``, the codec's cost at the real rates.

    The compiled twin's figures, measured while it was built (``compiled_measured``), are kept from the
    figures file: the command that took them is that commit's version of this one.
    """
    load = os.getloadavg()[0]  # before the measuring adds its own
    codec = bench_codec(repeats=repeats)
    duration_s = 20.0
    rates = _message_rates(duration_s)
    stack = [_stack_percent(duration_s) for _ in range(repeats)]
    return {'commit': _commit(), 'date': datetime.date.today().isoformat(), 'load_average_1min': round(load, 1),
            'cores': os.cpu_count(),
            'command': 'social-touch report compiled-code cdr', 'rounds': repeats,
            'rates_hz': {k: round(v, 3) for k, v in rates.items()}, 'kinds': codec['kinds'],
            'stack_percent': {'python': round(statistics.median(stack), 3)}, 'stack_runs': repeats,
            'python_percent_of_core': _percent_of_core(codec['kinds'], rates, 'python', 1),
            'python_ceiling_percent_of_core': _percent_of_core(codec['kinds'], rates, 'python', CEILING_DECODES),
            'compiled_measured': _load().get('cdr', {}).get('compiled_measured')}


def _kinds_table(figures: dict[str, Any], *codecs: tuple[str, str]) -> list[str]:
    """Markdown rows: per kind its rate, bytes and each codec's encode + decode us (``(key, title)`` each)."""
    rows = ['| kind | rate, Hz | bytes | ' + ' | '.join(f'{title} encode + decode, us' for _, title in codecs) + ' |',
            '|---|---:|---:|' + '---:|' * len(codecs)]
    for kind, k in figures['kinds'].items():
        rows.append(f'| {kind} | {figures["rates_hz"][kind]} | {k["bytes"]} | '
                    + ' | '.join(f'{k[f"{key}_encode_us"]} + {k[f"{key}_decode_us"]}' for key, _ in codecs) + ' |')
    return rows


def render_cdr(f: dict[str, Any]) -> str:
    before = f.get('compiled_measured')
    lines = ['## The CDR codec (touch_graph/cdr.py; compiled twin touch_graph/_cdr_accel.c)', '',
             'Every message that crosses processes is encoded once and decoded once per subscribing process. '
             'Per message kind, the median us per call over the rounds (`bench codec`: the codecs in one '
             'process, in turns, synthetic messages of the real sizes), then the cost at the real message '
             'rates (frames at each sensor\'s rate; gesture events at the rate the recognisers perceive them '
             'in the demo\'s people scenes, synthetic) as % of one core: one encode and one decode per message, '
             f'and a ceiling with {CEILING_DECODES} decodes (recogniser, recorder, view).', '']
    if before:
        lines += [f'Before: measured at commit `{before["commit"]}` ({before["date"]}), that commit\'s '
                  f'`{before["command"]}`, {before["rounds"]} rounds, with the compiled codec built:', '',
                  *_kinds_table(before, ('python', 'Python'), ('c', 'compiled'))]
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
    if 'python_percent_of_core' in f:
        lines += [f'After: the compiled codec is removed. Measured at commit `{f["commit"]}` ({f["date"]}), '
                  f'`{f["command"]}`, {f["rounds"]} rounds, machine load average {f["load_average_1min"]} on '
                  f'{f["cores"]} cores; CPU time per call, rosbags\' generic serialiser beside ours:', '',
                  *_kinds_table(f, ('python', 'our codec'), ('rosbags', 'rosbags'))]
        lines += ['', f'The codec costs {f["python_percent_of_core"]:.3f} % of one core at the real rates '
                  f'({f["python_ceiling_percent_of_core"]:.3f} % with {CEILING_DECODES} decodes); `bench stack` '
                  f'total: {f["stack_percent"]["python"]:.2f} % of one core (median of {f["stack_runs"]}). A compiled '
                  'codec could save at most the whole codec\'s cost: '
                  f'{"under" if f["python_ceiling_percent_of_core"] < THRESHOLD_PERCENT else "over"} the '
                  f'{THRESHOLD_PERCENT} % threshold.', '']
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
            'Generated by `social-touch report compiled-code` (figures in docs/compiled-code.json); do '
            'not edit by hand. The design rule: compiled code only where it saves at least '
            f'{THRESHOLD_PERCENT} % of one core, or a latency a user feels, at the robot\'s real rates.', '']
    body = [SECTIONS[name][1](figures[name]) for name in SECTIONS if name in figures]
    return '\n'.join(head + body).rstrip() + '\n'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('sections', nargs='*', help=f'what to measure, of {", ".join(SECTIONS)} (default: all)')
    parser.add_argument('--repeats', type=positive_int, default=5, help='rounds to take the median of (default 5)')
    parser.add_argument('--render-only', action='store_true', help='rewrite the .md from the .json')


def run(args: argparse.Namespace) -> int:
    unknown = set(args.sections) - set(SECTIONS)
    if unknown:
        raise ConfigError(f'unknown section(s) {", ".join(sorted(unknown))}; known: {", ".join(SECTIONS)}')
    figures = _load()
    if not args.render_only:
        for name in args.sections or list(SECTIONS):
            figures[name] = SECTIONS[name][0](args.repeats)
        write_text(FIGURES, json.dumps(figures, indent=1, sort_keys=True) + '\n')
    write_text(REPORT, render(_load()))  # as read back (keys sorted), so the report is its file's rendering
    print(REPORT)
    return 0
