"""Does the acceptance score's model transfer across vocabularies? (issue 26, item 2: fit on one file, measure
on the other)

Leave-one-person-out over the ``--measure`` file (``social-touch eval skin-transfer``), each fold's
codebook calibrated for ``--max-wrong-rate`` three ways:

- **own**: weights fit on the fold's codebook (:func:`.acceptance.calibrate_acceptance`);
- **transferred**: weights fit once on the ``--fit`` file's codebook, only the limit set per fold;
- **product**: the score before the model (distance over scale times the ratio to the runner-up);
- the first two again with each context feature (:data:`touch_gestures.skin.doubt.CONTEXT_FEATURES`) added
  alone, with all of them, and added to those the calibration keeps (:data:`.acceptance.SCORE_CONTEXT`)
  (``own+strokes``, ``transferred+all``, ``own+disagreement+size``, ...): a feature is worth keeping only when it
  helps both ways.

Held-out samples are cut at the longest lift a gesture may have, so the figures compare the three
scores with each other; ``eval skin`` gives the absolute ones.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import dataclass

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.doubt import CONTEXT_FEATURES, context_features, touch_size_mm
from touch_gestures.skin.gesture import TouchGesture
from touch_gestures.skin.screening import screen_gesture
from touch_gestures.skin.segmentation import ENDING_GAP_S, ENDING_WAIT_S, SINGLE_STROKE_GAP_S
from touch_graph.cli.options import non_negative_int
from touch_lab.skin.cli import _joined
from touch_lab.skin.datasets import read_traces
from touch_lab.skin.ending_eval import PIECE_GAP_S
from touch_lab.skin.evaluate import choose_codebook
from touch_lab.skin.recognisers import make_recogniser
from touch_sim.skin.render import RenderSettings, default_cache_dir, render_samples
from touch_sim.skin.synthetic import random_touches

from .acceptance import (
    SCORE_CONTEXT,
    HeldOut,
    class_scales,
    fit_weights,
    habits_of,
    held_out_opinions,
    max_score,
    null_touches,
    scores,
    skin_touches,
    wrong_rate,
)

#: Random touches made for each file (the evaluation's generator, touch_sim.skin.synthetic.random_touches).
RANDOM_TOUCHES = 150

__all__ = ['Fold', 'add_arguments', 'folds', 'measure', 'run', 'whole_file_weights']


@dataclass
class Fold:
    """One leave-one-person-out fold's opinions (:class:`.acceptance.HeldOut`): the codebook's own held-out
    templates, the calibration's stray touches, the held-out person's samples (``true`` their class, ``named``
    the recogniser's; ``open`` (N,) bool: neither screened nor rejected by a rule but the score's), the
    evaluation's random touches (``random_open`` likewise, of ``random_made`` touches made)."""

    held: HeldOut
    stray: HeldOut
    stray_made: int
    test: HeldOut
    open: np.ndarray
    samples: int
    randoms: HeldOut
    random_open: np.ndarray
    random_made: int


def _render(path: str, limit: int | None = None):
    samples = read_traces(path, limit=limit).samples
    multi = max(s.n_strokes for s in samples) > 1
    gap = ENDING_GAP_S if multi else SINGLE_STROKE_GAP_S   # as ``eval skin``
    rendered = _joined(render_samples(samples, RenderSettings(mode='sensor', seed=0, gap_s=PIECE_GAP_S,
                                                              min_frames=1), default_cache_dir()),
                       ENDING_WAIT_S if multi else gap)
    randoms = skin_touches(random_touches(RANDOM_TOUCHES, seed=1), 10**6, gap)
    return rendered, randoms, gap


def _opinions(model: TemplateRecogniser, gestures: list[TouchGesture], labels: list[int] | None = None
              ) -> tuple[HeldOut, np.ndarray]:
    """The whole codebook's opinions of ``gestures`` and which are open to the score (module doc)."""
    n = len(model.classes_)
    model.set_acceptance({'class_scales': [1.0] * n, 'max_score': None})   # only the other rules reject
    habits = habits_of(model)
    rows, named, true, open_, context = [], [], [], [], []
    for k, g in enumerate(gestures):
        query = model._query_features(g)
        if query is None:
            continue
        match = model.predict(g)
        per_class = model.query_class_distances(query)
        rows.append(per_class)
        named.append(int(np.searchsorted(model.classes_, match.nearest)) if match.nearest is not None else 0)
        context.append(context_features(habits, named[-1], g.strokes, g.contact_s, model.opinions(g, per_class)[1],
                                        touch_size_mm(g.trajectory)))
        true.append(-1 if labels is None else labels[k])
        open_.append(screen_gesture(g) is None and match.label is not None)
    held = HeldOut(np.array(rows).reshape(-1, n), np.array(named, dtype=np.intp), np.array(true, dtype=np.intp),
                   np.full(len(named), ''), np.array(context).reshape(-1, len(CONTEXT_FEATURES)))
    return held, np.array(open_, dtype=bool)


def folds(path: str, recogniser: str, templates_per_gesture: int | None, say=print,
          limit: int | None = None) -> list[Fold]:
    """Every leave-one-person-out fold of ``path`` (its first ``limit`` samples) read by ``recogniser`` (module
    doc)."""
    rendered, randoms, gap = _render(path, limit)
    stray = null_touches(gap_s=gap)
    subjects = sorted({r.subject for r in rendered})
    out = []
    for k, subject in enumerate(subjects):
        train = [r for r in rendered if r.subject != subject]
        test = [r for r in rendered if r.subject == subject and len(r.gestures) == 1]
        book = choose_codebook(train, templates_per_gesture, np.random.default_rng([0, k]))
        model = make_recogniser(recogniser).fit([r.gestures[0] for r in book], [r.label for r in book],
                                                [r.subject for r in book])
        model = getattr(model, 'chosen_', model)
        held = held_out_opinions(model)
        classes = model.classes_.tolist()
        test_held, test_open = _opinions(model, [r.gestures[0] for r in test], [classes.index(r.label) for r in test])
        stray_held, stray_open = _opinions(model, stray)
        random_held, random_open = _opinions(model, randoms)
        out.append(Fold(held, stray_held.subset(stray_open), len(stray), test_held, test_open,
                        sum(r.subject == subject for r in rendered), random_held, random_open, RANDOM_TOUCHES))
        say(f'fold {k + 1}/{len(subjects)} (subject {subject}) read')
    return out


def whole_file_weights(path: str, recogniser: str, templates_per_gesture: int | None, limit: int | None = None,
                       contexts: tuple[tuple[str, ...], ...] = ((),)) -> list[np.ndarray]:
    """The score's weights fit on ``path``'s whole codebook (everyone, read by each other) against stray touches,
    one per tuple of context features of ``contexts`` (:func:`.acceptance.fit_weights`)."""
    rendered, _, gap = _render(path, limit)
    book = choose_codebook(rendered, templates_per_gesture, np.random.default_rng(0))
    model = make_recogniser(recogniser).fit([r.gestures[0] for r in book], [r.label for r in book],
                                            [r.subject for r in book])
    model = getattr(model, 'chosen_', model)
    held = held_out_opinions(model)
    stray, stray_open = _opinions(model, null_touches(gap_s=gap))
    scales = class_scales(held, len(model.classes_))
    return [fit_weights(held, stray.subset(stray_open), scales, context=c) for c in contexts]


def measure(all_folds: list[Fold], max_wrong_rate: float, weights: str | np.ndarray,
            context: tuple[str, ...] = ()) -> dict:
    """Right, wrong, rejected over the held-out samples and random touches firing, each fold's limit set on its
    codebook with ``weights``: 'own' (fit per fold, with the ``context`` features), 'product', or (5 + K,)
    fixed weights."""
    right = wrong = samples = fired = made = 0
    for f in all_folds:
        scales = class_scales(f.held, f.held.distances.shape[1])
        w = (fit_weights(f.held, f.stray, scales, context=context) if isinstance(weights, str) and weights == 'own'
             else None if isinstance(weights, str) else weights)
        limit = max_score(f.held, f.stray, scales, max_wrong_rate, f.stray_made, w)
        accepted = f.open & (scores(f.test, scales, w) <= limit)
        right += int(np.sum(accepted & (f.test.named == f.test.true)))
        wrong += int(np.sum(accepted & (f.test.named != f.test.true)))
        samples += f.samples
        fired += int(np.sum(f.random_open & (scores(f.randoms, scales, w) <= limit)))
        made += f.random_made
    return {'right': right / samples, 'wrong': wrong / samples, 'rejected': 1 - (right + wrong) / samples,
            'random_fired': fired / made if made else math.nan}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval skin-transfer``."""
    parser.add_argument('--fit', required=True, help='trace file the transferred weights are fit on')
    parser.add_argument('--fit-recogniser', default='trace', help='recogniser of the --fit codebook (trace)')
    parser.add_argument('--fit-templates-per-gesture', type=non_negative_int, default=0,
                        help='codebook size per gesture of --fit (0: all)')
    parser.add_argument('--measure', required=True, help='trace file measured leave-one-person-out')
    parser.add_argument('--measure-recogniser', default='fused', help='recogniser measured (fused)')
    parser.add_argument('--templates-per-gesture', type=non_negative_int, default=0,
                        help='codebook size per gesture of --measure (0: all)')
    parser.add_argument('--max-wrong-rate', type=wrong_rate, default=0.005, metavar='RATE',
                        help='share of wrong commands each fold is calibrated for (0.005)')
    parser.add_argument('--limit', type=non_negative_int, default=0,
                        help='use only the first N samples of each file (0: all): for trying things out')
    parser.add_argument('--json', action='store_true', help='print one JSON object instead of text')


def run(args: argparse.Namespace) -> int:
    """``social-touch eval skin-transfer``: the module doc's comparison of the three scores."""
    def say(line: str) -> None:
        print(f'[acceptance transfer] {line}', file=sys.stderr, flush=True)

    limit = args.limit or None
    # No context, each feature alone, all of them, and each other feature added to the calibration's (SCORE_CONTEXT).
    extra = [n for n in CONTEXT_FEATURES if n not in SCORE_CONTEXT]
    variants = [(), *((n,) for n in CONTEXT_FEATURES), CONTEXT_FEATURES, *((*SCORE_CONTEXT, n) for n in extra)]
    names = ['', *(f'+{n}' for n in CONTEXT_FEATURES), '+all', *(f'+{"+".join(SCORE_CONTEXT)}+{n}' for n in extra)]
    with_all = variants.index(CONTEXT_FEATURES)
    fitted = whole_file_weights(args.fit, args.fit_recogniser, args.fit_templates_per_gesture or None, limit,
                                tuple(variants))
    transferred = fitted[0]
    say(f'weights fit on {args.fit}: {np.round(transferred, 3).tolist()}; with all context features '
        f'{np.round(fitted[with_all], 3).tolist()}')
    measured = folds(args.measure, args.measure_recogniser, args.templates_per_gesture or None, say, limit)
    scored = {}
    for name, context, fixed in zip(names, variants, fitted, strict=True):
        scored[f'own{name}'] = measure(measured, args.max_wrong_rate, 'own', context)
        scored[f'transferred{name}'] = measure(measured, args.max_wrong_rate, fixed)
    scored['product'] = measure(measured, args.max_wrong_rate, 'product')
    result = {'fit': args.fit, 'fit_recogniser': args.fit_recogniser, 'measure': args.measure,
              'measure_recogniser': args.measure_recogniser,
              'fit_templates_per_gesture': args.fit_templates_per_gesture or 'all',
              'templates_per_gesture': args.templates_per_gesture or 'all',
              **({'limit': limit} if limit else {}),
              'max_wrong_rate': args.max_wrong_rate, 'transferred_weights': transferred.tolist(),
              'transferred_weights_context': fitted[with_all].tolist(), 'scores': scored}
    if args.json:
        print(json.dumps(result, indent=1))
    else:
        for name, r in result['scores'].items():
            print(f"{name:26s} right {r['right']:.2%} wrong {r['wrong']:.2%} rejected {r['rejected']:.2%} "
                  f"random touches firing {r['random_fired']:.2%}")
    return 0
