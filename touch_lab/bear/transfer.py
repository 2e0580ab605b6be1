"""Across populations: fit the subtype model on one family of simulated people, measure it on another.

``social-touch eval bear --cross`` renders a training and a test scene per family of
:data:`~.evaluate.FAMILIES` once, keeping every cycle's features and active sensors; each model then
classifies every test scene behind the ``NoTouchGate`` and the symbolic gestures are replayed from
those codes through the real :class:`~touch_gestures.bear.symbolic.SymbolicRecogniser`. Scores as in
:mod:`.evaluate`. All data is synthetic.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.sensor_level import ACTIVATION_THRESHOLD
from touch_gestures.bear.symbolic import GestureLibrary, SymbolicRecogniser
from touch_lab.bear.subtype_training import SubtypeClassifier

from .evaluate import (
    FAMILIES,
    EvalConfig,
    SceneRun,
    bear_cycles,
    collect_training_rows,
    family_scene,
    run_scene,
    score_subtypes,
    score_symbolic,
)

__all__ = ['Rendered', 'cross_population', 'format_cross', 'render', 'replay']


@dataclass
class Rendered:
    """A scene and its run with every feature table kept (one rendering serves many models)."""

    scene: object
    run: SceneRun
    recogniser: BearRecogniser


def render(family: str, config: EvalConfig, seed: int, subtype_reps: int, gesture_reps: int, n_people: int,
           progress: Callable[[str], None] | None = None) -> Rendered:
    """Render a ``family`` scene through the virtual bear and driver, keeping features and active sensors."""
    scene = family_scene(family, n_people, seed, subtype_reps, gesture_reps)
    rec = BearRecogniser(config.rate_hz, config.buffer_len, detrend=config.detrend, named_outputs=False,
                         symbolic=False)
    run = run_scene(scene, bear_cycles(scene, config, seed), {'features': rec}, keep_features=True,
                    progress=progress)
    return Rendered(scene, run, rec)


def replay(rendered: Rendered, predictor, library, body_map) -> tuple[np.ndarray, list]:
    """(n, 64) int8 codes of ``predictor`` over the rendered cycles, and the symbolic events they give."""
    run, fitted = rendered.run, rendered.recogniser.fitted
    n = run.features.shape[0]
    codes = np.zeros((n, 64), dtype=np.int8)
    codes[:, fitted] = predictor.predict_codes(run.features[:, fitted].reshape(-1, run.features.shape[-1]))[0] \
        .reshape(n, -1)
    symbolic = SymbolicRecogniser(library, body_map)
    events = []
    for i, t in enumerate(run.times):
        events += symbolic.update(float(t), run.active[i], codes[i])
    return codes, events


def _fit(parts: list[Rendered], seed: int) -> SubtypeClassifier:
    rows, codes = [], []
    for r in parts:
        X, y = collect_training_rows(r.run, r.recogniser.fitted, seed=seed)
        rows.append(X)
        codes.append(y)
    return SubtypeClassifier().fit(np.concatenate(rows), np.concatenate(codes))


def _summary(scores: dict) -> dict:
    sub, sym = scores['subtype'], scores['symbolic']
    recall = {k: v['recall'] for k, v in sub['per_class'].items() if v['recall'] is not None}
    return {'subtype_accuracy': sub['accuracy'], 'lowest_class_recall': min(recall.values()) if recall else None,
            'recall': recall, 'reached_threshold': sub['reached_threshold'],
            'median_subtype_latency_s': sub['median_latency_s'],
            'symbolic_detected': sym['accuracy'], 'symbolic_labelled': sym['labelled'],
            'symbolic_false_alarms': sym['false_alarms'],
            'symbolic_false_alarms_by_gesture': dict(zip(sym['labels'][:-1], sym['confusion'][-1][:-1], strict=True)),
            'symbolic_starts_during_subtype_touches': sym['starts_during_subtype_touches'],
            'median_symbolic_latency_s': sym['median_latency_s'],
            'symbolic_recall': {g: v['recall'] for g, v in sym['per_class'].items() if g != 'none'},
            'symbolic_labelled_by_gesture': {g: v['support'] for g, v in sym['per_class'].items() if g != 'none'},
            'confusion': sub['confusion'], 'labels': sub['labels']}


def cross_population(config: EvalConfig, models: dict[str, SubtypeClassifier] | None = None,
                     progress: Callable[[str], None] | None = None) -> dict:
    """Every training population's model (and ``models``, by name) on every family's held-out people.

    Returns ``{'families', 'scores': {model name: {test family: summary}}, 'config'}``; model names are
    ``fit on <family>``, ``fit on all families`` and the keys of ``models``.
    """
    say = progress or (lambda _m: None)
    train, test = {}, {}
    for family in FAMILIES:
        say(f'{family}: training scene, {config.train_people} people (seed {config.seed + 1000})')
        train[family] = render(family, config, config.seed + 1000, config.subtype_reps + 1, 1, config.train_people,
                               say)
        say(f'{family}: test scene, {config.n_people} people (seed {config.seed})')
        test[family] = render(family, config, config.seed, config.subtype_reps, config.gesture_reps, config.n_people,
                              say)
    fitted = {f'fit on {f}': _fit([train[f]], config.seed) for f in FAMILIES}
    fitted['fit on all families'] = _fit(list(train.values()), config.seed)
    fitted.update(models or {})
    body_map = next(iter(test.values())).recogniser.body_map
    library = GestureLibrary.default(body_map)
    scores: dict[str, dict] = {}
    for name, model in fitted.items():
        gated = NoTouchGate(model, ACTIVATION_THRESHOLD)
        scores[name] = {}
        for family, r in test.items():
            codes, events = replay(r, gated, library, body_map)
            scores[name][family] = _summary({
                'subtype': score_subtypes(r.scene, r.run, codes, r.recogniser.fitted, body_map, config.rate_hz),
                'symbolic': score_symbolic(r.scene, r.run, events, library)})
    return {'data': 'synthetic: simulated people of every family, not recordings of real people',
            'families': list(FAMILIES), 'scores': scores,
            'config': {'rate_hz': config.rate_hz, 'buffer_len': config.buffer_len, 'n_people': config.n_people,
                       'train_people': config.train_people, 'seed': config.seed, 'reps': config.subtype_reps}}


def format_cross(result: dict) -> str:
    """The text table of :func:`cross_population`."""
    fams = result['families']
    head = f"{'model':24s} " + ' '.join(f'{f + ": subtype / lowest class / symbolic / false alarms":>58s}'
                                          for f in fams)
    lines = ['Subtype model across populations (SYNTHETIC simulated people; held-out people of each family)', head]
    for name, per in result['scores'].items():
        cells = []
        for f in fams:
            s = per[f]
            cells.append(f"{_pct(s['subtype_accuracy'])} / {_pct(s['lowest_class_recall'])} / "
                         f"{_pct(s['symbolic_detected'])} / {s['symbolic_false_alarms']:3d}")
        lines.append(f'{name:24s} ' + ' '.join(f'{c:>58s}' for c in cells))
    return '\n'.join(lines)


def _pct(value) -> str:
    return '  n/a ' if value is None else f'{100 * value:5.1f} %'
