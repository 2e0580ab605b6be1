"""``social-touch train bear``: train the eight-subtype model on simulated people and write it as .npz (no pickle).

The model is tied to the scan rate and buffer length it was trained at; both are stored in the file
(``trained_rate_hz_``, ``trained_buffer_len_``) so a node can refuse a model trained for another rate.
The training data is synthetic (``--family``) unless ``--bags`` gives recorded sessions.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import replace
from pathlib import Path

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES
from touch_gestures.bear.symbolic import GestureLibrary
from touch_gestures.model_card import attach_card, make_card
from touch_graph.cli.options import add_output, deprecated_alias, positive_float, positive_int, seed
from touch_graph.errors import SocialTouchError
from touch_graph.paths import share_file
from touch_lab.cards import session_data
from touch_lab.collect.session_bag import SessionError

from .cli import train_families
from .evaluate import FAMILIES, EvalConfig, stderr_progress
from .sessions import fit_model, fold_models, load_runs
from .suggest_report import card_entry, default_output, format_table, run_suggestions, write_config
from .transfer import POPULATIONS, compare_candidates, fit_populations, train_seed

#: What each population of simulated people is, for the model card.
FAMILY_TEXT = {'script': 'touch_sim/bear/people.py: level waveforms, knight2009 Table II statistics',
               'hands': 'touch_sim/bear/hand_people.py: hands over plates, written independently from knight2009',
               'wide': 'touch_sim/bear/people.py with population=WIDE: the script people with pressure, tempo, '
                       'persistence, rhythm, level noise, drift and scan jitter drawn per person from wide ranges'}

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch train bear``."""
    add_output(parser, 'the .npz file to write', required=True)
    parser.add_argument('--rate', type=positive_float, default=3.4, help='scan rate, Hz (3.4)')
    parser.add_argument('--buffer', type=positive_int, default=20, help='cycles per sensor buffer (20)')
    parser.add_argument('--people', type=positive_int, default=8, help='simulated people to train on (8)')
    parser.add_argument('--seed', type=seed, default=0, help='training scene seed is seed + 1000 (0)')
    parser.add_argument('--family', choices=(*FAMILIES, 'both'), default='both',
                        help='families of simulated people to train on, --people of each: script '
                        '(touch_sim/bear/people.py), hands (touch_sim/bear/hand_people.py) or both (both)')
    parser.add_argument('--population', nargs='+', choices=POPULATIONS, metavar='NAME',
                        help='train on these populations of simulated people instead of --family, --people of each: '
                        f'{", ".join(POPULATIONS)} (wide: the script family with a wide population of styles)')
    parser.add_argument('--columns', nargs='+', metavar='COLUMN',
                        help="the model's input columns (features, or <level feature>/peak; default: all features "
                        'and the level ratios)')
    parser.add_argument('--C', type=positive_float, default=1.0,
                        help='inverse regularisation (1; `eval bear-models --choose-c` chooses one across families)')
    parser.add_argument('--bags', nargs='+', metavar='BAG',
                        help='train on these session bags (social-touch collect bear) instead of simulated people')
    parser.add_argument('--gestures-config', metavar='YAML',
                        help='--bags: the symbolic gesture config whose min_active / dwell_s are suggested from the '
                        "bags' symbolic/<gesture> trials (default: the package's config/bear_gestures.yaml)")
    suggest = parser.add_argument('--suggest-output', metavar='YAML',
                                  help='--bags: where to write the suggested gesture config (default: beside '
                                  '-o/--output, MODEL.gestures.yaml; never the config it is made from)')
    deprecated_alias(parser, '--suggest-out', suggest)
    parser.add_argument('--evaluate', action='store_true',
                        help="also measure the model's figures (bags: leave-one-person-out; simulated: held-out "
                        "simulated people, `eval bear`) and record them in the file's card")


def run(args: argparse.Namespace) -> int:
    """Train and write the model; progress on stderr."""
    if args.bags:
        if args.C != 1.0:
            print('social-touch train bear: error: --C applies to simulated people, not yet to --bags', file=sys.stderr)
            return 2
        return _run_bags(args)
    families = tuple(dict.fromkeys(args.population)) if args.population else train_families(args.family)
    config = EvalConfig(rate_hz=args.rate, buffer_len=args.buffer, train_people=args.people, seed=args.seed)
    try:
        model = fit_populations(config, families, tuple(args.columns) if args.columns else None,
                                progress=stderr_progress, C=args.C)
    except ValueError as err:
        print(f'social-touch train bear: error: {err}', file=sys.stderr)
        return 2
    model.save(args.output, rate_hz=args.rate, buffer_len=args.buffer)
    reps = config.subtype_reps + 1   # the training scenes' repetitions
    population = '; '.join(f'{args.people} of the {f!r} population ({FAMILY_TEXT[f]}), scene seed '
                           f'{train_seed(f, args.seed)}' for f in families)
    data = {'synthetic': True, 'source': f'simulated people through the virtual bear and bear_driver: {population}',
            'families': list(families), 'people': args.people * len(families), 'columns': list(model.design_),
            'C': args.C,
            'trials_per_class': {s: reps * args.people * len(families) for s in TOUCH_SUBTYPES},
            'rate_hz': args.rate, 'buffer_cycles': args.buffer}
    evaluation = None
    if args.evaluate:
        from .evaluate import evaluate
        evaluation = {'method': f'held-out simulated people of each family (scene seed {args.seed}), `social-touch '
                      f'eval bear --model {args.output} --family F --seed {args.seed} --rate {args.rate} --buffer '
                      f'{args.buffer}`', 'synthetic': True}
        for family in FAMILIES:
            result = evaluate(replace(config, family=family), progress=stderr_progress, model=model)
            m = result['model']
            evaluation[family] = {
                'subtype_accuracy': m['subtype']['accuracy'], 'subtype_frame_accuracy': m['subtype']['frame_accuracy'],
                'median_subtype_latency_s': m['subtype']['median_latency_s'],
                'symbolic_accuracy': m['symbolic']['accuracy'],
                'symbolic_false_alarms': m['symbolic']['false_alarms'],
                'median_symbolic_latency_s': m['symbolic']['median_latency_s'],
                'paper_rule_subtype_accuracy': result['rule']['subtype']['accuracy']}
        evaluation['across_families'] = _across_families(config, families, model.design_, args)
    attach_card(args.output, make_card('bear_subtype_model', data=data, evaluation=evaluation))
    print(f'wrote {args.output}: classes {", ".join(model.classes_)}; trained at {args.rate} Hz, buffer {args.buffer} '
          f'on {args.people} simulated people of each of {", ".join(families)} (synthetic)', file=sys.stderr)
    return 0


def _across_families(config: EvalConfig, populations: tuple[str, ...], columns: tuple[str, ...],
                      args: argparse.Namespace) -> dict:
    """The model's recipe (its columns) fit without each family and measured on it, and on all its populations."""
    training = {'+'.join(populations): populations}
    for family in FAMILIES:
        rest = tuple(p for p in populations if p != family)
        if rest and family in populations:
            training['+'.join(rest)] = rest
    result = compare_candidates(EvalConfig(rate_hz=config.rate_hz, buffer_len=config.buffer_len,
                                           train_people=config.train_people, seed=config.seed),
                                {'these columns': columns}, training, progress=stderr_progress, C=args.C)
    command = ' '.join(['social-touch train bear -o', str(args.output), '--population', *populations,
                        *(['--columns', *args.columns] if args.columns else []),
                        *(['--C', f'{args.C:g}'] if args.C != 1.0 else []), '--people', str(args.people),
                        '--seed', str(args.seed), '--evaluate'])
    return {'method': 'the same input columns fit on each training set below (scene seeds of '
            'touch_lab.bear.transfer.train_seed) and measured on 6 held-out people of each family (scene seed '
            f'{config.seed}); a family left out of a training set is one it never met', 'command': command,
            'synthetic': True,
            'scores': {row['training']: {f: {k: row['scores'][f][k] for k in ('subtype_accuracy', 'lowest_class_recall',
                                                                             'recall')}
                                         for f in FAMILIES} for row in result['rows']}}


def _run_bags(args: argparse.Namespace) -> int:
    """``train bear --bags``: the subtype model from recorded sessions (:mod:`.sessions`), and suggested
    symbolic-gesture settings from their symbolic trials (:mod:`.suggest`)."""
    try:
        body_map = BodyMap.default()
        config = args.gestures_config or share_file('config', 'bear_gestures.yaml')
        library = GestureLibrary.load(config, body_map)
        out = Path(args.suggest_output or default_output(args.output))
        if out.resolve() == Path(config).resolve():
            raise SessionError(f'--suggest-output {out} is the gesture config the suggestion is made from; the '
                               'suggestion goes to a new file')
        runs = load_runs(args.bags, args.rate, args.buffer, stderr_progress)
        if not any(r.labels for r in runs):
            raise SessionError('the bags hold no touch-subtype trial to fit the subtype model from; record some '
                               f'(collect bear --gestures {",".join(TOUCH_SUBTYPES)})')
        stderr_progress(f'fitting the subtype model on {sum(len(r.labels) for r in runs)} trials')
        model = fit_model(runs, seed=args.seed)
        people = sorted({lab.person for r in runs for lab in (*r.labels, *r.gestures)})
        folds = None
        if (args.evaluate or any(r.gestures for r in runs)) and len(people) > 1:
            folds = fold_models(runs, people, seed=args.seed, progress=stderr_progress)
        suggestion = run_suggestions(runs, library, body_map, NoTouchGate(model),
                                     {p: NoTouchGate(m) for p, m in (folds or {}).items()}, stderr_progress)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch train bear: error: {err}', file=sys.stderr)
        return 2
    model.save(args.output, rate_hz=args.rate, buffer_len=args.buffer)
    synthetic = any(r.session.synthetic for r in runs)
    card_data = session_data(((lab.person, lab.gesture) for r in runs for lab in (*r.labels, *r.gestures)),
                             synthetic=synthetic, bags=args.bags)
    card_data.update(rate_hz=args.rate, buffer_cycles=args.buffer)
    if suggestion is not None:
        print(format_table(suggestion, library, synthetic))
        header = (f'Suggested by `social-touch train bear --bags` from\n  {config}\nand '
                  f'{sum(len(r.gestures) for r in runs)} labelled gesture trials '
                  f'({"SYNTHETIC: simulated people" if synthetic else "recorded sessions"}); only min_active and '
                  f'dwell_s differ.\nHow, and the leave-one-person-out figures: the model card of {args.output}.')
        try:
            changed = write_config(config, out, suggestion['suggestions'], header, body_map)
        except SocialTouchError as err:
            print(f'social-touch train bear: error: {err}', file=sys.stderr)
            return 2
        stderr_progress(f'wrote {out}: suggested settings of {changed} gestures (launch with gestures:={out})')
        card_data['symbolic_suggestion'] = card_entry(suggestion, str(config), str(out))
    else:
        stderr_progress('no symbolic/<gesture> trials in the bags: no gesture settings suggested '
                        '(collect bear --symbolic records some)')
    evaluation = None
    if args.evaluate and len(people) < 2:
        # The model is trained and saved all the same; only the held-out figures need a second person.
        print(f'social-touch train bear: warning: --evaluate holds out one person at a time and the bags hold '
              f'{len(people)} ({", ".join(people) or "none"}); no evaluation in the model card (record a second '
              'person, or run eval bear --bags on more sessions)', file=sys.stderr)
    elif args.evaluate:
        from .sessions import leave_one_person_out
        result = leave_one_person_out(runs, seed=args.seed, progress=stderr_progress, models=folds)
        evaluation = {'method': 'leave-one-person-out on the training bags (`social-touch eval bear --bags ...`)',
                      'synthetic': synthetic, 'subtype_accuracy': result['model']['accuracy'],
                      'median_subtype_latency_s': result['model']['median_latency_s'],
                      'paper_rule_subtype_accuracy': result['rule']['accuracy'], 'people': len(result['people'])}
    attach_card(args.output, make_card('bear_subtype_model', data=card_data, evaluation=evaluation))
    data = 'SYNTHETIC (simulated people)' if synthetic else 'recorded'
    print(f'wrote {args.output}: classes {", ".join(model.classes_)}; trained at {args.rate} Hz, buffer {args.buffer} '
          f'on {len(args.bags)} session bags ({data})', file=sys.stderr)
    return 0
