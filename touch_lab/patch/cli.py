"""``social-touch train patch`` and ``social-touch eval patch``.

Sources (one of): ``--csv FILE --grid RxC --rate HZ`` (CoST-layout CSV), ``--bags`` (session bags or a
YAML manifest of /patch/frame recordings), ``--simulate N`` (SYNTHETIC people on the virtual patch).
``train`` fits one Gaussian mixture per class and writes a model file (``.npz``, no pickle); ``eval``
runs leave-one-subject-out with a grid search over components, threshold and dwell and prints Fig. 6 of
sympartner2018 (``--json``: one JSON object). Progress goes to stderr.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import shlex
import sys
from pathlib import Path

import numpy as np

from touch_gestures.model_card import attach_card, make_card
from touch_gestures.patch.features import window_features
from touch_gestures.patch.model_io import PatchModel, load_model, save_model
from touch_graph.cli.options import (
    non_negative_seconds,
    positive_float,
    positive_int,
    probability,
    rate_hz,
    seconds,
    seed,
)
from touch_lab.cards import session_data
from touch_lab.cli.targets import Target
from touch_lab.collect.coverage import read_checked
from touch_lab.patch.datasets import Session, parse_grid, read_bag_manifest, read_cost_csv, render_session
from touch_lab.patch.evaluate import leave_one_subject_out, score_model
from touch_lab.patch.session_bags import common_rate, trial_sessions
from touch_lab.patch.training import PatchGestureClassifier
from touch_sim.patch import people as patch_people

__all__ = ['EVAL', 'TRAIN', 'add_eval_arguments', 'add_train_arguments', 'load_sessions', 'run_eval', 'run_train']


def _progress(args: argparse.Namespace):
    if getattr(args, 'quiet', False):
        return lambda _msg: None
    return lambda msg: print(f'[patch] {msg}', file=sys.stderr, flush=True)


class _Renamed(argparse.Action):
    """An option's old spelling: still accepted, with a warning naming the new one."""

    def __init__(self, *args, new: str, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.new = new

    def __call__(self, parser, namespace, values, option_string=None) -> None:
        print(f'warning: {option_string} is deprecated: use {self.new}', file=sys.stderr)
        setattr(namespace, self.dest, values)


def _floats(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(',') if v.strip()]
    except ValueError:
        values = []
    if not values or not all(math.isfinite(v) and v >= 0 for v in values):
        raise argparse.ArgumentTypeError(f'expected comma-separated numbers >= 0 such as 0.9,0.99; got {text!r}')
    return values


def _ints(text: str) -> list[int]:
    try:
        values = [int(v) for v in text.split(',') if v.strip()]
    except ValueError:
        values = []
    if not values or not all(1 <= v <= 1000 for v in values):
        raise argparse.ArgumentTypeError(f'expected comma-separated integers in [1, 1000] such as 3,5,7; got {text!r}')
    return values


def _grid(text: str) -> tuple[int, int]:
    try:
        return parse_grid(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def _add_source_arguments(parser: argparse.ArgumentParser) -> None:
    src = parser.add_mutually_exclusive_group(required=True)
    src.add_argument('--csv', metavar='FILE', help='CoST-layout CSV: subject,variant,gesture,frame,ch1..chN')
    src.add_argument('--bags', metavar='BAG', nargs='+',
                     help='session bags (social-touch collect patch: labels on /touch/label), or one YAML manifest '
                     'of single-gesture recordings of /patch/frame')
    src.add_argument('--simulate', metavar='PEOPLE', type=positive_int, help='simulated people (SYNTHETIC data)')
    parser.add_argument('--grid', type=_grid, help='activation map ROWSxCOLS (CSV: required, e.g. 8x8 for CoST; '
                        'bags: 16x16)')
    parser.add_argument('--rate', type=rate_hz, help='frame rate of the CSV, Hz (CoST: 135)')
    parser.add_argument('--values', choices=('raw', 'activation'), default='raw',
                        help='CSV values: raw counts (converted by eq. 1-2) or activations (default raw)')
    parser.add_argument('--gain', type=positive_float,
                        help='eq. (2) gain per count for raw CSV values (default 1/1023)')
    parser.add_argument('--events', type=positive_int, default=6, help='simulated gestures per session (default 6)')
    parser.add_argument('--seed', type=seed, default=0, help='seed of the simulated people and of EM (default 0)')
    parser.add_argument('--window-s', type=seconds, default=3.0, help='window length, s (paper: 3 s)')
    parser.add_argument('--covariance', choices=('full', 'diag', 'tied', 'spherical'), default='full',
                        help='mixture covariance type (default full)')
    parser.add_argument('--reg-covar', type=positive_float, default=1e-3,
                        help='added to covariance diagonals, standardised units (default 1e-3)')
    parser.add_argument('--release', type=probability, default=0.9, help='event rule release posterior (default 0.9)')
    parser.add_argument('--quiet', action='store_true', help='no progress on stderr')


def load_sessions(args: argparse.Namespace, progress=None) -> list[Session]:
    """The labelled sessions the arguments name (see the module docstring)."""
    say = progress or (lambda _m: None)
    if args.csv:
        if args.grid is None or args.rate is None:
            raise SystemExit('--csv needs --grid ROWSxCOLS and --rate HZ (CoST: --grid 8x8 --rate 135)')
        say(f'reading {args.csv}')
        return read_cost_csv(args.csv, grid=args.grid, rate_hz=args.rate, values=args.values, gain=args.gain)
    if args.bags and len(args.bags) == 1 and args.bags[0].endswith(('.yaml', '.yml')):
        say(f'reading bags listed in {args.bags[0]}')
        return read_bag_manifest(args.bags[0], grid=args.grid or (16, 16))
    if args.bags:
        return trial_sessions(read_checked(args.bags, 'patch', say), say)
    if args.simulate < 2:
        raise SystemExit('--simulate needs at least 2 people (leave-one-subject-out)')
    out = []
    data = patch_people.simulate_people(args.simulate, args.events, seed=args.seed)
    for i, (person, gesture, scene) in enumerate(data):
        say(f'simulating {person.name} {gesture} ({i + 1}/{len(data)}, SYNTHETIC)')
        out.append(render_session(scene, person.name, gesture, seed=args.seed * 7919 + i))
    return out


# ---------------------------------------------------------------------- train
def add_train_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``social-touch train patch``."""
    _add_source_arguments(parser)
    parser.add_argument('--output', '-o', required=True, help='model file to write (.npz)')
    parser.add_argument('--components', type=positive_int, default=5,
                        help='mixture components per class (paper: 5)')
    parser.add_argument('--threshold', type=probability, default=0.99,
                        help='posterior threshold for events (paper: 0.99)')
    parser.add_argument('--evaluate', action='store_true',
                        help="also evaluate leave-one-person-out with these settings and record the figures in "
                        "the model's card")
    parser.add_argument('--dwell-s', type=non_negative_seconds, default=0.4,
                        help='time a class must stay above the threshold before an event, s (default 0.4; '
                        'one frame is the paper rule)')
    parser.add_argument('--hold-s', dest='dwell_s', type=non_negative_seconds, action=_Renamed, new='--dwell-s',
                        help=argparse.SUPPRESS)


def run_train(args: argparse.Namespace) -> int:
    """Fit on every frame of every session and write the model file; returns the exit code."""
    say = _progress(args)
    sessions = load_sessions(args, say)
    try:
        rate = common_rate([s.rate_hz for s in sessions], [s.source for s in sessions])
    except ValueError as err:
        raise SystemExit(f'train patch: {err}') from None
    window = max(1, round(args.window_s * rate))
    grids = {s.grid for s in sessions}
    if len(grids) != 1:
        raise SystemExit(f'sessions have different grids {sorted(grids)}')
    say(f'features of {len(sessions)} sessions, window {window} frames at {rate:g} Hz')
    X = np.concatenate([window_features(s.activations, window) for s in sessions])
    y = np.concatenate([[s.gesture] * s.n_frames for s in sessions])
    for name, count in zip(*np.unique(y, return_counts=True), strict=True):
        if count < args.components:  # a mixture cannot have more components than points
            raise SystemExit(f'train patch: class {name!r} has {count} frames, fewer than --components '
                             f'{args.components}; record more trials of {name!r} or give --components '
                             f'{max(1, count // 10)} (about ten frames per component)')
    say(f'fitting {args.components} components per class on {len(X)} frames')
    try:
        clf = PatchGestureClassifier(n_components=args.components, threshold=args.threshold,
                                     covariance_type=args.covariance, reg_covar=args.reg_covar,
                                     random_state=args.seed).fit(X, y)
    except ValueError as err:  # one class only, bad settings: say so, no traceback
        raise SystemExit(f'train patch: {err}') from err
    model = PatchModel(clf, window=window, rate_hz=rate, grid=sessions[0].grid, release=args.release,
                       dwell=max(1, round(args.dwell_s * rate)), metadata=_training_metadata(args, sessions, len(X)))
    save_model(args.output, model)
    synthetic = any(s.synthetic for s in sessions)
    rows = [(s.subject, s.gesture) for s in sessions for _ in range(len(s.events) if s.events else 1)]
    data = session_data(rows, synthetic=synthetic, bags=args.bags,
                        source=model.metadata['data'] if not args.bags else '')
    evaluation = None
    if args.evaluate:
        result = leave_one_subject_out(sessions, n_components=[args.components], thresholds=[args.threshold],
                                       dwells_s=[args.dwell_s], window_s=args.window_s, release=args.release,
                                       covariance_type=args.covariance, reg_covar=args.reg_covar,
                                       random_state=args.seed, progress=say).as_dict()
        evaluation = {'method': 'leave-one-person-out on the training data with these settings (sympartner2018 '
                      'Fig. 6 figures)', 'synthetic': synthetic,
                      **{k: result[k] for k in ('event_correct_rate', 'false_detection_rate', 'miss_rate',
                                                'median_detection_latency_s', 'tpr_all_samples', 'n_events')}}
    attach_card(args.output, make_card('patch_gesture_model', data={**data, 'frames': len(X)},
                                       evaluation=evaluation))
    synthetic = ' (SYNTHETIC data)' if any(s.synthetic for s in sessions) else ''
    say(f'wrote {args.output}: classes {", ".join(model.classes)}, components {clf.n_components_.tolist()}'
        f'{synthetic}')
    return 0


def _training_metadata(args: argparse.Namespace, sessions: list[Session], n_frames: int) -> dict:
    """What a model file records about how it was made (model_io's optional ``metadata``)."""
    if args.csv or args.bags:
        data = f"{'CSV' if args.csv else 'bags'} {args.csv or ' '.join(args.bags)}"
    else:
        data = (f'simulated people (SYNTHETIC): {args.simulate} people x {args.events} events per gesture, seed '
                f'{args.seed}, through the virtual patch and patch_driver (touch_sim/patch/people.py)')
    prog = Path(sys.argv[0]).name if sys.argv and sys.argv[0] else 'social-touch'
    return {
        'synthetic': any(s.synthetic for s in sessions), 'data': data,
        'subjects': len({s.subject for s in sessions}), 'sessions': len(sessions), 'frames': int(n_frames),
        'seed': int(args.seed), 'components': int(args.components), 'covariance': args.covariance,
        'reg_covar': float(args.reg_covar), 'command': shlex.join([prog, *sys.argv[1:]]),
        'created_utc': datetime.datetime.now(datetime.timezone.utc).strftime('%Y-%m-%dT%H:%M:%SZ'),
    }


# ---------------------------------------------------------------------- eval
def add_eval_arguments(parser: argparse.ArgumentParser) -> None:
    """Arguments of ``social-touch eval patch``."""
    _add_source_arguments(parser)
    parser.add_argument('--components', type=_ints, default=[3, 5, 7],
                        help='grid of components per class (default 3,5,7)')
    parser.add_argument('--thresholds', type=_floats, default=[0.9, 0.99, 0.999],
                        help='grid of posterior thresholds (default 0.9,0.99,0.999)')
    parser.add_argument('--dwells-s', type=_floats, default=[0.05, 0.25, 0.4],
                        help='grid of event dwell times, s (default 0.05,0.25,0.4; 0.05 s = one frame = the paper)')
    parser.add_argument('--holds-s', dest='dwells_s', type=_floats, action=_Renamed, new='--dwells-s',
                        help=argparse.SUPPRESS)
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--model', metavar='FILE', help='score this trained model (.npz) as it is on the sessions, '
                        'without retraining (its own window, threshold and hold)')


def run_eval(args: argparse.Namespace) -> int:
    """Leave-one-subject-out evaluation with grid search; prints a report or JSON."""
    say = _progress(args)
    sessions = load_sessions(args, say)
    if args.model:
        return _eval_model(args, sessions)
    try:
        result = leave_one_subject_out(sessions, n_components=args.components, thresholds=args.thresholds,
                                       dwells_s=args.dwells_s, window_s=args.window_s, release=args.release,
                                       covariance_type=args.covariance, reg_covar=args.reg_covar,
                                       random_state=args.seed, progress=say)
    except ValueError as err:  # too few subjects or classes, mixed rates: say so, no traceback
        raise SystemExit(f'eval patch: {err}') from err
    report = result.as_dict()
    report['source'] = args.csv or (args.bags and ' '.join(args.bags)) or \
        f'simulated people: {args.simulate} (seed {args.seed}, virtual patch and patch_driver node)'
    if args.json:
        print(json.dumps(_jsonable(report), indent=2))
    else:
        print(format_report(report))
    return 0


def _eval_model(args: argparse.Namespace, sessions) -> int:
    """``eval patch --model FILE``: :func:`~touch_lab.patch.evaluate.score_model`."""
    try:
        report = score_model(sessions, load_model(args.model))
    except ValueError as err:   # ModelFileError is one too
        raise SystemExit(f'eval patch: {err}') from err
    report['model'] = args.model
    print(json.dumps(_jsonable(report), indent=2) if args.json else
          f"{args.model} on {len(report['subjects'])} subjects ({'SYNTHETIC' if report['synthetic'] else 'recorded'}): "
          f"{report['event_correct']} / {report['n_events']} events correct, {report['false_detections']} false "
          f"detections, median latency {report['median_detection_latency_s']:.2f} s (over all detected events)")
    return 0


def _jsonable(value):
    if isinstance(value, dict):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, (np.floating, float)):
        return None if not math.isfinite(float(value)) else float(value)
    if isinstance(value, np.integer):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def format_report(report: dict) -> str:
    """Fig. 6-style text of an evaluation report (``EvaluationResult.as_dict()``)."""
    lines = []
    tag = ' -- SYNTHETIC data (simulated people)' if report.get('synthetic') else ''
    lines.append(f"Leave-one-subject-out over {len(report['subjects'])} subjects{tag}")
    lines.append(f"best: {report['n_components']} components, threshold {report['threshold']}, dwell "
                 f"{report['dwell_frames']} frames, window {report['window_s']:g} s")
    n = report['n_events']
    lines.append(f"events: {n}; correct {report['event_correct']} ({report['event_correct_rate']:.0%}), "
                 f"false detections {report['false_detections']} ({report['false_detection_rate']:.0%}), "
                 f"misses {report['misses']} ({report['miss_rate']:.0%})")
    lines.append(f"median detection latency {report['median_detection_latency_s']:.2f} s "
                 f"(90th percentile {report['p90_detection_latency_s']:.2f} s); {report['us_per_frame']:.1f} us/frame")
    lines.append(f"per-sample TPR {report['tpr_all_samples']:.2f} (all samples), "
                 f"{report['tpr_detected_samples']:.2f} (detected samples)")
    lines.append('')
    lines += _matrix('per-sample confusion (rows: predicted, columns: truth)', report['sample_confusion'])
    lines.append('')
    lines += _matrix('event confusion (rows: truth, columns: detected)', report['event_confusion'])
    lines.append('')
    lines.append('grid: components threshold dwell | correct false misses latency_s')
    for g in report['grid']:
        lines.append(f"  {g['n_components']:>3} {g['threshold']:>7} {g['dwell_frames']:>3} | "
                     f"{g['event_correct_rate']:.2f} {g['false_detection_rate']:.2f} {g['miss_rate']:.2f} "
                     f"{g['median_detection_latency_s']:.2f}")
    return '\n'.join(lines)


def _matrix(title: str, table: dict) -> list[str]:
    cols = list(next(iter(table.values())).keys())
    width = max(8, *(len(c) for c in cols)) + 1
    out = [title, ' ' * 16 + ''.join(f'{c:>{width}}' for c in cols)]
    for row, values in table.items():
        out.append(f'{row:<16}' + ''.join(f'{values[c]:>{width}}' for c in cols))
    return out


TRAIN = Target(add_train_arguments, run_train, __doc__)
EVAL = Target(add_eval_arguments, run_eval, __doc__)
