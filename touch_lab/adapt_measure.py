"""``social-touch eval adapt bear|patch|skin``: what adapting to a new person buys (SYNTHETIC).

A base model is trained on ``--people`` simulated people; each of ``--new-people`` others records
:data:`REPETITIONS` trials per class: the first ``k`` per class adapt the model (:mod:`touch_lab.adapt`),
the last :data:`TEST_TRIALS` test it, for k = 0, 1, 3, 5, scored as ``eval --bags`` scores them.
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
from collections import defaultdict
from dataclasses import replace
from pathlib import Path

import numpy as np

from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.patch.classifier import decide
from touch_gestures.patch.features import window_features
from touch_graph.cli.options import positive_int, seed
from touch_lab.bear.sessions import bear_trials, fit_model, score_trials
from touch_lab.collect.protocol import DEFAULT_GESTURES, Protocol
from touch_lab.collect.session_bag import read_session
from touch_lab.collect.simulate import simulate_session
from touch_lab.patch.evaluate import onset_ages, run_detector, score
from touch_lab.patch.session_bags import trial_sessions
from touch_lab.patch.training import PatchGestureClassifier
from touch_lab.skin import sessions as skin_sessions

from .adapt import adapt_bear, adapt_patch

__all__ = ['KS', 'add_arguments', 'measure', 'run']


KS = (0, 1, 3, 5)
REPETITIONS = 8
TEST_TRIALS = 3
#: The bear's classes here: tap is left out, at 3.4 Hz it falls between two readings of its sensor.
BEAR_GESTURES = ('poke', 'pat', 'tickle', 'pet', 'hold', 'shake', 'rub')


def _split(labels, k: int) -> tuple[list[int], list[int]]:
    """Indices of the first ``k`` trials per class (adaptation) and the last TEST_TRIALS per class (test)."""
    by_class = defaultdict(list)
    for i, lab in enumerate(labels):
        by_class[lab.gesture].append(i)
    adapt = [i for idx in by_class.values() for i in idx[:k]]
    test = [i for idx in by_class.values() for i in idx[-TEST_TRIALS:]]
    return adapt, test


def _patch(base_bags, new_bags, seed, say) -> dict[int, list[float]]:
    train = trial_sessions([read_session(b, 'patch') for b in base_bags])
    rate = train[0].rate_hz
    window = round(3.0 * rate)
    X = np.concatenate([window_features(s.activations, window) for s in train])
    y = np.concatenate([[s.gesture] * s.n_frames for s in train])
    base = PatchGestureClassifier(n_components=3, random_state=seed).fit(X, y)
    classes = tuple(str(c) for c in base.classes_)
    out: dict[int, list[float]] = {k: [] for k in KS}
    for bag in new_bags:
        rec = read_session(bag, 'patch')
        trials = trial_sessions([rec])
        feats = [window_features(s.activations, window) for s in trials]
        for k in KS:
            adapt_idx, test_idx = _split(rec.labels, k)
            clf = base
            if adapt_idx:
                clf = adapt_patch(base, np.concatenate([feats[i] for i in adapt_idx]),
                                  np.concatenate([[trials[i].gesture] * len(feats[i]) for i in adapt_idx]))
            correct = 0
            for i in test_idx:
                lp = clf.predict_log_proba(feats[i])
                dets = run_detector(lp, onset_ages(trials[i].activations, window), classes, 0.99, 0.9, rate, dwell=5)
                m = score(dets, trials[i].events, trials[i].gesture, decide(lp, 0.99), classes, rate,
                          late_s=window / rate)
                correct += m.event_correct
            out[k].append(correct / len(test_idx))
        say(f'{rec.people[0]}: ' + ', '.join(f'k={k} {out[k][-1]:.2f}' for k in KS))
    return out


def _bear(base_bags, new_bags, seed, say) -> dict[int, list[float]]:
    base = fit_model([bear_trials(read_session(b, 'bear'), 3.4, 20) for b in base_bags], seed=seed,
                     drop_thin=say)
    out: dict[int, list[float]] = {k: [] for k in KS}
    for bag in new_bags:
        run = bear_trials(read_session(bag, 'bear'), 3.4, 20)
        for k in KS:
            adapt_idx, test_idx = _split(run.labels, k)
            model = base
            if adapt_idx:
                rows, codes = [], []
                for i in adapt_idx:   # the cycles of the chosen trials on their touched sensors
                    lab, channels = run.labels[i], run.touched[i]
                    inside = (run.times >= lab.start_s) & (run.times <= lab.end_s + 1 / 3.4)
                    rows.append(run.features[np.ix_(inside, channels)].reshape(-1, run.features.shape[-1]))
                    codes.append(run.truth[np.ix_(inside, channels)].ravel())
                model = adapt_bear(base, np.concatenate(rows), np.concatenate(codes))
            test = _subset(run, test_idx)
            out[k].append(score_trials([test], NoTouchGate(model))['accuracy'])
        say(f'{run.session.people[0]}: ' + ', '.join(f'k={k} {out[k][-1]:.2f}' for k in KS))
    return out


def _subset(run, idx):
    return replace(run, labels=[run.labels[i] for i in idx], touched=[run.touched[i] for i in idx])


def _skin(base_bags, new_bags, seed, say) -> dict[int, list[float]]:
    base_trials = [t for b in base_bags for t in skin_sessions.skin_trials(read_session(b, 'skin'))]
    base = skin_sessions.fit_codebook(base_trials, 'trace')
    out: dict[int, list[float]] = {k: [] for k in KS}
    for bag in new_bags:
        rec = read_session(bag, 'skin')
        trials = skin_sessions.skin_trials(rec)
        for k in KS:
            adapt_idx, test_idx = _split(rec.labels, k)
            model = (skin_sessions.fit_codebook([trials[i] for i in adapt_idx], base.name, base=base)
                     if adapt_idx else base)
            out[k].append(skin_sessions.score(model, [trials[i] for i in test_idx])['accuracy'])
        say(f'{rec.people[0]}: ' + ', '.join(f'k={k} {out[k][-1]:.2f}' for k in KS))
    return out


_MEASURE = {'bear': _bear, 'patch': _patch, 'skin': _skin}


def measure(sensor: str, people: int = 4, new_people: int = 3, seed: int = 0, progress=None) -> dict:
    """Mean accuracy (and per new person) for k = 0, 1, 3, 5 adaptation examples per class (module doc)."""
    say = progress or (lambda _m: None)
    gestures = BEAR_GESTURES if sensor == 'bear' else DEFAULT_GESTURES[sensor]
    with tempfile.TemporaryDirectory(prefix='adapt-') as tmp:
        root = Path(tmp)
        base_bags, new_bags = [], []
        for i in range(people):
            say(f'base person {i + 1}/{people}')
            base_bags.append(simulate_session(sensor, Protocol(gestures, repetitions=3, pause_s=2.0, seed=seed), i,
                                              people, root / f'base_{i}', seed=seed))
        for i in range(new_people):
            say(f'new person {i + 1}/{new_people} ({REPETITIONS} trials per class)')
            new_bags.append(simulate_session(sensor, Protocol(gestures, repetitions=REPETITIONS, pause_s=2.0,
                                                              seed=seed + 1), i, new_people, root / f'new_{i}',
                                             seed=seed + 500))
        per_k = _MEASURE[sensor](base_bags, new_bags, seed, say)
    return {'sensor': sensor, 'synthetic': True, 'people': people, 'new_people': new_people, 'seed': seed,
            'classes': list(gestures), 'test_trials_per_class': TEST_TRIALS,
            'accuracy': {k: float(np.mean(v)) for k, v in per_k.items()},
            'per_person': {k: [float(a) for a in v] for k, v in per_k.items()}}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval adapt``."""
    parser.add_argument('sensor', choices=('bear', 'patch', 'skin'))
    parser.add_argument('--people', type=positive_int, default=4, help='simulated people of the base model (4)')
    parser.add_argument('--new-people', type=positive_int, default=3, help='other simulated people adapted to (3)')
    parser.add_argument('--seed', type=seed, default=0, help='population seed; the new people use seed + 500 (0)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def run(args: argparse.Namespace) -> int:
    """Measure and print the table row."""
    if args.people < 2 or args.new_people < 1:
        print('social-touch eval adapt: error: need --people >= 2 and --new-people >= 1', file=sys.stderr)
        return 2
    result = measure(args.sensor, args.people, args.new_people, args.seed,
                     lambda m: print(f'[adapt {args.sensor}] {m}', file=sys.stderr, flush=True))
    if args.json:
        print(json.dumps(result))
        return 0
    acc = result['accuracy']
    print(f"{args.sensor}: accuracy of {args.new_people} new simulated people (SYNTHETIC), base model of "
          f"{args.people} others, {TEST_TRIALS} test trials per class")
    print('| examples per class | ' + ' | '.join(str(k) for k in KS) + ' |')
    print('|---|' + '---|' * len(KS))
    print(f'| {args.sensor} | ' + ' | '.join(f'{100 * acc[k]:.0f} %' for k in KS) + ' |')
    return 0
