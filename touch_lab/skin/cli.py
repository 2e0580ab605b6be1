"""``social-touch eval skin``: leave-one-subject-out evaluation of the skin recognisers.

Each trace of the file goes through the virtual skin, the real driver decode and calibration and the
segmenter (:mod:`.render`), then every recogniser is evaluated (:mod:`.evaluate`). Progress goes to
stderr; the report to stdout, as text or, with ``--json``, one object::

    {"recognisers": {NAME: {"accuracy": ..., "us_per_recognition": ..., ...}}, "best": NAME, ...}

A sample split into several gestures by its pen-ups is a segmentation failure (wrong). In a
multi-stroke vocabulary the end of a gesture is the codebook's (:mod:`touch_gestures.skin.ending`,
``--gap``, ``--wait``; cut per fold, :mod:`.ending_eval`); single-stroke vocabularies end at 0.15 s.
The report gives the pauses between strokes and the samples each gap keeps whole (:mod:`.gaps`).
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path
from typing import Any

from touch_gestures.skin.ending import GestureEnd
from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S, SINGLE_STROKE_GAP_S
from touch_graph.cli.options import non_negative_int, non_negative_seconds, positive_int, seconds, seed
from touch_graph.errors import SocialTouchError
from touch_lab.skin.acceptance import calibrate_acceptance, null_touches, wrong_rate
from touch_lab.skin.datasets import read_traces
from touch_lab.skin.early_eval import early_decisions
from touch_lab.skin.early_eval import summary as early_summary
from touch_lab.skin.ending_eval import PIECE_GAP_S, join_pieces
from touch_lab.skin.evaluate import REJECTED, SEGMENTATION, RecogniserResult, format_losses, leave_one_subject_out
from touch_lab.skin.gaps import gap_table, pause_percentiles_s
from touch_lab.skin.logged_times import logged_times
from touch_lab.skin.recognisers import DEFAULT_RECOGNISER, RECOGNISERS, make_recogniser
from touch_lab.skin.sessions import run_eval_bags
from touch_sim.skin.render import RenderedSample, RenderSettings, default_cache_dir, render_samples
from touch_sim.skin.synthetic import random_touches

__all__ = ['add_arguments', 'evaluate_file', 'format_text', 'json_safe', 'run']

#: The recogniser the report calls the default: whichever the vocabulary's codebook picks
#: (touch_lab.skin.recognisers.auto).
DEFAULT = 'auto'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add the options of ``social-touch eval skin`` to ``parser``."""
    source = parser.add_mutually_exclusive_group(required=True)
    source.add_argument('--traces', help='trace CSV (.csv or .csv.gz): subject,variant,gesture,sample,stroke,x,y,t_ms')
    source.add_argument('--bags', nargs='+', metavar='BAG', help='session bags (social-touch collect skin): '
                        'leave-one-person-out with the first of --recognisers (touch_lab.skin.sessions)')
    parser.add_argument('--codebook', metavar='FILE', help='with --bags: score this codebook on every trial instead of '
                        'leave-one-person-out (people it has not seen)')
    parser.add_argument('--json', action='store_true', help='print one JSON object instead of text')
    parser.add_argument('--recognisers', default=','.join(RECOGNISERS),
                        help=f'comma-separated names (default: all: {",".join(RECOGNISERS)})')
    parser.add_argument('--limit', type=positive_int, default=None, help='use only the first N samples of the file')
    parser.add_argument('--templates-per-gesture', type=non_negative_int, default=0,
                        help='codebook size per gesture per fold, spread over the training subjects '
                             '(default 0: every training sample; 30 is the m of cirillo2017 3.3)')
    parser.add_argument('--mode', choices=('sensor', 'direct', 'both'), default='sensor',
                        help='through the virtual skin (default), before it (true finger path, perfect map), or both')
    parser.add_argument('--random-touches', type=non_negative_int, default=150,
                        help='synthetic touches that are no gesture, for the random-touch acceptance (0: none)')
    parser.add_argument('--seed', type=seed, default=0, help='noise and codebook-choice seed')
    parser.add_argument('--early', type=non_negative_int, default=0, metavar='EVERY',
                        help='also measure early decisions of the default recogniser (auto) on one held-out '
                             'gesture in EVERY (0: no; touch_lab.skin.early_eval)')
    parser.add_argument('--vocabulary', default=None,
                        help="the vocabulary's name in the report (default: the file's name without extensions)")
    parser.add_argument('--gap', type=seconds, default=None,
                        help=f"segmenter's gap, s: a lift this long ends a whole gesture (default: {ENDING_GAP_S} s "
                             f'if the file has multi-stroke samples, else {SINGLE_STROKE_GAP_S} s)')
    parser.add_argument('--wait', type=non_negative_seconds, default=None,
                        help='longest lift, s, that continues strokes the codebook calls the beginning of a longer '
                             f'gesture (default: {ENDING_WAIT_S} s for multi-stroke files; 0: none, every gesture '
                             'ends at --gap)')
    parser.add_argument('--max-wrong-rate', type=wrong_rate, default=None, metavar='RATE',
                        help="calibrate each fold's acceptance from its codebook, leave-one-person-out, for at most "
                             'this share of wrong commands (touch_lab.skin.acceptance; default: the recognisers\' '
                             'own rejection)')
    parser.add_argument('--no-cache', action='store_true', help='render every trace again (cache: '
                        f'{default_cache_dir()})')


def _progress(line: str) -> None:
    print(f'[eval skin] {line}', file=sys.stderr, flush=True)


def evaluate_file(traces: str, recognisers: list[str], limit: int | None = None, templates_per_gesture: int = 0,
                  mode: str = 'sensor', random_count: int = 150, seed: int = 0, cache: bool = True,
                  progress: Any = _progress, gap_s: float | None = None, vocabulary: str | None = None,
                  early_every: int = 0, wait_s: float | None = None, max_wrong_rate: float | None = None) -> dict:
    """Run the whole evaluation and return the report object (see the module doc)."""
    for name in recognisers:
        make_recogniser(name)  # unknown names fail before minutes of rendering
    say = progress or (lambda line: None)
    trace_set = read_traces(traces, limit=limit)
    samples = trace_set.samples
    multi = max(s.n_strokes for s in samples) > 1
    if gap_s is None:
        gap_s = ENDING_GAP_S if multi else SINGLE_STROKE_GAP_S
    if wait_s is None:
        wait_s = ENDING_WAIT_S if multi else 0.0
    if not (math.isfinite(gap_s) and gap_s >= PIECE_GAP_S):
        raise ValueError(f'--gap must be a finite number of seconds >= {PIECE_GAP_S}, got {gap_s}')
    if not (math.isfinite(wait_s) and (wait_s == 0 or wait_s >= gap_s)):
        raise ValueError(f'--wait must be 0 or a finite number of seconds >= --gap ({gap_s}), got {wait_s}')
    wait = wait_s if wait_s > 0 else None
    cache_dir = default_cache_dir() if cache else None
    per_gesture = templates_per_gesture if templates_per_gesture > 0 else None
    factories = {name: (lambda name=name: make_recogniser(name)) for name in recognisers}
    modes = ('direct', 'sensor') if mode == 'both' else (mode,)
    report: dict[str, Any] = {
        'traces': str(traces), 'vocabulary': vocabulary or Path(str(traces)).name.split('.')[0],
        'samples': len(samples), 'subjects': trace_set.subjects,
        'gestures': trace_set.gestures, 'multi_stroke_samples': trace_set.multi_stroke_samples,
        'skipped_rows': trace_set.skipped_rows, 'gap_s': gap_s, 'wait_s': wait,
        'pauses_between_strokes_s': pause_percentiles_s(samples), 'samples_whole_per_gap': gap_table(samples),
        'logged_times': logged_times(samples),
        'templates_per_gesture': per_gesture or 'all', 'seed': seed, 'max_wrong_rate': max_wrong_rate,
        'protocol': 'leave-one-subject-out; accuracy = nearest class right (rejection off, as the paper); '
                    'accuracy_with_rejection, rejection_rate, error_rate with the rejection rule on',
    }
    for m in modes:
        t0 = time.perf_counter()
        say(f'rendering {len(samples)} samples ({m}) ...')
        # Pieces (every lift of PIECE_GAP_S cuts), joined per rule: touch_lab.skin.ending_eval.
        settings = RenderSettings(mode=m, seed=seed, gap_s=PIECE_GAP_S, min_frames=1)
        pieces = render_samples(samples, settings, cache_dir,
                                progress=lambda done, total: say(f'  {done}/{total} samples'))
        # The codebook's samples are cut at the longest lift a gesture may have (a recording can wait).
        rendered = _joined(pieces, wait or gap_s)
        randoms = []
        if random_count > 0:
            touches = random_touches(random_count, seed=seed + 1)
            randoms = _joined(render_samples(touches, RenderSettings(mode=m, placement='mm', seed=seed + 10**6,
                                                                     gap_s=PIECE_GAP_S, min_frames=1), cache_dir),
                              gap_s)
        say(f'rendered in {time.perf_counter() - t0:.1f} s; evaluating {", ".join(recognisers)}')
        segment = _segmenter(pieces, rendered, gap_s, wait)
        calibrate = None
        if max_wrong_rate is not None:
            null = null_touches(gap_s=gap_s)   # another seed than the evaluation's random touches
            calibrate = lambda model, null=null: calibrate_acceptance(model, max_wrong_rate, null)  # noqa: E731
        results = leave_one_subject_out(rendered, factories, per_gesture, seed, randoms, progress=say,
                                        segment=segment, calibrate=calibrate)
        block = {
            'mode': m, 'data': 'synthetic sensor frames (virtual skin) from real traces' if m == 'sensor'
            else 'true finger path and perfect maps (before the sensor)',
            'gestures_per_sample': _histogram(len(r.gestures) for r in rendered),
            'random_touches': len(randoms), 'recognisers': {k: v.to_dict() for k, v in results.items()},
            'best': _best(results), 'default': DEFAULT if DEFAULT in results else None,
        }
        if early_every > 0:
            block['early'] = early_decisions(rendered, lambda: make_recogniser(DEFAULT), per_gesture, seed,
                                             early_every, progress=say)
        if m == modes[-1]:
            report.update(block)
        else:
            report['before_sensor'] = block
    if 'before_sensor' in report:
        report['sensor_cost'] = {name: report['before_sensor']['recognisers'][name]['accuracy']
                                 - report['recognisers'][name]['accuracy'] for name in recognisers}
    return report


def _joined(pieces: list[RenderedSample], gap_s: float) -> list[RenderedSample]:
    """Each sample's pieces joined at a fixed gap (what a segmenter with ``gap_s`` alone cuts)."""
    return [RenderedSample(p.subject, p.variant, p.label, p.sample, join_pieces(p.gestures, gap_s)[0])
            for p in pieces]


def _segmenter(pieces: list[RenderedSample], rendered: list[RenderedSample], gap_s: float, wait_s: float | None
               ) -> Any:
    """``segment(sample, recogniser)`` for :func:`leave_one_subject_out`: the held-out sample cut by
    the fold's codebook (:class:`GestureEnd`), or at ``wait_s`` for a recogniser without ordered points."""
    by_sample = {id(r): p.gestures for r, p in zip(rendered, pieces, strict=True)}
    last: list[Any] = [None, None]   # the recogniser of the fold and its rule

    def segment(sample: RenderedSample, recogniser: Any) -> tuple[list, list[float]]:
        if wait_s is None:
            return join_pieces(by_sample[id(sample)], gap_s)
        if last[0] is not recogniser:
            try:
                last[:] = [recogniser, GestureEnd(recogniser)]
            except ValueError:   # no ordered points: no rule, the longest lift ends every gesture
                last[:] = [recogniser, None]
        if last[1] is None:
            return join_pieces(by_sample[id(sample)], wait_s)
        return join_pieces(by_sample[id(sample)], gap_s, wait_s, last[1])

    return segment


def _histogram(values: Any) -> dict[str, int]:
    out: dict[str, int] = {}
    for v in values:
        out[str(v)] = out.get(str(v), 0) + 1
    return dict(sorted(out.items()))


def _best(results: dict[str, RecogniserResult]) -> str:
    """Highest accuracy; ties go to the faster recogniser."""
    return min(results, key=lambda k: (-results[k].accuracy, results[k].us_per_recognition))


def _pct(x: float | None) -> str:
    return '   n/a' if x is None or (isinstance(x, float) and math.isnan(x)) else f'{100 * x:6.2f}'


def format_text(report: dict) -> str:
    """The report as text: summary table, then per recogniser eq. 8-9 and the confusion matrix."""
    recs = report['recognisers']
    lines = [f"vocabulary {report['vocabulary']}: skin recognisers, leave-one-subject-out on {report['traces']} "
             f"({report['samples']} samples, "
             f"subjects {', '.join(report['subjects'])}, {len(report['gestures'])} gestures)",
             f"mode: {report['mode']} ({report['data']}); codebook: {report['templates_per_gesture']} templates "
             f"per gesture per fold; random touches (synthetic): {report['random_touches']}",
             f"multi-stroke samples: {report['multi_stroke_samples']}; gestures per sample after segmentation: "
             f"{report['gestures_per_sample']}; gap {report['gap_s']} s",
             'samples kept whole per gap (from the pauses of the file): '
             + ', '.join(f"{r['gap_s']:g} s: {100 * r['whole']:.1f} %" for r in report['samples_whole_per_gap']), '',
             f"{'recogniser':12s} {'acc %':>6s} {'before':>6s} {'acc+rej':>7s} {'rej %':>6s} {'err %':>6s} "
             f"{'random':>6s} {'us/rec':>8s} {'us p90':>8s}"]
    before = report.get('before_sensor', {}).get('recognisers', {})
    for name, r in recs.items():
        b = before.get(name, {}).get('accuracy')
        lines.append(f"{name:12s} {_pct(r['accuracy'])} {_pct(b)} {_pct(r['accuracy_with_rejection']):>7s} "
                     f"{_pct(r['rejection_rate'])} {_pct(r['error_rate'])} {_pct(r['random_touch_acceptance'])} "
                     f"{r['us_per_recognition']:8.1f} {r['us_p90']:8.1f}")
    if report.get('default'):
        chosen = recs[report['default']].get('choices', {})
        lines += ['', f"default ({report['default']}, the vocabulary's rule): accuracy "
                  f"{_pct(recs[report['default']]['accuracy']).strip()} %, chose "
                  + ', '.join(f'{k} in {v} folds' for k, v in chosen.items())]
    if report.get('early'):
        lines += ['', f"early decisions ({DEFAULT}), {early_summary(report['early'])}"]
    lines += ['', f"best: {report['best']}", '(acc: nearest class right, rejection off; before: same before the '
              'sensor; acc+rej, rej, err: with the rejection rule; random: synthetic random touches that fired '
              'a command)']
    for name, r in recs.items():
        lines += ['', f'== {name}: per gesture, mean and standard deviation over performers (eq. 9, eq. 8), %']
        for g, st in r['per_gesture'].items():
            lines.append(f"  {g:20s} mu {100 * st['mu']:6.2f}  sigma {100 * st['sigma']:6.2f}")
        lines.append('  per performer: ' + ', '.join(f'{s}: {100 * a:.2f}' for s, a in r['per_performer'].items()))
        lines.append('  ' + format_losses(r['losses'], r['samples']))
        lines += _confusion_lines(r['confusion'])
    return '\n'.join(lines)


def _confusion_lines(confusion: dict[str, dict[str, int]]) -> list[str]:
    labels = list(confusion)
    extra = [c for c in (REJECTED, SEGMENTATION) if any(c in row for row in confusion.values())]
    cols = labels + extra
    short = {c: c[:6] for c in cols}
    out = ['  confusion (rows: traced, columns: recognised nearest class)',
           '  ' + ' ' * 20 + ' '.join(f'{short[c]:>6s}' for c in cols)]
    for g in labels:
        row = confusion[g]
        out.append(f'  {g:20s}' + ' '.join(f'{row.get(c, 0):6d}' for c in cols))
    return out


def run(args: argparse.Namespace) -> int:
    """Entry point of ``social-touch eval skin``; returns the exit status."""
    names = [n.strip() for n in str(args.recognisers).split(',') if n.strip()]
    if args.bags:
        return run_eval_bags(args, names[0] if len(names) == 1 else DEFAULT_RECOGNISER)
    if args.limit is not None and args.limit < 1:
        print('eval skin: --limit must be a positive number of samples', file=sys.stderr)
        return 2
    try:
        report = evaluate_file(args.traces, names, args.limit, args.templates_per_gesture, args.mode,
                               args.random_touches, args.seed, cache=not args.no_cache, gap_s=args.gap,
                               vocabulary=args.vocabulary, early_every=args.early, wait_s=args.wait,
                               max_wrong_rate=args.max_wrong_rate)
    except (SocialTouchError, ValueError) as err:
        print(f'eval skin: {err}', file=sys.stderr)
        return 2
    try:
        print(json.dumps(json_safe(report), indent=1, allow_nan=False) if args.json else format_text(report))
    except BrokenPipeError:  # `... | head`: the reader left, which is fine
        sys.stderr.close()
    return 0


def json_safe(value: Any) -> Any:
    """``value`` with NaN and infinities replaced by None (strict JSON has neither).

    >>> json_safe({'a': float('nan'), 'b': [1.0, float('inf')]})
    {'a': None, 'b': [1.0, None]}
    """
    if isinstance(value, dict):
        return {k: json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [json_safe(v) for v in value]
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value

