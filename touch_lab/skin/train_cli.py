"""``social-touch train skin --bags BAG... -o FILE``: a skin codebook from labelled session bags.

    social-touch train skin --bags sessions/skin/* -o skin_codebook.npz [--recogniser trace]
    social-touch train skin --bags sessions/new_person/* --extend config/skin_codebook.npz -o robot.npz

Every usable labelled touch of the sessions (``collect skin``) becomes a template
(:mod:`touch_lab.skin.sessions`); ``--extend`` adds them to an existing codebook (same recogniser
and parameters) instead of starting a new one, e.g. to adapt the robot's codebook to a new person.
"""

from __future__ import annotations

import argparse
import sys

from touch_gestures.model_card import attach_card, make_card
from touch_graph.errors import SocialTouchError
from touch_lab.cards import session_data
from touch_lab.skin.recognisers import DEFAULT_RECOGNISER, RECOGNISERS, load_codebook, save_codebook

from .sessions import _say, fit_codebook, leave_one_person_out, load_trials, usable

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch train skin``."""
    parser.add_argument('--bags', nargs='+', metavar='BAG', required=True, help='session bags of the skin')
    parser.add_argument('--output', '-o', required=True, help='codebook file to write (.npz)')
    parser.add_argument('--recogniser', choices=sorted(RECOGNISERS), default=DEFAULT_RECOGNISER,
                        help=f'recogniser whose templates to build (default {DEFAULT_RECOGNISER})')
    parser.add_argument('--extend', metavar='CODEBOOK', help='add the new templates to this codebook')
    parser.add_argument('--evaluate', action='store_true', help='also score leave-one-person-out on the bags and '
                        "record the figures in the codebook's card")
    parser.add_argument('--quiet', action='store_true', help='no progress on stderr')


def run(args: argparse.Namespace) -> int:
    """Build the codebook and write it; 2 on bad input (message on stderr)."""
    say = _say('train skin', args.quiet)
    try:
        trials, synthetic = load_trials(args.bags, say)
        base = load_codebook(args.extend) if args.extend else None
        model = fit_codebook(trials, base.name if base is not None else args.recogniser, base=base)
    except (SocialTouchError, ValueError) as err:
        print(f'social-touch train skin: error: {err}', file=sys.stderr)
        return 2
    data = 'SYNTHETIC (simulated people)' if synthetic else 'recorded sessions'
    kept = usable(trials)
    description = (f'{model.name} codebook from {len(kept)} labelled touches of '
                   f'{len({t.label.person for t in kept})} people ({data})'
                   + (f', extending {args.extend}' if args.extend else ''))
    path = save_codebook(args.output, model, description=description)
    evaluation = None
    if args.evaluate:
        result = leave_one_person_out(trials, model.name, say)
        evaluation = {'method': 'leave-one-person-out on the training bags (`social-touch eval skin --bags ...`)',
                      'synthetic': synthetic, **{k: result[k] for k in ('accuracy', 'right', 'wrong', 'rejected',
                                                                         'missed', 'trials', 'median_latency_s')}}
    data = session_data(((t.label.person, t.label.gesture) for t in kept), synthetic=synthetic, bags=args.bags)
    if args.extend:
        data['extends'] = str(args.extend)
    attach_card(path, make_card('skin_codebook', data={**data, 'recogniser': model.name,
                                                       'templates': len(model.templates_)},
                                evaluation=evaluation))
    say(f'wrote {path}: {len(model.classes_)} gestures, {len(model.templates_)} templates; {description}')
    return 0
