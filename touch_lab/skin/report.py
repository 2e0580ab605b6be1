"""Write ``docs/skin-evaluation.md``: the measurements behind the choice of recogniser.

``social-touch report skin --traces FILE`` regenerates it: every recogniser leave-one-subject-out
through the virtual skin and before it (:func:`touch_lab.skin.cli.evaluate_file`); speed against
error; generalisation to other gesture sets and people (synthetic); rejection operating points; the
speed benchmark (:mod:`.bench`).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from touch_gestures.skin.base import TemplateRecogniser
from touch_graph.cli.options import add_output
from touch_graph.files import write_text
from touch_lab.skin.bench import bench_recognition
from touch_lab.skin.cli import evaluate_file
from touch_lab.skin.datasets import read_traces
from touch_lab.skin.evaluate import leave_one_subject_out
from touch_lab.skin.recognisers import PAPER, PEERS, RECOGNISERS, make_recogniser
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples
from touch_sim.skin.synthetic import DIGITS, PAPER_CENTROID_SET, random_touches, synthetic_traces

__all__ = ['add_arguments', 'run', 'write_report']


COMMAND = 'social-touch report skin --traces ../shared/data/unistroke_dev.csv.gz'
CONDITIONS = {
    'default': {}, 'shaky (x3 wobble and tremor)': {'shake': 3.0}, 'slow (x0.4)': {'speed': 0.4},
    'fast (x2.5)': {'speed': 2.5}, 'hesitant (x10 pauses)': {'pauses': 10.0},
    'slanted (sd 15 deg)': {'slant_deg': 15.0},
}
SYNTHETIC_SETS = {'Fig. 8 + vertical lines + secondary diagonal':
                  (*PAPER_CENTROID_SET, 'line_down', 'line_up', 'secondary_diagonal'), 'digits 0-9': DIGITS}


def _say(line: str) -> None:
    print(f'[skin report] {line}', file=sys.stderr, flush=True)


def _pct(x: float | None) -> str:
    return 'n/a' if x is None or x != x else f'{100 * x:.2f}'


def _main_section(report: dict) -> list[str]:
    before = report['before_sensor']['recognisers']
    rows = ['| recogniser | kind | accuracy % (through the skin) | before the sensor % | with rejection: correct % '
            '| rejected % | wrong command % | random touches firing % | us per recognition (median, p90) |',
            '|---|---|---|---|---|---|---|---|---|']
    for name, r in report['recognisers'].items():
        kind = 'paper' if name in PAPER else 'peer' if name in PEERS else 'ours'
        rows.append(f"| {name} | {kind} | {_pct(r['accuracy'])} | {_pct(before[name]['accuracy'])} | "
                    f"{_pct(r['accuracy_with_rejection'])} | {_pct(r['rejection_rate'])} | {_pct(r['error_rate'])} | "
                    f"{_pct(r['random_touch_acceptance'])} | {r['us_per_recognition']:.1f}, {r['us_p90']:.1f} |")
    best = report['best']
    sigma = report['recognisers'][best]['per_gesture']
    rows += ['', f"Best: **{best}**. Per gesture for {best} (eq. 9 mean and eq. 8 standard deviation of the "
             'performers\' recognition rates, %):', '', '| gesture | mu | sigma |', '|---|---|---|']
    rows += [f"| {g} | {100 * s['mu']:.1f} | {100 * s['sigma']:.1f} |" for g, s in sigma.items()]
    return rows


def _speed_error_section(rendered: list, lengths: tuple[int, ...], sizes: tuple[int | None, ...],
                         points: list | None = None) -> list[str]:
    """The table's rows; ``points`` (if given) gets (name, length, templates, accuracy, us) of each."""
    rows = ['| recogniser | resample length | templates per gesture | accuracy % | us per recognition |',
            '|---|---|---|---|---|']
    for name, param in (('trace', 'n_points'), ('centroid', 'length')):
        for n in lengths:
            for m in sizes:
                def make(name: str = name, param: str = param, n: int = n) -> TemplateRecogniser:
                    return make_recogniser(name, **{param: n}, max_distance=None)

                res = leave_one_subject_out(rendered, {name: make}, m)[name]
                rows.append(f"| {name} | {n} | {'all (~120)' if m is None else m} | {_pct(res.accuracy)} | "
                            f'{res.us_per_recognition:.1f} |')
                _say(rows[-1])
                if points is not None:
                    points.append((name, n, m, res.accuracy, res.us_per_recognition))
    return rows


def _generalisation_section(names: list[str], cache: Path | None) -> tuple[list[str], dict[str, list[float]]]:
    header = '| gesture set | condition | ' + ' | '.join(names) + ' |'
    rows = [header, '|---|---|' + '---|' * len(names)]
    factories = {n: (lambda n=n: make_recogniser(n, max_distance=None)) for n in names}
    scores: dict[str, list[float]] = {n: [] for n in names}
    for set_name, shapes in SYNTHETIC_SETS.items():
        for cond, kw in CONDITIONS.items():
            traces = synthetic_traces(shapes, performers=6, repetitions=8, seed=7, **kw)
            rendered = render_samples(traces, RenderSettings(mode='sensor', placement='mm', seed=7), cache)
            res = leave_one_subject_out(rendered, factories, None)
            rows.append(f'| {set_name} | {cond} | ' + ' | '.join(_pct(res[n].accuracy) for n in names) + ' |')
            for n in names:
                scores[n].append(res[n].accuracy)
            _say(rows[-1])
    return rows, scores


def _conclusion(report: dict, scores: dict[str, list[float]], bench: dict) -> list[str]:
    """The choice, in numbers measured above."""
    recs = report['recognisers']
    n = report['samples']
    ranked = sorted(recs, key=lambda k: -recs[k]['accuracy'])
    top = recs[ranked[0]]['accuracy']
    se = (top * (1 - top) / n) ** 0.5
    close = [k for k in ranked if top - recs[k]['accuracy'] <= 2 * se]
    mean = {k: sum(v) / len(v) for k, v in scores.items() if v}
    fast = {k: r['us_per_recognition'] for k, r in bench['recognisers'].items()}
    lines = [f"On the $1 traces through the skin the best accuracy is {_pct(top)} % ({ranked[0]}); within two "
             f"binomial standard errors ({200 * se:.2f} points) of it: {', '.join(close)}. The traces do not "
             'separate these recognisers.']
    if mean:
        order = sorted(mean, key=lambda k: -mean[k])
        lines.append('Averaged over the synthetic gesture sets and conditions of section 3 (other people, other '
                     'gestures, lines in both directions, shake, speed, pauses, slant): '
                     + ', '.join(f'{k} {_pct(mean[k])} %' for k in order) + '.')
    lines.append('Speed at 16 gestures x 30 templates: ' + ', '.join(f'{k} {v:.0f} us' for k, v in fast.items())
                 + f" (goal {bench['goal_us']:.0f} us).")
    lines.append('The skin node uses `trace` (registry.DEFAULT_RECOGNISER): as accurate as the best on the traces, '
                 'as robust as DTW on the other sets, and as fast as the centroid method.')
    return lines


def _rejection_section(rendered: list, randoms: list) -> list[str]:
    rows = ['| recogniser | auto_scale | min_margin | correct % | rejected % | wrong command % | '
            'random touches firing % |', '|---|---|---|---|---|---|---|']
    for name in ('trace', 'centroid'):
        factories = {f'{s}/{m}': (lambda s=s, m=m, name=name: make_recogniser(name, auto_scale=s, min_margin=m))
                     for s in (1.5, 2.0, 2.5, 3.0) for m in (0.0, 0.1, 0.2)}
        res = leave_one_subject_out(rendered, factories, None, random_rendered=randoms)
        for key, r in res.items():
            s, m = key.split('/')
            rows.append(f'| {name} | {s} | {m} | {_pct(r.accuracy_with_rejection)} | {_pct(r.rejection_rate)} | '
                        f'{_pct(r.error_rate)} | {_pct(r.random_acceptance)} |')
    return rows


def write_report(traces: str, out: str | Path = 'docs/skin-evaluation.md', quick: bool = False) -> Path:
    """Measure everything (module doc) and write the markdown file; returns its path.

    ``quick`` shrinks the sweeps (for a smoke test), not the main evaluation.
    """
    t0 = time.perf_counter()
    cache = default_cache_dir()
    names = list(RECOGNISERS)
    _say('main evaluation (all recognisers, through the skin and before it) ...')
    report = evaluate_file(traces, names, templates_per_gesture=0, mode='both', progress=_say)
    samples = read_traces(traces).samples
    rendered = render_samples(samples, RenderSettings(mode='sensor'), cache)
    randoms = render_samples(random_touches(150, seed=1), RenderSettings(mode='sensor', placement='mm', seed=10**6),
                             cache)
    lengths = (16, 32) if quick else (8, 16, 32, 64)
    sizes = (5, 30) if quick else (5, 10, 30, None)
    _say('speed against error ...')
    speed_points: list = []
    speed = _speed_error_section(rendered, lengths, sizes, speed_points)
    _say('generalisation on synthetic gesture sets ...')
    general, scores = _generalisation_section(names if not quick else ['centroid', 'trace'], cache)
    _say('rejection operating points ...')
    rejection = _rejection_section(rendered, randoms)
    _say('speed benchmark ...')
    bench = bench_recognition(names)
    _say('figures ...')
    from touch_lab.figures.skin import skin_figures  # matplotlib: loaded only to write the report

    figures = skin_figures(Path(out).parent, report, samples, speed_points, _say)
    n_subj = len(report['subjects'])
    lines = [
        '# Skin gesture recognisers: evaluation', '',
        f'Regenerate with `{COMMAND}` (about 15 minutes; this run took {(time.perf_counter() - t0) / 60:.0f}).',
        'Synthetic data is labelled: the sensor frames are simulated by the virtual skin '
        '(`touch_driver.skin`), the traces behind them are real ($1 unistroke logs, Wobbrock et al. 2007, '
        f'{n_subj} subjects x 3 speeds x 16 gestures x 10); sections 3-4 also use synthetic performers and '
        'synthetic random touches.', '',
        'Multi-stroke vocabularies (symbols), the per-vocabulary default, early decisions and collisions: '
        '[skin-multistroke.md](skin-multistroke.md) (`social-touch report skin-multistroke`).', '',
        '## Conclusion', '', *_conclusion(report, scores, bench), '',
        '## 1. Leave-one-subject-out on the traces', '',
        f"{report['samples']} samples; each is traced across the virtual skin (finger contact model, noise, "
        'hysteresis, 150 Hz), decoded by the real stream decoder, calibrated by the real calibrator and cut by the '
        'segmenter (gestures per sample: '
        f"{report['gestures_per_sample']}). Codebook per fold: every sample of the other four subjects (120 per "
        "gesture; section 2 also gives m = 5, 10 and 30, the paper's m). *Accuracy* is the nearest class (the "
        "paper's recognition rate, no rejection); the rejection columns use each recogniser's default rule "
        '(per-class threshold 2.0 x the 90th percentile of the codebook\'s leave-one-out distances, margin '
        '>= 0.1 x distance); random touches are 150 synthetic scribbles, zigzags and dabs.', '',
        *_main_section(report), '', figures['confusion'], '', figures['traces'], '',
        "Sensor cost (accuracy before the sensor minus through it, points): "
        + ', '.join(f'{k} {100 * v:+.2f}' for k, v in report['sensor_cost'].items()) + '.', '',
        '## 2. Speed against error', '',
        'Through the skin, leave-one-subject-out, nearest class (no rejection); us per recognition is the median '
        'of one `predict` during the evaluation (16 gestures x m templates).', '', *speed, '',
        figures['speed_error'], '',
        '## 3. Other gesture sets and other people (synthetic)', '',
        'Synthetic performers (`touch_sim.skin.synthetic`: 6 people x 8 repetitions, each with their own size, '
        'position, slant, proportions, speed, corner style and shake) trace the gestures of cirillo2017 Fig. 7-8 '
        '(lines and diagonals in both directions) and the digits through the virtual skin; leave-one-performer-out, '
        'codebook = the other performers, nearest class, accuracy %.', '', *general, '',
        '## 4. Rejection: genuine gestures against random touches', '',
        'Through the skin, every training sample in the codebook, leave-one-subject-out; random touches: 150 '
        'synthetic. The default rule is auto_scale 2.0, min_margin 0.1.', '',
        *rejection, '',
        '## 5. Speed benchmark', '',
        f"`social-touch bench skin`: {bench['gestures']} gestures x {bench['templates_per_gesture']} "
        f"templates (synthetic), median of {bench['repeats']} runs of {bench['queries']} recognitions; "
        f"goal {bench['goal_us']:.0f} us.", '', '| recogniser | us per recognition | x goal | x centroid |',
        '|---|---|---|---|',
        *[f"| {n} | {r['us_per_recognition']:.1f} | {r['ratio_to_goal']:.2f} | {r.get('ratio_to_centroid', 0):.2f} |"
          for n, r in bench['recognisers'].items()], '',
    ]
    path = Path(out)
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text(path, '\n'.join(lines) + '\n', encoding='utf-8')
    _say(f'wrote {path} in {time.perf_counter() - t0:.0f} s')
    return path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch report skin``."""
    parser.add_argument('--traces', required=True, help='$1 unistroke logs (CSV, e.g. unistroke_dev.csv.gz)')
    add_output(parser, 'Markdown file to write', default='docs/skin-evaluation.md')
    parser.add_argument('--quick', action='store_true', help='smaller sweeps (smoke test)')


def run(args: argparse.Namespace) -> int:
    """Measure and write docs/skin-evaluation.md (about 15 minutes)."""
    write_report(args.traces, args.output, args.quick)
    return 0
