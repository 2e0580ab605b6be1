"""``social-touch report skin-multistroke``: regenerate docs/skin-multistroke.md (issue 13).

One section per vocabulary (one trace file each: leave-one-person-out through the virtual skin,
:func:`~touch_lab.skin.cli.evaluate_file`), the pauses between strokes and the gap, the early
decisions of the default recogniser, collisions against presses and traces
(:mod:`.collision_eval`, synthetic), the cost per recognition (:mod:`.bench`, synthetic
gestures) and the time from the gap's end to the command through the nodes (:mod:`.latency`,
synthetic gestures). Every figure of the file comes from this one command.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from touch_gestures.skin.ending import ENDING_MARGIN
from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S, SINGLE_STROKE_GAP_S
from touch_graph.cli.options import add_output, non_negative_int, positive_int
from touch_graph.files import write_text
from touch_lab.skin.bench import bench_recognition
from touch_lab.skin.cli import DEFAULT, evaluate_file
from touch_lab.skin.collision_eval import evaluate_collisions
from touch_lab.skin.datasets import read_traces
from touch_lab.skin.early_eval import summary as early_summary
from touch_lab.skin.ending_eval import CAUSES, PIECE_GAP_S, ending_causes, ending_table
from touch_lab.skin.evaluate import LOSS_REASONS
from touch_lab.skin.latency import bench_latency
from touch_lab.skin.recognisers import make_recogniser
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples

__all__ = ['add_arguments', 'run', 'write_report']

#: Evaluated per vocabulary: the default, the two it chooses from (fused, trace), fused with the oriented
#: cloud naming the class, the cloud refereed by $N (the default before fused) and the cloud alone, the
#: oriented cloud alone, $N, the paper's centroid method.
RECOGNISERS = ('auto', 'fused', 'fused_oriented', 'refereed', 'cloud', 'oriented', 'ndollar', 'trace', 'centroid')


def _say(line: str) -> None:
    print(f'[report skin-multistroke] {line}', file=sys.stderr, flush=True)


def _pct(x: float | None) -> str:
    return 'n/a' if x is None else f'{100 * x:.2f}'


def _vocabulary_section(r: dict) -> list[str]:
    recs = r['recognisers']
    ending = (f"gap {r['gap_s']} s, waiting up to {r['wait_s']} s for strokes the codebook calls the beginning of a "
              "longer gesture" if r.get('wait_s') else f"gap {r['gap_s']} s")
    default = recs.get(r.get('default') or '', {})
    out = [f"## Vocabulary `{r['vocabulary']}` ({Path(r['traces']).name})", '',
           f"{r['samples']} samples of {len(r['gestures'])} gestures by {len(r['subjects'])} people, "
           f"{r['multi_stroke_samples']} of them multi-stroke; {ending}; gestures per sample after segmentation "
           f"(`{r.get('default')}`): {default.get('gestures_per_sample', r['gestures_per_sample'])} (a sample cut into "
           f"other than one gesture counts as wrong). Codebook per fold: every sample of the other people. "
           f"{r['data']}.", '',
           'Rejection: distance over the class threshold, too small a margin, a time in contact (pauses between '
           'strokes left out) out of the range the nearest class shows in the codebook, a stroke count more than '
           'one stroke from every count it shows in 1 % of its templates or more (touch_gestures.skin.evidence), '
           'for fused the cloud putting first another class the codebook confuses with the one named '
           '(touch_gestures.skin.fused), or, for the order-free cloud, a one-stroke touch whose path is '
           "far from every one-stroke path of the nearest class (touch_gestures.skin.order_evidence); touches the "
           'node screens out (a dab, two fingers) fire nothing. Latency: the lift after the last stroke at which the '
           'gesture ended.',
           '', '| recogniser | accuracy % | with rejection: correct % | rejected % | wrong command % | '
           'random touches firing % | latency s (mean / median) | us per recognition (median) |',
           '|---|---|---|---|---|---|---|---|']
    for name, v in recs.items():
        lat = v.get('latency_s')
        latency = f"{lat['mean']:.2f} / {lat['median']:.2f}" if lat else f"{r['gap_s']:.2f} / {r['gap_s']:.2f}"
        out.append(f"| {name} | {_pct(v['accuracy'])} | {_pct(v['accuracy_with_rejection'])} | "
                   f"{_pct(v['rejection_rate'])} | {_pct(v['error_rate'])} | {_pct(v['random_touch_acceptance'])} | "
                   f"{latency} | {v['us_per_recognition']:.0f} |")
    losses = [(name, v['losses']) for name, v in recs.items() if v.get('losses')]
    if losses:
        shown = [k for k in LOSS_REASONS if any(lost.get(k) for _, lost in losses)]
        out += ['', 'Where the right commands are lost (genuine gestures that fired no right command, counted by the '
                'first reason, touch_lab.skin.evaluate.LOSS_REASONS: split = cut into more than one gesture; '
                'named_wrong = the nearest class is not the one traced; disagreement = named right, but the '
                "deciding distances put another class first; then the evidence checks and the thresholds):", '',
                '| recogniser | lost | ' + ' | '.join(shown) + ' |', '|---|---|' + '---|' * len(shown)]
        out += [f"| {name} | {sum(lost.values())} | " + ' | '.join(str(lost.get(k, 0)) for k in shown) + ' |'
                for name, lost in losses]
    if r.get('default'):
        choices = recs[r['default']].get('choices', {})
        out += ['', f"Default (`{DEFAULT}`, the rule of touch_lab.skin.recognisers.auto) chose: "
                + ', '.join(f'{k} in {n} of {sum(choices.values())} folds' for k, n in choices.items()) + '.']
    best = recs[r['best']]
    whole = 1 - best['segmentation_failures'] / best['samples']
    out += ['', f"Samples cut into exactly one gesture: {_pct(whole)} %; accuracy of the best ({r['best']}) on "
            f"those: {_pct(best['correct'] / max(1, best['samples'] - best['segmentation_failures']))} %."]
    if r.get('pauses_between_strokes_s'):
        p = r['pauses_between_strokes_s']
        out += ['', 'Pauses between strokes (s): ' + ', '.join(f'{k} {v:.2f}' for k, v in p.items()) + '.',
                'Samples kept whole per gap (from the pauses of the file; the gap is also the latency every '
                'command pays after the last lift):', '', '| gap s | ' + ' | '.join(
                    f"{x['gap_s']:g}" for x in r['samples_whole_per_gap']) + ' |',
                '|---|' + '---|' * len(r['samples_whole_per_gap']),
                '| whole % | ' + ' | '.join(_pct(x['whole']) for x in r['samples_whole_per_gap']) + ' |']
    if r.get('logged_times', {}).get('points_sharing_a_time'):
        lt = r['logged_times']
        lost = lt['ink_lost_one_point_per_time']
        out += ['', f"Logged times: the file's clock ticks every {lt['tick_ms']:g} ms (median over the samples) and "
                f"{_pct(lt['points_sharing_a_time'])} % of its points share their time with another point of their "
                'stroke; the virtual skin spreads them over the tick (touch_sim.skin.traces.spread_stamps). A replay '
                'keeping one point per time would lose ' + ', '.join(f'{_pct(v)} %' for v in lost.values())
                + f" of a sample's ink (percentiles {', '.join(k[1:] for k in lost)}; touch_lab.skin.logged_times)."]
    if r.get('ending_table'):
        out += ['', 'The end of a gesture (cloud, leave-one-person-out, codebook cut at 3 s; accuracy over all '
                'samples, rejection off; a fixed gap has no bound; rule `fractions`: whole templates against '
                'prefixes cut at fractions of their ink, strokes fewer than the nearest class ever shows wait the '
                'bound like any prefix; `-unfinished`: those wait until the limit of a gesture, 10 s from its start; '
                '`strokes-`: prefixes cut between strokes; `fractions*` and `-nomargin` (the rules before): strokes '
                'that make a whole gesture end at the gap however near the beginning of a longer one, '
                f'`strokes-unfinished` waits for the longer one unless a whole template is {ENDING_MARGIN:g} nearer '
                '(relative); waits after: whole samples after which the segmenter '
                'still waited, so that a next touch within the wait would have joined them, of them to the limit):', '',
                '| gap s | bound s | rule | whole % | accuracy % | latency s mean | latency s median | '
                'waits after % (to the limit) |', '|---|---|---|---|---|---|---|---|']
        for x in r['ending_table']:
            bound = 'fixed' if x['wait_s'] is None else f"{x['wait_s']:g}"
            out.append(f"| {x['gap_s']:g} | {bound} | {x['rule'] or '-'} | "
                       f"{_pct(x['whole'])} | {_pct(x['accuracy'])} | {x['latency_mean_s']:.2f} | "
                       f"{x['latency_median_s']:.2f} | {_pct(x['waits_after'])} ({_pct(x['waits_to_limit'])}) |")
    if r.get('ending_causes'):
        c = r['ending_causes']
        t = c['totals']
        out += ['', f"Why samples are not one gesture (cloud, gap {c['gap_s']:g} s, bound {c['wait_s']:g} s, rule "
                f"`{c['rule']}`; per class: `social-touch eval skin-ending`): "
                + ', '.join(f'{k} {t[k]}' for k in CAUSES if t[k]) + f" of {t['samples']}; strokes taken for a whole "
                'gesture: ' + ('; '.join(f'{k} ({n})' for k, n in c['prefixes'].items()) or 'none')
                + '; the lifts that cut at a bound or limit: ' + ', '.join(f'{k}: {n}' for k, n in
                                                                           c['bound_pauses'].items())
                + '. Samples the skin traced with fewer strokes than the file (two strokes joined): '
                f"{sum(v['strokes joined'] for v in c['rendering'].values())}, with more (a stroke broken): "
                f"{sum(v['stroke broken'] for v in c['rendering'].values())}."]
    if r.get('early'):
        out += ['', f"Early decisions (`{DEFAULT}`, one held-out gesture in {r['early_every']}), "
                f"{early_summary(r['early'])}"]
    return [*out, '']


def write_report(traces: list[str], out: str | Path = 'docs/skin-multistroke.md', early_every: int = 8,
                 per_kind: int = 40) -> Path:
    """Run everything (module doc) and write the Markdown file."""
    started = time.perf_counter()
    command = ('social-touch report skin-multistroke ' + ' '.join(f'--traces {t}' for t in traces)
               + f' --early {early_every} --per-kind {per_kind}')
    lines = ['# Skin: multi-stroke vocabularies, early decisions, collisions', '',
             f'Regenerate with `{command}`.', '',
             'The traces are real (pen traces of the files named below), the skin is simulated: each trace goes '
             'through the virtual skin (contact model, noise, hysteresis, 150 Hz), the real decoder and '
             'calibrator and the segmenter. Collisions and the cost benchmark use synthetic contacts and '
             'gestures. Leave-one-person-out only.', '',
             f'End of a gesture: in a vocabulary with multi-stroke gestures a lift of {ENDING_GAP_S} s ends strokes '
             f'the codebook calls a whole gesture (a whole template {ENDING_MARGIN:g} nearer, relative, than the '
             f'beginning of every longer one), strokes that may be the beginning of a longer one wait up to '
             f'{ENDING_WAIT_S} s (the templates cut between strokes tell which), strokes fewer than the nearest class '
             'was ever written with wait until the limit of '
             f'a gesture (10 s from its start; touch_gestures.skin.ending); {SINGLE_STROKE_GAP_S} s ends every '
             'gesture otherwise.',
             '']
    for path in traces:
        _say(f'evaluating {path}')
        r = evaluate_file(path, list(RECOGNISERS), progress=_say, early_every=early_every)
        r['early_every'] = early_every
        if r['multi_stroke_samples']:
            samples = read_traces(path).samples
            pieces = render_samples(samples, RenderSettings(gap_s=PIECE_GAP_S, min_frames=1), default_cache_dir())
            r['ending_table'] = ending_table(pieces, lambda: make_recogniser('cloud'), progress=_say)
            r['ending_causes'] = ending_causes(pieces, lambda: make_recogniser('cloud'),
                                               {s.key: s.n_strokes for s in samples}, progress=_say)
        lines += _vocabulary_section(r)
    _say('collisions')
    c = evaluate_collisions(per_kind)
    lines += ['## Collisions, presses and traced gestures (synthetic)', '',
              f"{per_kind} simulated contacts of each kind through the virtual skin; thresholds "
              f"{c['collision_force_n']} N and {c['collision_rate_n_s']} N/s (touch_lab.skin.collision_eval).", '',
              '| contact | collision | gesture | nothing |', '|---|---|---|---|']
    for kind, row in c['confusion'].items():
        lines.append(f"| {kind} | {row['collision']} | {row['gesture']} | {row['nothing']} |")
    lat = c['bump_latency_frames']
    if lat:
        lines += ['', "Bump detection latency, frames after the contact's first frame "
                  f"({c['frame_period_ms']:.2f} ms each): median {lat['median']:.0f}, 90th percentile "
                  f"{lat['p90']:.0f}, max {lat['max']:.0f}."]
    _say('cost')
    b = bench_recognition(['trace', 'cloud', 'refereed', 'fused', 'oriented', 'fused_oriented', 'ndollar', 'auto',
                           'centroid'])
    lines += ['', '## Cost per recognition (synthetic gestures)', '',
              f"{b['gestures']} gestures x {b['templates_per_gesture']} templates, median of {b['repeats']} runs over "
              f"{b['queries']} queries, one `predict` each (`social-touch bench skin`):", '',
              '| recogniser | us per recognition | CPU us (no waits for a core) |', '|---|---|---|']
    for name, v in b['recognisers'].items():
        lines.append(f"| {name} | {v['us_per_recognition']:.0f} | {v['cpu_us_per_recognition']:.0f} |")
    if 'fused_3_strokes' in b:
        f3 = b['fused_3_strokes']
        lines += ['', f"{f3.get('recogniser', 'fused')}, the multi-stroke default, with every template of three "
                  "strokes (each gesture cut into thirds; the trace matches "
                  f"each template in its 6 stroke orders, {f3['templates']} rows): {f3['us_per_recognition']:.0f} us "
                  f"({f3['cpu_us_per_recognition']:.0f} CPU us). A vocabulary of one to three strokes costs between "
                  'this and the row above.']
    if 'early' in b:
        lines += ['', f"An early candidate (cloud, template prefixes at four fractions) for the first half of a "
                  f"gesture: {b['early']['us_per_candidate']:.0f} us ({b['early']['cpu_us_per_candidate']:.0f} CPU us; "
                  'published at most every 0.1 s of a gesture).']
    _say('latency')
    t = bench_latency()
    lines += ['', '## From the end of the gap to the command (synthetic gestures)', '',
              f"{t['commands']} gestures traced on the virtual skin, read by skin_driver and haptic_commands in one "
              f"graph, {t['recogniser']} codebook of {t['gestures']} x {t['templates_per_gesture']}, gap "
              f"{t['gap_s']} s (`social-touch bench skin-latency`): the command comes {t['ms_median']:.1f} ms "
              f"(median) and {t['ms_p99']:.1f} ms (99th percentile) after the gap ends (goal {t['goal_ms']:.0f} ms): "
              f"waiting for the first frame after the gap (frames at {t['frame_rate_hz']:.0f} Hz, at most "
              f"{1e3 / t['frame_rate_hz']:.1f} ms; median {abs(t['wait_for_frame_ms_median']):.1f} ms), then "
              f"processing that frame to the delivered command, median {t['processing_ms_median']:.2f} ms, "
              f"99th percentile {t['processing_ms_p99']:.2f} ms."]
    lines += ['', f'(This run took {(time.perf_counter() - started) / 60:.0f} minutes.)', '']
    out = Path(out)
    write_text(out, '\n'.join(lines), encoding='utf-8')
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch report skin-multistroke``."""
    parser.add_argument('--traces', action='append', required=True,
                        help='a trace file per vocabulary (repeat the option), e.g. '
                             '../shared/data/multistroke_dev.csv.gz')
    add_output(parser, 'the Markdown file to write', default='docs/skin-multistroke.md')
    parser.add_argument('--early', type=non_negative_int, default=8,
                        help='early decisions on one held-out gesture in EARLY')
    parser.add_argument('--per-kind', type=positive_int, default=40,
                        help='simulated contacts of each kind for collisions')


def run(args: argparse.Namespace) -> int:
    try:
        path = write_report(args.traces, args.output, args.early, args.per_kind)
    except (ValueError, OSError) as err:
        print(f'report skin-multistroke: {err}', file=sys.stderr)
        return 2
    print(f'wrote {path}')
    return 0
