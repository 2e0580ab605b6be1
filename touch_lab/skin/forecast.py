"""``social-touch codebook forecast``: which gestures of a vocabulary the skin will confuse, before deploying it.

Each person's templates are read by a codebook of the others
(:func:`touch_lab.skin.acceptance.held_out_opinions`); a codebook of one person is read a fifth at a time
(:data:`FOLDS`), which the output says. Per pair of classes: the share of their held-out templates named
as the other, and the median ratio of the distance to the other class over the distance to their own.
A pair confused at :data:`CONFUSED_SHARE` or more, or with a median ratio under :data:`NEAR_RATIO`, is
one the skin cannot reliably tell apart.
"""

from __future__ import annotations

import argparse
import copy
import json
import sys
import warnings
from dataclasses import dataclass

import numpy as np

from touch_graph.cli.options import positive_int
from touch_graph.errors import SocialTouchError
from touch_lab.cli.targets import Target
from touch_lab.skin.acceptance import HeldOut, held_out_opinions
from touch_lab.skin.recognisers import load_codebook

__all__ = ['CONFUSED_SHARE', 'FOLDS', 'FORECAST', 'NEAR_RATIO', 'Forecast', 'forecast']

#: A single person's codebook is read in this many folds of templates.
FOLDS = 5
#: Share of a pair's held-out templates named as the other class from which the pair is called confused.
CONFUSED_SHARE = 0.05
#: Median distance ratio (other class over own) under which two classes are called too near.
NEAR_RATIO = 1.2


@dataclass(frozen=True)
class Forecast:
    """The held-out reading of a codebook (C classes).

    Attributes:
        classes: (C,) class names.
        confusion: (C, C) counts, row = the template's class, column = the class named.
        ratios: (C, C) median over the row class's held-out templates of distance to the column class over
            distance to their own class (nan: no usable template; the diagonal is 1).
        unit: 'person' (leave-one-person-out) or 'fold' (one person's codebook, :data:`FOLDS` folds).
        people: how many people (or folds) were held out in turn.
    """

    classes: np.ndarray
    confusion: np.ndarray
    ratios: np.ndarray
    unit: str
    people: int

    def right(self) -> np.ndarray:
        """(C,) share of each class's held-out templates named right (nan: none held out)."""
        n = self.confusion.sum(axis=1)
        return np.divide(np.diag(self.confusion), n, out=np.full(len(n), np.nan), where=n > 0)

    def pairs(self) -> list[dict]:
        """Every pair of classes, the most confusable first: names, confused share, nearest median ratio."""
        out = []
        n = self.confusion.sum(axis=1)
        for i in range(len(self.classes)):
            for j in range(i + 1, len(self.classes)):
                total = n[i] + n[j]
                confused = (self.confusion[i, j] + self.confusion[j, i]) / total if total else 0.0
                near = np.nanmin([self.ratios[i, j], self.ratios[j, i]]) if not (
                    np.isnan(self.ratios[i, j]) and np.isnan(self.ratios[j, i])) else float('nan')
                out.append({'classes': [str(self.classes[i]), str(self.classes[j])], 'confused': float(confused),
                            'median_ratio': float(near),
                            'apart': bool(confused < CONFUSED_SHARE and not near < NEAR_RATIO)})
        return sorted(out, key=lambda p: (-p['confused'], p['median_ratio'] if p['median_ratio'] == p['median_ratio']
                                          else np.inf))


def _held_out(recogniser, per_class: int | None) -> tuple[HeldOut, str, int]:
    people = getattr(recogniser, 'template_people_', None)
    known = set() if people is None else set(people.tolist()) - {''}
    if len(known) >= 2:
        return held_out_opinions(recogniser, per_class), 'person', len(known)
    folded = copy.copy(recogniser)
    labels = recogniser.template_labels_
    fold = np.empty(len(labels), dtype=object)
    for c in np.unique(labels):   # each class's templates dealt round the folds, so every fold holds each class
        where = np.flatnonzero(labels == c)
        fold[where] = [f'fold{k % FOLDS}' for k in range(len(where))]
    folded.template_people_ = fold.astype(str)
    return held_out_opinions(folded, per_class), 'fold', FOLDS


def forecast(recogniser, per_class: int | None = None) -> Forecast:
    """Forecast the confusions of a fitted codebook on people it has not seen (module doc).

    Args:
        recogniser: a fitted skin recogniser (``load_codebook``) with at least two templates per class.
        per_class: read at most this many templates per class and person (None: all).

    Raises:
        ValueError: a class with fewer than two templates (nothing to hold out), or fewer than two classes.
    """
    classes = recogniser.classes_
    if len(classes) < 2:
        raise ValueError(f'a forecast needs at least two gestures; the codebook has {len(classes)}')
    counts = np.bincount(recogniser.template_labels_, minlength=len(classes))
    if counts.min() < 2:
        thin = ', '.join(str(c) for c in classes[counts < 2])
        raise ValueError(f'every gesture needs two templates or more to hold one out; too few: {thin}')
    held, unit, people = _held_out(recogniser, per_class)
    n = len(classes)
    confusion = np.zeros((n, n), dtype=np.int64)
    np.add.at(confusion, (held.true, held.named), 1)
    ratios = np.full((n, n), np.nan)
    own = held.distances[np.arange(len(held.true)), held.true]
    usable = np.isfinite(own) & (own > 0)   # a class the fold lacked, or a template identical to another: no ratio
    for c in range(n):
        mine = usable & (held.true == c)
        if mine.any():
            ratio = held.distances[mine] / own[mine][:, None]
            ratio[~np.isfinite(ratio)] = np.nan   # a class the reading codebook lacked says nothing
            with warnings.catch_warnings():   # a column of nan (a class never read beside c) stays nan
                warnings.simplefilter('ignore', RuntimeWarning)
                ratios[c] = np.nanmedian(ratio, axis=0)
    return Forecast(classes, confusion, ratios, unit, people)


def _arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('file', help='a skin codebook (.npz), best recorded by several people (--person)')
    parser.add_argument('--json', action='store_true', help='print one JSON object instead of text')
    parser.add_argument('--top', type=positive_int, default=10, metavar='K',
                        help='pairs to list, the most confusable first (default 10)')
    parser.add_argument('--per-class', type=positive_int, default=None, metavar='N',
                        help='read at most N templates per gesture and person (default: all)')


def _text(path: str, result: Forecast, top: int) -> list[str]:
    who = (f'leave-one-person-out over {result.people} people' if result.unit == 'person' else
           f'one person: a fifth of the templates at a time read by the rest ({FOLDS} folds); this forecasts how '
           "that person's own gestures are told apart, not new people's")
    lines = [f'{path}: {len(result.classes)} gestures, {int(result.confusion.sum())} templates held out, {who}',
             '', f'{"gesture":18s} {"right":>7s}  most often read as']
    for i, (name, right) in enumerate(zip(result.classes, result.right(), strict=True)):
        row = result.confusion[i].copy()
        row[i] = 0
        wrong = f'{result.classes[row.argmax()]} ({row.max()})' if row.max() else '-'
        lines.append(f'{name!s:18s} {right:7.1%}  {wrong}')
    pairs = result.pairs()
    lines += ['', 'pairs, most confusable first (confused: share of both classes\' held-out templates named as '
                  'the other; ratio: median distance to the other class over the own, 1 = as near):']
    for p in pairs[:top]:
        lines.append(f'  {p["classes"][0]:>12s} / {p["classes"][1]:<12s} confused {p["confused"]:6.1%}  '
                     f'ratio {p["median_ratio"]:5.2f}' + ('' if p['apart'] else '  <- hard to tell apart'))
    hard = [p for p in pairs if not p['apart']]
    lines += ['', f'{len(hard)} pair(s) the skin cannot reliably tell apart (confused >= {CONFUSED_SHARE:.0%} or '
                  f'ratio < {NEAR_RATIO:g}): record more repetitions, change one gesture of each pair, or give both '
                  'one command.' if hard else 'every pair told apart in the held-out reading.']
    return lines


def _run(args: argparse.Namespace) -> int:
    try:
        result = forecast(load_codebook(args.file), args.per_class)
    except (SocialTouchError, ValueError, OSError) as err:
        print(f'social-touch codebook forecast: error: {err}', file=sys.stderr)
        return 2
    if args.json:
        print(json.dumps({'file': args.file, 'unit': result.unit, 'held_out_groups': result.people,
                          'classes': [str(c) for c in result.classes], 'confusion': result.confusion.tolist(),
                          'right': [None if np.isnan(r) else float(r) for r in result.right()],
                          'pairs': result.pairs()[:args.top]}, indent=1))
    else:
        print('\n'.join(_text(args.file, result, args.top)))
    return 0


FORECAST = Target(_arguments, _run)
