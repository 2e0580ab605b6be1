"""``social-touch eval skin-ending``: which samples the end of a gesture cuts, and why; the rules side by side.

The samples are rendered into pieces once (cached, shared with ``eval skin``), then cut
leave-one-person-out with the other people's cloud codebook (:mod:`.ending_eval`): per class why
samples were cut (:func:`~.ending_eval.ending_causes`), and the end-of-gesture table
(:func:`~.ending_eval.ending_table`).
"""

from __future__ import annotations

import argparse
import json
import sys

from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S
from touch_graph.cli.options import non_negative_seconds, positive_int, seconds
from touch_graph.errors import SocialTouchError
from touch_lab.skin.datasets import read_traces
from touch_lab.skin.ending_eval import CAUSES, DEFAULT_RULE, PIECE_GAP_S, RULES, ending_causes, ending_table
from touch_lab.skin.recognisers import make_recogniser
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples

__all__ = ['add_arguments', 'format_text', 'run']

#: Column heads of the causes table.
_SHORT = {'ended as whole': 'as whole', 'pause over the bound': '>bound', 'pause over the limit': '>limit',
          'longer than the limit': 'too long', 'pause over the gap': '>gap', 'no gesture': 'none'}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval skin-ending``."""
    parser.add_argument('--traces', required=True, help='trace CSV (.csv or .csv.gz) with multi-stroke samples')
    parser.add_argument('--gap', type=seconds, default=ENDING_GAP_S, help=f'lift that ends a whole gesture, s '
                        f'(default {ENDING_GAP_S})')
    parser.add_argument('--wait', type=non_negative_seconds, default=ENDING_WAIT_S,
                        help=f'longest lift that continues a prefix, s (default {ENDING_WAIT_S}; 0: a fixed gap)')
    parser.add_argument('--rule', choices=tuple(RULES), default=DEFAULT_RULE,
                        help=f'the rule of the causes table (default {DEFAULT_RULE}: touch_gestures.skin.ending; '
                             'touch_lab.skin.ending_eval.RULES)')
    parser.add_argument('--limit', type=positive_int, default=None, help='use only the first N samples of the file')
    parser.add_argument('--no-table', action='store_true', help='skip the end-of-gesture table (the rules compared)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def _say(line: str) -> None:
    print(f'[eval skin-ending] {line}', file=sys.stderr, flush=True)


def format_text(report: dict) -> str:
    """The causes per class, the prefixes taken for whole gestures, rendering faults and the table."""
    c = report['causes']
    cols = ['samples', 'whole', *CAUSES]
    lines = [f"{report['traces']}: gap {c['gap_s']} s, bound {c['wait_s']} s, rule {c['rule']} (cloud, "
             'leave-one-person-out); why samples are not one gesture (columns: '
             + ', '.join(f'{_SHORT[h]} = {h}' for h in CAUSES) + '):', '',
             f"{'class':18s}" + ''.join(f'{_SHORT.get(h, h):>9s}' for h in cols)]
    for label, row in [*c['per_class'].items(), ('all', c['totals'])]:
        lines.append(f'{label:18s}' + ''.join(f'{row[h]:9d}' for h in cols))
    lines += ['', 'strokes taken for a whole gesture (class traced: strokes so far, taken for):']
    lines += [f'  {n:4d}  {k}' for k, n in c['prefixes'].items()] or ['  none']
    lines += ['', 'the lifts that cut at a bound, a limit or a gap: ' + ', '.join(
        f'{k}: {n}' for k, n in c['bound_pauses'].items())]
    lines += ['', 'rendering (strokes the skin traced otherwise than the file): ' + (', '.join(
        f"{k} {v['strokes joined']} joined, {v['stroke broken']} broken" for k, v in c['rendering'].items())
        or 'none')]
    lines += ['', 'whole samples the segmenter still waited after, to the bound / to the limit (a next touch '
              'within that wait joins them): ' + ', '.join(f"{k} {n['bound']} / {n['limit']}"
                                                         for k, n in c['waits_after'].items())]
    if report.get('table'):
        lines += ['', 'the end-of-gesture table (leave-one-person-out, cloud; accuracy over all samples, rejection '
                  'off; waits after: whole samples the segmenter still waited after, of them to the limit):', '',
                  f"{'gap s':>6s} {'bound s':>8s} {'rule':>20s} {'whole %':>8s} {'acc %':>7s} "
                  f"{'lat mean':>9s} {'lat med':>8s} {'waits after %':>14s} {'to limit %':>11s}"]
        for x in report['table']:
            bound = 'fixed' if x['wait_s'] is None else f"{x['wait_s']:g}"
            lines.append(f"{x['gap_s']:6g} {bound:>8s} {x['rule'] or '-':>20s} {100 * x['whole']:8.2f} "
                         f"{100 * x['accuracy']:7.2f} {x['latency_mean_s']:9.2f} {x['latency_median_s']:8.2f} "
                         f"{100 * x['waits_after']:14.2f} {100 * x['waits_to_limit']:11.2f}")
    return '\n'.join(lines)


def run(args: argparse.Namespace) -> int:
    """Entry point of ``social-touch eval skin-ending``; returns the exit status."""
    if args.limit is not None and args.limit < 1:
        print('eval skin-ending: --limit must be a positive number of samples', file=sys.stderr)
        return 2
    if not (args.gap >= PIECE_GAP_S and (args.wait == 0 or args.wait >= args.gap)):
        print(f'eval skin-ending: need --gap >= {PIECE_GAP_S} s and --wait 0 or >= --gap', file=sys.stderr)
        return 2
    try:
        samples = read_traces(args.traces, limit=args.limit).samples
    except SocialTouchError as err:
        print(f'eval skin-ending: {err}', file=sys.stderr)
        return 2
    _say(f'rendering {len(samples)} samples (cached after the first run) ...')
    pieces = render_samples(samples, RenderSettings(gap_s=PIECE_GAP_S, min_frames=1), default_cache_dir(),
                            progress=lambda done, total: _say(f'  {done}/{total} samples'))
    try:
        causes = ending_causes(pieces, lambda: make_recogniser('cloud'), {s.key: s.n_strokes for s in samples},
                               args.gap, args.wait or None, args.rule, progress=_say)
        table = None if args.no_table else ending_table(pieces, lambda: make_recogniser('cloud'), progress=_say)
    except ValueError as err:
        print(f'eval skin-ending: {err}', file=sys.stderr)
        return 2
    report = {'traces': args.traces, 'samples': len(samples), 'causes': causes, 'table': table}
    try:
        print(json.dumps(report, indent=1) if args.json else format_text(report))
    except BrokenPipeError:
        sys.stderr.close()
    return 0
