"""``social-touch model info FILE`` and ``social-touch model card FILE --evaluation EVAL.json``.

``info`` prints a model or codebook file's card (:mod:`touch_gestures.model_card`) and what the file
holds; ``card`` records the figures of an ``eval ... --json`` run, and the command that printed them,
in the file's card.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from touch_gestures.model_card import KINDS, attach_card, file_kind, format_card, make_card, read_card
from touch_gestures.patch.model_io import load_model
from touch_gestures.skin.codebook import load_codebook
from touch_graph.errors import SocialTouchError

__all__ = ['add_arguments', 'headline_figures', 'run']


#: Words that mark a figure worth a card: scores, error rates, latencies, counts of trials.
_FIGURE_WORDS = ('accuracy', 'rate', 'latency', 'correct', 'right', 'wrong', 'missed', 'misses', 'false', 'trials',
                 'events', 'rejected', 'tpr')


def headline_figures(report: dict[str, Any], depth: int = 2, prefix: str = '') -> dict[str, float | int]:
    """The numeric figures of an evaluation report (nested up to ``depth``) whose names say what they score.

    >>> headline_figures({'model': {'accuracy': 0.75, 'confusion': [[1]]}, 'seed': 3, 'miss_rate': 0.1})
    {'model.accuracy': 0.75, 'miss_rate': 0.1}
    """
    out: dict[str, float | int] = {}
    for key, value in report.items():
        name = f'{prefix}{key}'
        if isinstance(value, bool):
            continue
        if isinstance(value, (int, float)) and any(w in str(key).lower() for w in _FIGURE_WORDS):
            out[name] = value
        elif isinstance(value, dict) and depth > 1:
            out.update(headline_figures(value, depth - 1, f'{name}.'))
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch model``."""
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    info = sub.add_parser('info', help='print the card of a model or codebook file')
    info.add_argument('file', help='a .npz model or codebook')
    card = sub.add_parser('card', help="record an evaluation's figures in a file's card")
    card.add_argument('file', help='a .npz model or codebook')
    card.add_argument('--evaluation', required=True, metavar='JSON', help='what `eval ... --json` printed')
    card.add_argument('--evaluation-command', required=True, help='the eval command that printed it')
    card.add_argument('--method', default='', help='what the figures measure (default: the command)')


def _describe(path: Path, kind: str | None) -> list[str]:
    """What the file itself says, beside its card."""
    if kind == 'skin_codebook':
        book = load_codebook(path)
        return [f'recogniser {book.name}; {len(book.classes_)} gestures, {len(book.templates_)} templates: '
                f'{", ".join(book.classes_)}']
    if kind == 'bear_subtype_model':
        from touch_lab.bear.subtype_training import SubtypeClassifier  # scikit-learn: only for a bear model
        model = SubtypeClassifier.load(path)
        return [f'classes {", ".join(model.classes_)}; trained at {model.trained_rate_hz_} Hz, buffer '
                f'{model.trained_buffer_len_} cycles']
    if kind == 'patch_gesture_model':
        model = load_model(path)
        return [f'classes {", ".join(model.classes)}; {model.rate_hz:g} Hz, window {model.window} frames']
    return []


def run(args: argparse.Namespace) -> int:
    """0, or 2 with one line on stderr for a file that is not a model."""
    path = Path(args.file)
    try:
        kind = file_kind(path)
        card = read_card(path)
        if kind is None:
            raise ValueError(f'{path} is none of our model files ({", ".join(KINDS)})')
        if args.action == 'card':
            report = json.loads(Path(args.evaluation).read_text(encoding='utf-8'))
            if not isinstance(report, dict):
                raise ValueError(f'{args.evaluation}: expected the JSON object an eval --json prints')
            card = card or make_card(kind, command='(not recorded: made before cards)')
            figures = headline_figures(report)
            if not figures:
                raise ValueError(f'{args.evaluation}: no figure (accuracy, rates, latency) found in it')
            card['evaluation'] = {'method': args.method or args.evaluation_command,
                                  'command': args.evaluation_command,
                                  'synthetic': bool(report.get('synthetic', card.get('data', {}).get('synthetic'))),
                                  **figures}
            attach_card(path, card)
            print(f'{path}: card updated with {len(figures)} figures')
            return 0
        lines = [f'{path}: {kind}', *_describe(path, kind)]
    except (OSError, ValueError, SocialTouchError) as err:
        print(f'social-touch model: error: {err}', file=sys.stderr)
        return 2
    print('\n'.join(lines))
    print(format_card(card) if card else 'no model card: the file was made before cards; regenerate it with its '
          'training command to record how it was made')
    return 0
