"""``social-touch eval bear``: run simulated people through the bear's graph and score the recognisers.

Text report by default; ``--json`` prints one JSON object (at least ``subtype_accuracy``,
``symbolic_accuracy``, ``median_detection_latency_s``, ``us_per_cycle``). Progress goes to stderr.
All data is synthetic (simulated people), and both outputs say so.
"""

from __future__ import annotations

import argparse
import json
import sys

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES
from touch_gestures.bear.symbolic import GestureLibrary
from touch_graph.cli.options import deprecated_alias, positive_float, positive_int, seed
from touch_graph.errors import SocialTouchError
from touch_graph.paths import share_file
from touch_lab.bear.evaluate import FAMILIES, EvalConfig, evaluate, percent_text, seconds_text, stderr_progress
from touch_lab.bear.false_starts import format_gesture_starts
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.collect.session_bag import SessionError

from .sessions import fold_models, load_runs
from .shipped import format_scores, score_model
from .transfer import cross_population, format_cross

__all__ = ['add_arguments', 'format_text', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval bear``."""
    parser.add_argument('--json', action='store_true', help='print one JSON object instead of the text report')
    parser.add_argument('--people', type=positive_int, default=6, help='simulated people in the test scene (6)')
    parser.add_argument('--train-people', type=positive_int, default=8,
                        help='other simulated people the subtype model is trained on (8)')
    parser.add_argument('--seed', type=seed, default=0, help='scene seed; the training scene uses seed + 1000 (0)')
    parser.add_argument('--rate', type=positive_float, default=3.4,
                        help='scan rate, Hz: 3.4 is the real bear (knight2009 VI.B), 25 the ideal (3.4)')
    parser.add_argument('--buffer', type=positive_int, default=20, help='cycles per sensor buffer (20, V.A)')
    repetitions = parser.add_argument('--repetitions', type=positive_int, default=2, metavar='N',
                                      help='repetitions of each subtype and gesture per person (2; >= 2 fills '
                                      'Table III)')
    deprecated_alias(parser, '--reps', repetitions)
    parser.add_argument('--bags', nargs='+', metavar='BAG',
                        help='session bags (social-touch collect bear): leave-one-person-out on them instead of '
                        'simulated scenes (or, with --model, that model scored on every person in them)')
    parser.add_argument('--model', metavar='FILE',
                        help='with --bags: score this subtype model (.npz, e.g. config/bear_subtype_model.npz) as it '
                        'is, on people it has not seen, instead of retraining leave-one-person-out')
    parser.add_argument('--gestures', metavar='YAML',
                        help='the symbolic gesture library (default: config/bear_gestures.yaml)')
    parser.add_argument('--family', choices=FAMILIES, default='script',
                        help='family of simulated people in the test scene: script (touch_sim/bear/people.py) or '
                        'hands (touch_sim/bear/hand_people.py, written independently) (script)')
    parser.add_argument('--train-family', choices=(*FAMILIES, 'both'), default='script',
                        help='family of the training scene, or both (script)')
    parser.add_argument('--cross', action='store_true',
                        help='across populations: a model fit on each family (and on all, and --model) measured on '
                        'the held-out people of every family')
    parser.add_argument('--quiet', action='store_true', help='no progress on stderr')


def _config(args: argparse.Namespace) -> EvalConfig:
    return EvalConfig(rate_hz=args.rate, buffer_len=args.buffer, n_people=args.people,
                      train_people=args.train_people, seed=args.seed, subtype_reps=args.repetitions,
                      gesture_reps=args.repetitions, family=args.family,
                      train_families=train_families(args.train_family), gestures=args.gestures)


def train_families(choice: str) -> tuple[str, ...]:
    """``--train-family`` as the families it names."""
    return FAMILIES if choice == 'both' else (choice,)


def format_text(result: dict) -> str:
    """The human-readable report of :func:`~.evaluate.evaluate`'s result."""
    m, r, cfg = result['model'], result['rule'], result['config']
    lines = [
        f"Sensate Bear recognisers, {cfg['rate_hz']} Hz scan, buffer {cfg['buffer_len']} cycles, "
        f"{cfg['n_people']} simulated people of the {cfg['family']!r} family (seed {cfg['seed']}), through the "
        'bear_driver node',
        f"DATA: {result['data']}",
        '',
        f"{'':40s} {'trained model':>14s} {'paper rule':>12s}",
        f"{'subtype accuracy (per interaction)':40s} {percent_text(m['subtype']['accuracy']):>14s} "
        f"{percent_text(r['subtype']['accuracy']):>12s}",
        f"{'subtype accuracy (per sensor-cycle)':40s} {percent_text(m['subtype']['frame_accuracy']):>14s} "
        f"{percent_text(r['subtype']['frame_accuracy']):>12s}",
        f"{'median subtype latency':40s} {seconds_text(m['subtype']['median_latency_s']):>14s} "
        f"{seconds_text(r['subtype']['median_latency_s']):>12s}",
        f"{'symbolic accuracy':40s} {percent_text(m['symbolic']['accuracy']):>14s} "
        f"{percent_text(r['symbolic']['accuracy']):>12s}",
        f"{'median symbolic latency (from onset)':40s} {seconds_text(m['symbolic']['median_latency_s']):>14s} "
        f"{seconds_text(r['symbolic']['median_latency_s']):>12s}",
        f"{'symbolic false alarms':40s} {m['symbolic']['false_alarms']:>14d} {r['symbolic']['false_alarms']:>12d}",
        f"{'compute per cycle (median, 56 sensors)':40s} {m['us_per_cycle']:>11.0f} us {r['us_per_cycle']:>9.0f} us",
        '',
        'Per subtype (trained model): precision / recall / median latency',
    ]
    for s in TOUCH_SUBTYPES:
        pc = m['subtype']['per_class'][s]
        lines.append(f"  {s:8s} {percent_text(pc['precision'])} / {percent_text(pc['recall'])} / "
                     f"{seconds_text(m['subtype']['median_latency_by_subtype_s'][s])}")
    lines += ['', 'Per symbolic gesture (trained-model subtypes): precision / recall / median latency']
    for g in m['symbolic']['labels']:
        if g == 'none':
            continue
        pc = m['symbolic']['per_class'][g]
        lines.append(f"  {g:13s} {percent_text(pc['precision'])} / {percent_text(pc['recall'])} / "
                     f"{seconds_text(m['symbolic']['median_latency_by_gesture_s'][g])}")
    lines += ['', *format_gesture_starts(m['symbolic']['gestures'])]
    lines += ['', 'Subtype confusion (trained model, per interaction; rows true, columns predicted)',
              '  ' + ' '.join(f'{s[:6]:>6s}' for s in ['', *m['subtype']['labels']])]
    for name, row in zip(m['subtype']['labels'], m['subtype']['confusion'], strict=True):
        lines.append('  ' + f'{name[:6]:>6s} ' + ' '.join(f'{v:6d}' for v in row))
    lines += ['', 'Table III shape (knight2009 VI.C): first try / with explanation / regional accuracy']
    for g, v in m['symbolic']['table_iii'].items():
        lines.append(f"  {g:9s} {percent_text(v['activated_first_try'])} / "
                     f"{percent_text(v['activated_with_explanation'])} / "
                     f"{percent_text(v['regional_accuracy'])}")
    if result.get('driver'):
        lines += ['', f"driver counters: {result['driver']}"]
    return '\n'.join(lines)


def run(args: argparse.Namespace) -> int:
    """Run the evaluation; 0 on success, 2 on a configuration error (message on stderr)."""
    if args.bags:
        return _run_bags(args)
    if args.cross:
        return _run_cross(args)
    try:
        model = _load_model(args) if args.model else None
        result = evaluate(_config(args), progress=None if args.quiet else stderr_progress, model=model)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval bear: error: {err}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps(result))
    else:
        print(format_text(result))
    return 0


def _run_bags(args: argparse.Namespace) -> int:
    """``eval bear --bags``: the given ``--model`` scored on recorded sessions as it ships, or leave-one-person-out
    (:mod:`.sessions`, :mod:`.shipped`); symbolic gestures with the model's subtype codes either way."""
    say = (lambda _m: None) if args.quiet else stderr_progress
    try:
        body_map = BodyMap.default()
        library = GestureLibrary.load(args.gestures or share_file('config', 'bear_gestures.yaml'), body_map)
        model = _load_model(args) if args.model else None
        runs = load_runs(args.bags, args.rate, args.buffer, say)
        if model is not None:
            result = score_model(runs, model, library, body_map, say)
            method = f'the given model {args.model}, not retrained, on every person of the bags'
        else:
            people = sorted({lab.person for r in runs for lab in r.labels})
            if len(people) < 2:
                raise SessionError(f'leave-one-person-out needs sessions of at least two people; got {people} '
                                   '(or give --model FILE to score a trained model on them)')
            folds = fold_models(runs, people, seed=args.seed, progress=say)
            result = score_model(runs, None, library, body_map, say, fold_models=folds)
            method = 'leave-one-person-out: each person scored by a model trained on the others'
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval bear: error: {err}', file=sys.stderr)
        return 2
    synthetic = any(r.session.synthetic for r in runs)
    result = {'method': method, **result, 'synthetic': synthetic, 'bags': list(args.bags),
              'gestures': str(library.source)}
    if args.json:
        print(json.dumps(result, default=_plain))
    else:
        print(format_scores(result, synthetic))
    return 0


def _run_cross(args: argparse.Namespace) -> int:
    """``eval bear --cross``: :func:`~.transfer.cross_population`."""
    try:
        models = {f'given {args.model}': _load_model(args)} if args.model else None
        result = cross_population(_config(args), models, progress=None if args.quiet else stderr_progress)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch eval bear: error: {err}', file=sys.stderr)
        return 2
    print(json.dumps(result) if args.json else format_cross(result))
    return 0


def _load_model(args: argparse.Namespace):
    """The ``--model`` file; ValueError when it was trained at another scan rate or buffer length."""
    model = SubtypeClassifier.load(args.model)
    rate, buffer = model.trained_rate_hz_, model.trained_buffer_len_
    if rate is not None and abs(rate / args.rate - 1) > 0.05:
        raise ValueError(f'{args.model} was trained at {rate:g} Hz; these bags are scored at --rate {args.rate:g} Hz '
                         '(the features depend on the scan rate)')
    if buffer is not None and buffer != args.buffer:
        raise ValueError(f'{args.model} was trained with a {buffer}-cycle buffer, not --buffer {args.buffer}')
    return model


def _plain(value):
    return value.tolist() if hasattr(value, 'tolist') else str(value)
