"""``social-touch report skin-rejection``: docs/skin-rejection.md, rejection tuned in one number (issue 26, item 2).

    social-touch eval skin --traces ../shared/data/unistroke_dev.csv.gz --recognisers trace,fused --json > uni.json
    social-touch eval skin --traces ../shared/data/unistroke_dev.csv.gz --recognisers trace,fused \\
        --max-wrong-rate 0.005 --json > uni-0.005.json
    ...
    social-touch report skin-rejection --runs uni.json uni-0.005.json multi.json multi-0.005.json

The report is made from the JSON of ``social-touch eval skin`` runs (each leave-one-person-out over a
trace file, with the recognisers' own rejection or with ``--max-wrong-rate``, :mod:`.acceptance`); it
names the command that gives each row, so every figure can be measured again. Runs take minutes
(unistroke) to an hour (multistroke, ``fused``) on a loaded machine, which is why they are inputs.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from touch_graph.cli.options import add_output

from .acceptance import MAX_RANDOM_FIRING, SCALE_QUANTILE

__all__ = ['add_arguments', 'format_report', 'run']

DEFAULT_OUTPUT = Path('docs') / 'skin-rejection.md'
#: The issue's goals (issue 26, Show).
GOALS = {'wrong': 0.005, 'random': 0.03, 'right_single': 0.99, 'right_multi': 0.97}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--runs', nargs='+', required=True, metavar='JSON',
                        help='outputs of `social-touch eval skin --json` (with and without --max-wrong-rate)')
    add_output(parser, 'the report to write', default=str(DEFAULT_OUTPUT))


def _pct(x: float | None) -> str:
    return '' if x is None else f'{100 * x:.2f} %'


def _command(run: dict, recognisers: list[str]) -> str:
    rate, per_gesture = run.get('max_wrong_rate'), run.get('templates_per_gesture', 'all')
    return (f"`social-touch eval skin --traces {run['traces']} --recognisers {','.join(recognisers)} --json"
            + ('' if per_gesture == 'all' else f' --templates-per-gesture {per_gesture}')
            + (f' --max-wrong-rate {rate:g}`' if rate is not None else '`'))


def _goals(run: dict, r: dict) -> str:
    """The issue's goals a row misses ('none' when it meets them all)."""
    multi = bool(run.get('multi_stroke_samples'))
    missed = [what for what, ok in (
        ('right', r['accuracy_with_rejection'] >= GOALS['right_multi' if multi else 'right_single']),
        ('wrong', r['error_rate'] <= GOALS['wrong']),
        ('random', r['random_touch_acceptance'] is None or r['random_touch_acceptance'] <= GOALS['random'])) if not ok]
    return ', '.join(missed) or 'none'


def _score(held: list[dict]) -> str:
    """Which score a calibrated run limited: the logistic odds (calibrated on stray touches), or the product
    score of runs made before it (calibrated on random touches of the evaluation's own generator)."""
    return ('logistic score, stray touches' if held and all(a.get('score') for a in held)
            else 'product score, random touches (same generator)')


def format_report(runs: list[dict]) -> str:
    """The markdown of the report from eval JSON objects (module doc)."""
    transfers = [r for r in runs if 'transferred_weights' in r]
    runs = [r for r in runs if 'transferred_weights' not in r]
    rows, commands = [], []
    for run in sorted(runs, key=lambda r: (r['vocabulary'], str(r.get('templates_per_gesture')),
                                           r.get('max_wrong_rate') or 0)):
        names = sorted(run['recognisers'])
        held_any = next((r.get('acceptance') or [] for r in run['recognisers'].values()), [])
        commands.append(f"- {run['vocabulary']}, "
                        + (f"calibrated for {run['max_wrong_rate']:g} ({_score(held_any)})"
                           if run.get('max_wrong_rate') is not None
                           else "the recognisers' own thresholds") + f': {_command(run, names)}')
        for name in names:
            r = run['recognisers'][name]
            held = r.get('acceptance') or []
            rule = (f"calibrated, {100 * run['max_wrong_rate']:g} %, {_score(held)}"
                    if run.get('max_wrong_rate') is not None else 'own thresholds')
            estimate = (f"{_pct(sum(a['wrong'] for a in held) / len(held))} / "
                        f"{_pct(sum(a['right'] for a in held) / len(held))}") if held else ''
            per_gesture = run.get('templates_per_gesture', 'all')
            book = '' if per_gesture == 'all' else f', {per_gesture} templates per gesture'
            what = f"{run['vocabulary']} ({run['samples']} samples, {len(run['subjects'])} people{book})"
            rows.append(f"| {what} | {name} | "
                        f"{rule} | {_pct(r['accuracy'])} | **{_pct(r['accuracy_with_rejection'])}** | "
                        f"{_pct(r['rejection_rate'])} | **{_pct(r['error_rate'])}** | "
                        f"**{_pct(r['random_touch_acceptance'])}** | {estimate} | {_goals(run, r)} |")
    return '\n'.join([
        '# Skin rejection tuned in one number',
        '',
        'Generated by `social-touch report skin-rejection` (touch_lab/skin/rejection_report.py) from the runs '
        'listed at the end; do not edit by hand. Real traces (the development files) through the virtual skin '
        '(synthetic sensor frames), leave-one-person-out; random touches are synthetic '
        '(`touch_sim.skin.synthetic.random_touches`).',
        '',
        '## The rule',
        '',
        'A user states **`max_wrong_rate`**: the share of gestures of people the codebook never saw that may fire '
        'a wrong command (`social-touch codebook record --max-wrong-rate 0.005`, `social-touch codebook calibrate`, '
        '`social-touch eval skin --max-wrong-rate`). When the codebook is made, touch_lab.skin.acceptance reads '
        "each person's templates with a codebook of everyone else's, and sets:",
        '',
        f'- each class\'s scale: the {SCALE_QUANTILE:g} quantile of its held-out templates\' distances to it;',
        "- a touch's score (*logistic score*, touch_gestures.skin.doubt): the odds that it fires no right command, "
        'by a logistic model on four features in the codebook\'s own units (log of: the distance to the named '
        "class over its scale; over the runner-up's distance; the runner-up's distance over its scale; over the "
        'median distance to the other classes), fit on the held-out templates named right against those named '
        'wrong and synthetic touches that are no gesture (`touch_sim.skin.stray.stray_touches`: presses, swipes, '
        'spirals, rubbing, taps). Runs made before it (*product score*, made with main at 600e2cf; the same '
        'command now calibrates the logistic score) limited the distance over the scale times the ratio to the '
        "runner-up's distance, calibrated on `random_touches` of another seed;",
        '- the largest score that keeps the held-out wrong commands at `max_wrong_rate` and the synthetic touches '
        f'that are no gesture firing at {100 * MAX_RANDOM_FIRING:g} %.',
        '',
        'The codebook file keeps the scales, the weights, the limit and the calibration record (`acceptance`); the '
        'robot computes one score per touch. The design (the features, the quantile, the random-touch share) was '
        'chosen on the unistroke file and is measured unchanged on the multistroke one: nothing is fitted to a '
        'vocabulary but its own codebook. *Random touches firing* counts `random_touches` (scribbles, zigzags, '
        'dabs). The logistic runs calibrate on another generator (stray touches), so their random-touch figure is '
        'a measurement on touches of a kind the calibration never saw; the product-score runs calibrated on '
        '`random_touches` itself (another seed), so theirs is not independent.',
        '',
        '## Figures',
        '',
        f"Goals (issue 26): wrong commands <= {_pct(GOALS['wrong'])}, random touches firing <= "
        f"{_pct(GOALS['random'])}, right >= {_pct(GOALS['right_single'])} single-stroke and "
        f"{_pct(GOALS['right_multi'])} multi-stroke. *nearest right*: the nearest class, rejection off; *right*, "
        '*rejected*, *wrong*: with the rule; *held-out estimate*: what the calibration expected inside each '
        "fold's codebook (wrong / right, mean over folds).",
        '',
        '| vocabulary | recogniser | rejection | nearest right | right | rejected | wrong | random touches firing '
        '| held-out estimate | goals missed |',
        '|---|---|---|---|---|---|---|---|---|---|',
        *rows,
        '',
        '## Runs',
        '',
        'Each row comes from one of these commands (its JSON kept in docs/skin-rejection-runs/, from which '
        '`social-touch report skin-rejection --runs docs/skin-rejection-runs/*.json` writes this page):',
        '',
        *commands,
        '',
        *_transfer_section(transfers),
    ])


def _transfer_command(t: dict) -> str:
    per = t.get('templates_per_gesture', 'all')
    return (f"`social-touch eval skin-transfer --fit {t['fit']} --fit-recogniser {t['fit_recogniser']}"
            + ('' if t.get('fit_templates_per_gesture', 'all') == 'all'
               else f" --fit-templates-per-gesture {t['fit_templates_per_gesture']}")
            + f" --measure {t['measure']} --measure-recogniser {t['measure_recogniser']}"
            + ('' if per == 'all' else f' --templates-per-gesture {per}')
            + f" --max-wrong-rate {t['max_wrong_rate']:g} --json`")


def _transfer_section(transfers: list[dict]) -> list[str]:
    """The cross-vocabulary table (touch_lab.skin.acceptance_transfer runs), empty without such runs."""
    if not transfers:
        return []
    rows, commands = [], []
    for t in sorted(transfers, key=lambda t: (t['measure'], t['fit'])):
        fit, measured = Path(t['fit']).name.split('.')[0], Path(t['measure']).name.split('.')[0]
        commands.append(f'- {measured}, weights fit on {fit}: {_transfer_command(t)}')
        for name, r in t['scores'].items():
            rows.append(f"| {measured} ({t['measure_recogniser']}) | {fit} ({t['fit_recogniser']}) | {name} | "
                        f"**{_pct(r['right'])}** | {_pct(r['rejected'])} | **{_pct(r['wrong'])}** | "
                        f"**{_pct(r['random_fired'])}** |")
    return [
        '## Across vocabularies',
        '',
        "The score's weights fit on one development file and used on the other, both ways "
        '(touch_lab.skin.acceptance_transfer): leave-one-person-out over the measured file, each fold\'s limit set '
        'on its own codebook for the same `max_wrong_rate`, with the weights fit on the fold\'s codebook (*own*, '
        'what `eval skin` does), fit on the whole other file (*transferred*), or the product score (*product*); '
        'all three calibrated on the stray touches. '
        'Held-out samples are cut at the longest lift a gesture may have (not the end-of-gesture rule of `eval '
        "skin`): compare the rows with each other, the table above gives the absolute figures.",
        '',
        '| measured on | weights fit on | score | right | rejected | wrong | random touches firing |',
        '|---|---|---|---|---|---|---|',
        *rows,
        '',
        *commands,
        '',
    ]


def run(args: argparse.Namespace) -> int:
    """Entry point; 2 on unreadable runs."""
    try:
        runs = [json.loads(Path(p).read_text()) for p in args.runs]
        text = format_report(runs)
    except (OSError, ValueError, KeyError, TypeError) as err:
        print(f'report skin-rejection: cannot read the runs: {type(err).__name__}: {err}', file=sys.stderr)
        return 2
    out = Path(args.output)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f'wrote {out}')
    return 0
