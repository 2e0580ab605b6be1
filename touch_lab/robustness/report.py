"""``social-touch report robustness``: regenerate docs/robustness.md (bad input and faults, about 3 minutes).

Runs every case of :mod:`touch_lab.robustness.cases` (out-of-range parameters, ports that can never
open, broken config, model and codebook files, command-line arguments, impossible recogniser input)
and measures the figures of :mod:`touch_lab.robustness.figures` (floods of fake headers, recovery
after an unplug, a recorder killed with SIGKILL, corrupted bag chunks). Per area: cases tried, clear
errors, handled, tracebacks, crashes, wrong results, data lost.
"""

from __future__ import annotations

import argparse
import datetime
import platform
from collections import Counter
from pathlib import Path
from typing import Any

from touch_graph.cli.options import add_output, positive_float
from touch_graph.files import write_text

from .cases import CLEAR, CRASH, HANDLED, HANG, LOST, TRACEBACK, WRONG, Outcome, all_cases, run_case, run_cli
from .dds_injection import dds_injection
from .figures import bag_corruption, flood, recorder_kill, unplug_recovery

__all__ = ['add_arguments', 'run', 'run_all', 'write_report']

RESULTS = (CLEAR, HANDLED, TRACEBACK, HANG, WRONG, LOST, CRASH)


def run_all(say=print, megabytes: float = 4.0) -> tuple[list[Outcome], dict[str, Any]]:
    """Every case and every figure."""
    outcomes = []
    for area, case, what in all_cases():
        outcome = run_cli(area, case, what) if isinstance(what, list) else run_case(area, case, what)
        say(f'{outcome.result:<12} {area}: {case}')
        outcomes.append(outcome)
    figures: dict[str, Any] = {}
    for name, measure in (('flood', lambda: flood(megabytes)), ('unplug', unplug_recovery),
                          ('recorder_kill', recorder_kill), ('bag_corruption', bag_corruption),
                          ('dds_injection', dds_injection)):
        say(f'measuring {name} ...')
        figures[name] = measure()
    return outcomes, figures


def _table(outcomes: list[Outcome]) -> list[str]:
    areas = list(dict.fromkeys(o.area for o in outcomes))
    lines = ['| area | cases | clear errors | handled | tracebacks | hangs | wrong | data lost | crashes |',
             '|---|---|---|---|---|---|---|---|---|']
    total: Counter = Counter()
    for area in areas:
        counts = Counter(o.result for o in outcomes if o.area == area)
        total.update(counts)
        lines.append(f'| {area} | {sum(counts.values())} | ' + ' | '.join(str(counts[r]) for r in RESULTS) + ' |')
    lines.append(f'| **all** | **{sum(total.values())}** | ' + ' | '.join(f'**{total[r]}**' for r in RESULTS) + ' |')
    return lines


def _figures(fig: dict[str, Any]) -> list[str]:
    fl, up, kill, bag = fig['flood'], fig['unplug'], fig['recorder_kill'], fig['bag_corruption']
    lines = ['| figure | value | how |', '|---|---|---|']
    for kind, r in fl.items():
        lines.append(f'| bogus frames per MB, flood `{kind}` | {r["bogus_frames"] / r["megabytes"]:.0f} '
                     f'({r["bogus_frames"]} in {r["megabytes"]:.1f} MB; {r["lost_frames"]} of {r["real_frames"]} '
                     f'real frames lost) | fake headers with real frames between, one decoder of every id '
                     f'(synthetic) |')
    recovery = ', '.join(f'{s:.2f}' for s in up['recovery_s'])
    lines.append(f'| recovery after unplug (s) | max {up["max_recovery_s"]:.2f} (runs: {recovery}) | skin driver '
                 f'on `skinsim://` unplugged 2 s, replugged at 4 phases of the {up["reconnect_period_s"]:g} s '
                 f'reconnect period, simulated time; ERROR on /diagnostics while unplugged: '
                 f'{"yes" if up["error_while_unplugged"] else "NO"} |')
    lines.append(f'| messages lost on kill -9 of a recorder | {kill["lost"]} of {kill["published"]} '
                 f'({kill["lost_s_at_200_hz"]:.2f} s of a 200 Hz topic; flush period {kill["flush_period_s"]:g} s); '
                 f'recovered: a gapless prefix: {"yes" if kill["gapless_prefix"] else "NO"} | a real process '
                 f'killed with SIGKILL, then `social-touch bag reindex` |')
    det = bag['detected']
    lines.append(f'| bag corruptions detected (of {bag["corruptions"]}) | reindex {det["reindex"]}, rosbags reader '
                 f'{det["rosbags_reader"]}, mcap reader with `validate_crcs=True` {det["mcap_reader_crc_on"]} '
                 f'(its default, no check: {det["mcap_reader_default"]}) | one bit flipped in the records of a '
                 'chunk, 8 places over 3 chunks |')
    return lines


def _dds(dds: dict[str, Any]) -> list[str]:
    if not dds.get('measured'):
        return [f'Not measured on this machine: {dds["why"]}.']
    who = f'another process, of uid {dds["intruder_uid"]} (our graph: uid {dds["our_uid"]})'
    note = f' ({dds["note"]}: DDS over UDP carries no user id.)' if dds['note'] else ''
    return [
        f'Measured: {who}, joined our DDS domain ({dds["discovery"]} discovery, the defaults otherwise) and '
        f'published {dds["sent"]} `/touch/haptic_command` messages; our subscription received '
        f'**{dds["received"]} of {dds["sent"]}** (senders: {", ".join(dds["senders"]) or "none"}).{note}',
        '',
        'What holds: nothing of the transport is a file or socket path another user could take over (the '
        'Unix-socket bridge of issue 12 is gone; `test/test_dds_bad_input.py` checks that nothing '
        'world-writable appears), a foreign layout under our type name is refused and reported, and a '
        'sample that does not decode is counted and skipped. What the defaults allow: any process that '
        'joins the domain, of any user on this machine (and, with `SUBNET` discovery, any host on the '
        'network), can read every topic and publish on any, as measured above; `LOCALHOST` keeps other '
        'machines out, not other users; a domain id separates graphs, it does not protect them. What a '
        'user can do (docs/network.md): run the nodes under ROS 2 with SROS2 (DDS Security: signed '
        'permissions per enclave; our own DDS layer does not load the security plugins), or keep the '
        'graph on a machine or network of its own with a domain id nobody else uses.',
    ]


def write_report(path: str | Path = 'docs/robustness.md', say=print, megabytes: float = 4.0) -> Path:
    """Run everything and write the report; returns its path."""
    outcomes, figures = run_all(say, megabytes)
    counts = Counter(o.result for o in outcomes)
    bogus = sum(r['bogus_frames'] for r in figures['flood'].values())
    dead_healthy = sum(o.result == WRONG for o in outcomes if o.area.startswith('driver faults'))
    lines = [
        '# Robustness: bad input and faults, tried',
        '',
        f'Generated by `social-touch report robustness` on {datetime.date.today().isoformat()} '
        f'(Python {platform.python_version()}); do not edit by hand. Issue 12. All sensor data is **synthetic** '
        '(virtual devices, written frames); the processes, pseudo-terminals and bag files are real.',
        '',
        f'**{counts[TRACEBACK]} tracebacks, {counts[HANG]} hangs, {counts[WRONG]} wrong results, {counts[LOST]} '
        f'with data lost, {counts[CRASH]} crashes, '
        f'{bogus} bogus frames, {dead_healthy} silently healthy dead drivers** in {len(outcomes)} cases and '
        f'{sum(r["megabytes"] for r in figures["flood"].values()):.0f} MB of floods.',
        '',
        'Outcomes: *clear error*: the stack refused the input with one of its errors, naming what is wrong '
        '(and the file and line when it came from a file); a command exited non-zero with a message and no '
        'traceback. *handled*: accepted and dealt with as it should, counted and reported (counted and '
        'skipped, WARN or ERROR on /diagnostics, or the reconnect loop). *traceback*: any other exception. '
        '*hang*: no answer within the case\'s time (a command killed after it; an in-process case after '
        '300 s). *wrong*: it returned, but silently did the wrong thing (for a driver fault: a driver '
        'publishing nothing while /diagnostics says OK). *data lost*: something already recorded or saved '
        'was lost. *crash*: a process killed by a signal it did not ask for.',
        '',
        '## Per area',
        '',
        *_table(outcomes),
        '',
        '## Figures',
        '',
        *_figures(figures),
        '',
        '## Another local user on the DDS domain',
        '',
        *_dds(figures['dds_injection']),
        '',
        '## Every case',
        '',
        '| area | case | outcome | what the user sees |',
        '|---|---|---|---|',
    ]
    for o in outcomes:
        detail = o.detail.replace('|', '\\|')
        lines.append(f'| {o.area} | `{o.case}` | {o.result} | {detail} |')
    lines += ['', 'The same behaviours are checked case by case in `test/test_robustness_*.py` (CI), with '
              'hypothesis where it fits, and the framing by `test/test_driver_framing.py`.', '']
    path = Path(path)
    write_text(path, '\n'.join(lines))
    return path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    add_output(parser, 'where to write (default docs/robustness.md)', default='docs/robustness.md')
    parser.add_argument('--megabytes', type=positive_float, default=4.0, help='MB per flood (default 4)')


def run(args: argparse.Namespace) -> int:
    if not args.megabytes > 0:
        raise SystemExit('social-touch report robustness: --megabytes must be > 0')
    print(f'wrote {write_report(args.output, megabytes=args.megabytes)}')
    return 0
