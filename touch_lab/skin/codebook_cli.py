"""``social-touch codebook info|add|remove|merge``: look into and edit skin codebooks.

Every edit writes a new file (``-o``) with a model card saying what was done to which file
(:mod:`touch_gestures.model_card`); rejection thresholds are recomputed from the templates kept
(:mod:`.codebook_tools`), and an edit drops a calibrated acceptance (calibrate again).
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter

from touch_gestures.model_card import attach_card, format_card, make_card, read_card
from touch_graph.errors import SocialTouchError
from touch_lab.cli.targets import Target
from touch_lab.skin.acceptance import calibrate, wrong_rate
from touch_lab.skin.recognisers import load_codebook, save_codebook

from .codebook_tools import merge_codebooks, remove_gestures, template_labels
from .sessions import _say, fit_codebook, load_trials, usable

__all__ = ['ADD', 'CALIBRATE', 'INFO', 'MERGE', 'REMOVE']


def _fail(what: str, err: Exception) -> int:
    print(f'social-touch codebook {what}: error: {err}', file=sys.stderr)
    return 2


def _info_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('file', help='a skin codebook (.npz)')


def _info(args: argparse.Namespace) -> int:
    try:
        book = load_codebook(args.file)
        card = read_card(args.file)
    except (SocialTouchError, ValueError) as err:
        return _fail('info', err)
    counts = Counter(template_labels(book))
    print(f'{args.file}: recogniser {book.name} {book.get_params()}')
    print(f'{len(book.classes_)} gestures, {len(book.templates_)} templates'
          + (f'; {book.description_}' if book.description_ else ''))
    scales = (book.acceptance_ or {}).get('class_scales')
    for i, (name, threshold) in enumerate(zip(book.classes_, book.class_thresholds_, strict=True)):
        rule = f'scale {scales[i]:.4g}' if scales else f'rejection distance {threshold:.4g}'
        print(f'  {name:18s} {counts[name]:4d} templates, {rule}')
    if book.acceptance_:
        a = book.acceptance_
        score = a.get('score') or 'distance over scale x ratio to the runner-up'
        print(f"acceptance calibrated for {a.get('max_wrong_rate')} wrong commands: max score {a.get('max_score')} "
              f"({score}); leave-one-person-out estimate {a.get('right')} right, {a.get('wrong')} wrong")
    print(format_card(card) if card else 'no model card (a codebook made before cards)')
    return 0


def _synthetic(*files: str) -> bool | None:
    """Whether the codebooks' cards say synthetic: True if any does, False if all say recorded, else None."""
    said = [(read_card(f) or {}).get('data', {}).get('synthetic') for f in files]
    return True if True in said else False if said and all(v is False for v in said) else None


def _write(args: argparse.Namespace, model, what: str, data: dict) -> int:
    """Save the edited codebook with a card (``data`` holds ``synthetic``: True, False or None = unknown)."""
    path = save_codebook(args.output, model, description=f'{what} (see its model card)')
    attach_card(path, make_card('skin_codebook', data={'edit': what, **data, 'templates': len(model.templates_)}))
    print(f'wrote {path}: {len(model.classes_)} gestures, {len(model.templates_)} templates ({what})')
    return 0


def _add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('file', help='the codebook to extend')
    parser.add_argument('--bags', nargs='+', required=True, metavar='BAG', help='skin session bags (collect skin)')
    parser.add_argument('--output', '-o', required=True, help='the codebook to write')


def _add(args: argparse.Namespace) -> int:
    try:
        base = load_codebook(args.file)
        trials, synthetic = load_trials(args.bags, _say('codebook add'))
        model = fit_codebook(trials, base.name, base=base)
    except (SocialTouchError, ValueError) as err:
        return _fail('add', err)
    kept = usable(trials)
    return _write(args, model, f'{args.file} plus {len(kept)} labelled touches', {
        'synthetic': True if synthetic else _synthetic(args.file), 'extends': str(args.file), 'bags': list(args.bags),
        'added_per_class': dict(sorted(Counter(t.label.gesture for t in kept).items()))})


def _remove_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('file', help='the codebook to edit')
    parser.add_argument('--gestures', required=True, help='comma-separated gestures to remove')
    parser.add_argument('--output', '-o', required=True, help='the codebook to write')


def _remove(args: argparse.Namespace) -> int:
    names = [n.strip() for n in args.gestures.split(',') if n.strip()]
    try:
        model = remove_gestures(load_codebook(args.file), names)
    except (SocialTouchError, ValueError) as err:
        return _fail('remove', err)
    return _write(args, model, f'{args.file} without {", ".join(names)}',
                  {'synthetic': _synthetic(args.file), 'source': str(args.file)})


def _merge_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('files', nargs=2, metavar='FILE', help='two codebooks of the same recogniser')
    parser.add_argument('--output', '-o', required=True, help='the codebook to write')


def _merge(args: argparse.Namespace) -> int:
    try:
        books = [load_codebook(f) for f in args.files]
        model = merge_codebooks(*books)
    except (SocialTouchError, ValueError) as err:
        return _fail('merge', err)
    return _write(args, model, f'{args.files[0]} merged with {args.files[1]}',
                  {'synthetic': _synthetic(*args.files), 'sources': list(args.files)})


def _calibrate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('file', help='a codebook that says who drew its templates (two people or more)')
    parser.add_argument('--max-wrong-rate', type=wrong_rate, required=True, metavar='RATE',
                        help='the share of gestures of new people that may fire a wrong command, e.g. 0.005')
    parser.add_argument('--output', '-o', required=True, help='the codebook to write')


def _calibrate(args: argparse.Namespace) -> int:
    try:
        model = calibrate(load_codebook(args.file), args.max_wrong_rate,
                          say=lambda line: print(f'[codebook calibrate] {line}', file=sys.stderr))
    except (SocialTouchError, ValueError) as err:
        return _fail('calibrate', err)
    return _write(args, model, f'{args.file} calibrated for {args.max_wrong_rate:g} wrong commands',
                  {'synthetic': _synthetic(args.file), 'source': str(args.file), 'acceptance': model.acceptance_})


INFO = Target(_info_arguments, _info)
ADD = Target(_add_arguments, _add)
REMOVE = Target(_remove_arguments, _remove)
MERGE = Target(_merge_arguments, _merge)
CALIBRATE = Target(_calibrate_arguments, _calibrate)
