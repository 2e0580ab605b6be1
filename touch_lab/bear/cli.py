"""``social-touch eval bear``: run simulated people through the bear's graph and score the recognisers.

Text report by default; ``--json`` prints one JSON object (at least ``subtype_accuracy``,
``symbolic_accuracy``, ``median_detection_latency_s``, ``us_per_cycle``). Progress goes to stderr.
All data is synthetic (simulated people), and both outputs say so.
"""

from __future__ import annotations

import argparse
import json
import math
import sys

from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES
from touch_lab.bear.evaluate import EvalConfig, evaluate, stderr_progress

__all__ = ['HELP', 'add_arguments', 'format_text', 'run']

HELP = 'evaluate the Sensate Bear recognisers on simulated people (synthetic)'


def positive_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected a number, got {text!r}') from None
    if not (value > 0 and math.isfinite(value)):
        raise argparse.ArgumentTypeError(f'expected a positive number, got {text!r}')
    return value


def positive_int(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f'expected an integer, got {text!r}') from None
    if value < 1:
        raise argparse.ArgumentTypeError(f'expected an integer >= 1, got {text!r}')
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval bear``."""
    parser.add_argument('--json', action='store_true', help='print one JSON object instead of the text report')
    parser.add_argument('--people', type=positive_int, default=6, help='simulated people in the test scene (6)')
    parser.add_argument('--train-people', type=positive_int, default=8,
                        help='other simulated people the subtype model is trained on (8)')
    parser.add_argument('--seed', type=int, default=0, help='scene seed; the training scene uses seed + 1000 (0)')
    parser.add_argument('--rate', type=positive_float, default=3.4,
                        help='scan rate, Hz: 3.4 is the real bear (knight2009 VI.B), 25 the ideal (3.4)')
    parser.add_argument('--buffer', type=positive_int, default=20, help='cycles per sensor buffer (20, V.A)')
    parser.add_argument('--reps', type=positive_int, default=2,
                        help='repetitions of each subtype and gesture per person (2; >= 2 fills Table III)')
    parser.add_argument('--bags', nargs='+', metavar='BAG',
                        help='session bags (social-touch collect bear): leave-one-person-out on them instead of '
                        'simulated scenes')
    parser.add_argument('--quiet', action='store_true', help='no progress on stderr')


def _config(args: argparse.Namespace) -> EvalConfig:
    return EvalConfig(rate_hz=args.rate, buffer_len=args.buffer, n_people=args.people,
                      train_people=args.train_people, seed=args.seed, subtype_reps=args.reps,
                      gesture_reps=args.reps)


def _pct(value) -> str:
    return 'n/a' if value is None else f'{100 * value:5.1f} %'


def _sec(value) -> str:
    return 'n/a' if value is None else f'{value:.2f} s'


def format_text(result: dict) -> str:
    """The human-readable report of :func:`~.evaluate.evaluate`'s result."""
    m, r, cfg = result['model'], result['rule'], result['config']
    lines = [
        f"Sensate Bear recognisers, {cfg['rate_hz']} Hz scan, buffer {cfg['buffer_len']} cycles, "
        f"{cfg['n_people']} simulated people (seed {cfg['seed']}), through the bear_driver node",
        f"DATA: {result['data']}",
        '',
        f"{'':40s} {'trained model':>14s} {'paper rule':>12s}",
        f"{'subtype accuracy (per interaction)':40s} {_pct(m['subtype']['accuracy']):>14s} "
        f"{_pct(r['subtype']['accuracy']):>12s}",
        f"{'subtype accuracy (per sensor-cycle)':40s} {_pct(m['subtype']['frame_accuracy']):>14s} "
        f"{_pct(r['subtype']['frame_accuracy']):>12s}",
        f"{'median subtype latency':40s} {_sec(m['subtype']['median_latency_s']):>14s} "
        f"{_sec(r['subtype']['median_latency_s']):>12s}",
        f"{'symbolic accuracy':40s} {_pct(m['symbolic']['accuracy']):>14s} {_pct(r['symbolic']['accuracy']):>12s}",
        f"{'median symbolic latency (from onset)':40s} {_sec(m['symbolic']['median_latency_s']):>14s} "
        f"{_sec(r['symbolic']['median_latency_s']):>12s}",
        f"{'symbolic false alarms':40s} {m['symbolic']['false_alarms']:>14d} {r['symbolic']['false_alarms']:>12d}",
        f"{'compute per cycle (median, 56 sensors)':40s} {m['us_per_cycle']:>11.0f} us {r['us_per_cycle']:>9.0f} us",
        '',
        'Per subtype (trained model): precision / recall / median latency',
    ]
    for s in TOUCH_SUBTYPES:
        pc = m['subtype']['per_class'][s]
        lines.append(f"  {s:8s} {_pct(pc['precision'])} / {_pct(pc['recall'])} / "
                     f"{_sec(m['subtype']['median_latency_by_subtype_s'][s])}")
    lines += ['', 'Per symbolic gesture (trained-model subtypes): precision / recall / median latency']
    for g in m['symbolic']['labels']:
        if g == 'none':
            continue
        pc = m['symbolic']['per_class'][g]
        lines.append(f"  {g:13s} {_pct(pc['precision'])} / {_pct(pc['recall'])} / "
                     f"{_sec(m['symbolic']['median_latency_by_gesture_s'][g])}")
    lines += ['', 'Subtype confusion (trained model, per interaction; rows true, columns predicted)',
              '  ' + ' '.join(f'{s[:6]:>6s}' for s in ['', *m['subtype']['labels']])]
    for name, row in zip(m['subtype']['labels'], m['subtype']['confusion'], strict=True):
        lines.append('  ' + f'{name[:6]:>6s} ' + ' '.join(f'{v:6d}' for v in row))
    lines += ['', 'Table III shape (knight2009 VI.C): first try / with explanation / regional accuracy']
    for g, v in m['symbolic']['table_iii'].items():
        lines.append(f"  {g:9s} {_pct(v['activated_first_try'])} / {_pct(v['activated_with_explanation'])} / "
                     f"{_pct(v['regional_accuracy'])}")
    if result.get('driver'):
        lines += ['', f"driver counters: {result['driver']}"]
    return '\n'.join(lines)


def run(args: argparse.Namespace) -> int:
    """Run the evaluation; 0 on success, 2 on a configuration error (message on stderr)."""
    from touch_graph.errors import SocialTouchError

    if args.bags:
        return _run_bags(args)
    try:
        result = evaluate(_config(args), progress=None if args.quiet else stderr_progress)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval bear: error: {err}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result))
    else:
        print(format_text(result))
    return 0



def _run_bags(args: argparse.Namespace) -> int:
    """``eval bear --bags``: leave-one-person-out on recorded sessions (:mod:`.sessions`)."""
    from touch_graph.errors import SocialTouchError

    from .sessions import format_lopo, leave_one_person_out, load_runs
    say = (lambda _m: None) if args.quiet else stderr_progress
    try:
        runs = load_runs(args.bags, args.rate, args.buffer, say)
        result = leave_one_person_out(runs, seed=args.seed, progress=say)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval bear: error: {err}', file=sys.stderr)
        return 2
    synthetic = any(r.session.synthetic for r in runs)
    if args.json:
        print(json.dumps({**result, 'synthetic': synthetic, 'bags': list(args.bags)}, default=_plain))
    else:
        print(format_lopo(result, synthetic))
    return 0


def _plain(value):
    return value.tolist() if hasattr(value, 'tolist') else str(value)
