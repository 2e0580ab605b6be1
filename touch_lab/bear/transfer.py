"""Across populations: fit the subtype model on one family of simulated people, measure it on another.

``social-touch eval bear --cross`` renders a training and a test scene per family of
:data:`~.evaluate.FAMILIES` once, keeping every cycle's features and active sensors; each model then
classifies every test scene behind the ``NoTouchGate`` and the symbolic gestures are replayed from
those codes through the real :class:`~touch_gestures.bear.symbolic.SymbolicRecogniser`. Scores as in
:mod:`.evaluate`. All data is synthetic.

Training populations (:data:`POPULATIONS`) are the families and ``wide``: the script generator's people
with every :class:`~touch_sim.bear.people.Style` drawn from :data:`~touch_sim.bear.people.WIDE`.
:func:`compare_candidates` scores candidate models (input columns x training populations) across
families: ``social-touch eval bear-models --help``. Two questions before a candidate: why one family's
subtypes read as another's (:func:`feature_spread`, ``--features``: every feature's quartiles per subtype
and family) and how strongly to regularise (:func:`choose_c`, ``--choose-c``: ``C`` chosen by fitting on
one family and measuring on the other, both ways, on training people only).
"""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from touch_gestures.bear.features import FEATURE_NAMES, PERIODIC_CONTACT, RELATIVE_SHAPE
from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.sensor_level import ACTIVATION_THRESHOLD
from touch_gestures.bear.subtype_labels import SUBTYPES, subtype_index
from touch_gestures.bear.subtype_model import design_names
from touch_gestures.bear.symbolic import GestureLibrary, SymbolicRecogniser
from touch_graph.cli.options import positive_float, positive_int, seed
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_sim.bear.people import WIDE, make_scene

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
    stderr_progress,
)

__all__ = [
    'C_GRID',
    'POPULATIONS',
    'Rendered',
    'add_arguments',
    'choose_c',
    'compare_candidates',
    'cross_population',
    'feature_spread',
    'fit_populations',
    'format_candidates',
    'format_choose_c',
    'format_cross',
    'format_spread',
    'population_scene',
    'render',
    'replay',
    'train_seed',
]

#: Populations a model can be trained on: the families of :data:`~.evaluate.FAMILIES` and ``wide``.
POPULATIONS = (*FAMILIES, 'wide')


def train_seed(population: str, seed: int) -> int:
    """Scene seed of ``population``'s training people: seed + 1000 (the families), seed + 2000 (``wide``, so
    its people are not the script family's training people with styles added)."""
    return seed + (2000 if population == 'wide' else 1000)


def population_scene(population: str, n_people: int, seed: int, subtype_reps: int, gesture_reps: int):
    """A labelled scene of ``n_people`` of ``population`` (:data:`POPULATIONS`). Synthetic."""
    if population == 'wide':
        return make_scene(n_people=n_people, seed=seed, subtype_reps=subtype_reps, gesture_reps=gesture_reps,
                          population=WIDE)
    if population not in FAMILIES:
        raise ValueError(f'unknown population {population!r}; populations: {", ".join(POPULATIONS)}')
    return family_scene(population, n_people, seed, subtype_reps, gesture_reps)


@dataclass
class Rendered:
    """A scene and its run with every feature table kept (one rendering serves many models)."""

    scene: object
    run: SceneRun
    recogniser: BearRecogniser


def render(family: str, config: EvalConfig, seed: int, subtype_reps: int, gesture_reps: int, n_people: int,
           progress: Callable[[str], None] | None = None) -> Rendered:
    """Render a scene of ``family`` (one of :data:`POPULATIONS`) through the virtual bear and driver, keeping
    features and active sensors."""
    scene = population_scene(family, n_people, seed, subtype_reps, gesture_reps)
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


def _fit(parts: list[Rendered], seed: int, columns: tuple[str, ...] | None = None, C: float = 1.0) -> SubtypeClassifier:
    rows, codes = [], []
    for r in parts:
        X, y = collect_training_rows(r.run, r.recogniser.fitted, seed=seed)
        rows.append(X)
        codes.append(y)
    return SubtypeClassifier(columns=columns, C=C).fit(np.concatenate(rows), np.concatenate(codes))


def fit_populations(config: EvalConfig, populations: tuple[str, ...], columns: tuple[str, ...] | None = None,
                    progress: Callable[[str], None] | None = None, C: float = 1.0) -> SubtypeClassifier:
    """The subtype model on training scenes of ``populations`` (``config.train_people`` each, seeds of
    :func:`train_seed`, ``config.subtype_reps + 1`` repetitions), with input ``columns`` (None: the default)
    and inverse regularisation ``C``."""
    parts = [render(p, config, train_seed(p, config.seed), config.subtype_reps + 1, 1, config.train_people, progress)
             for p in populations]
    return _fit(parts, config.seed, columns, C)


#: Inverse regularisation strengths :func:`choose_c` tries (scikit-learn's ``C``; 1 is the shipped model's).
C_GRID = (0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0)


def _subtype_accuracy(model: SubtypeClassifier, r: Rendered, config: EvalConfig) -> float | None:
    codes, _ = replay(r, NoTouchGate(model, ACTIVATION_THRESHOLD), GestureLibrary.default(r.recogniser.body_map),
                      r.recogniser.body_map)
    return score_subtypes(r.scene, r.run, codes, r.recogniser.fitted, r.recogniser.body_map,
                          config.rate_hz)['accuracy']


def choose_c(config: EvalConfig, columns: tuple[str, ...] | None = None, grid: tuple[float, ...] = C_GRID,
             progress: Callable[[str], None] | None = None) -> dict:
    """``C`` chosen across families: for each ``C`` of ``grid``, fit on one family's training people and
    measure subtype accuracy on the other's training people, both ways; the chosen ``C`` has the best
    worse-direction accuracy (ties: the better mean, then the smaller ``C``). Only training people
    (seeds of :func:`train_seed`) are seen, so the held-out people stay unseen by the choice.

    Returns ``{'grid': {C: {'<fit> -> <measured>': accuracy}}, 'chosen': C, 'columns', 'config'}``. Synthetic.
    """
    if len(FAMILIES) < 2:
        raise ValueError('choosing C across families needs two families')
    train = {f: render(f, config, train_seed(f, config.seed), config.subtype_reps + 1, 1, config.train_people,
                       progress) for f in FAMILIES}
    table: dict[float, dict[str, float | None]] = {}
    for c in grid:
        if progress:
            progress(f'C = {c:g}')
        table[c] = {f'{a} -> {b}': _subtype_accuracy(_fit([train[a]], config.seed, columns, c), train[b], config)
                    for a in FAMILIES for b in FAMILIES if a != b}

    def merit(c: float) -> tuple[float, float, float]:
        scores = [v if v is not None else 0.0 for v in table[c].values()]
        return min(scores), float(np.mean(scores)), -c
    chosen = max(grid, key=merit)
    return {'data': 'synthetic: simulated people, not recordings of real people', 'grid': table, 'chosen': chosen,
            'columns': None if columns is None else list(columns),
            'config': {'rate_hz': config.rate_hz, 'buffer_len': config.buffer_len,
                       'train_people': config.train_people, 'seed': config.seed, 'reps': config.subtype_reps + 1}}


def format_choose_c(result: dict) -> str:
    """The text table of :func:`choose_c`."""
    directions = list(next(iter(result['grid'].values())))
    lines = ['C chosen across families (SYNTHETIC simulated people; fit on one family\'s training people, '
             'subtype accuracy on the other\'s)', f"{'C':>8s} " + ' '.join(f'{d:>18s}' for d in directions)]
    for c, row in result['grid'].items():
        mark = '  <- chosen' if c == result['chosen'] else ''
        lines.append(f'{c:8g} ' + ' '.join(f'{_pct(row[d]):>18s}' for d in directions) + mark)
    return '\n'.join(lines)


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
    classes = list(dict.fromkeys(c for per in result['scores'].values() for s in per.values() for c in s['recall']))
    lines += ['', 'Recall per subtype (rows: model and test family)',
              f"{'':24s} {'':7s} " + ' '.join(f'{c[:6]:>6s}' for c in classes)]
    for name, per in result['scores'].items():
        for f in fams:
            recall = per[f]['recall']
            lines.append(f'{name:24s} {f:7s} ' + ' '.join(
                f'{100 * recall[c]:5.0f}%' if recall.get(c) is not None else f"{'n/a':>6s}" for c in classes))
    return '\n'.join(lines)


def _pct(value) -> str:
    return '  n/a ' if value is None else f'{100 * value:5.1f} %'


def _without(columns: tuple[str, ...], dropped: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(c for c in columns if c not in dropped)


#: Input columns that read how hard or how fast a person touches rather than what the touch is: the
#: candidates below leave them out (the buffer's peak stays, as the gate's threshold and in every ratio).
PERSON_LEVEL = ('peak_amplitude', 'latest_level', 'base_frequency_hz')

#: Candidate input columns of :func:`compare_candidates`, by name.
CANDIDATE_COLUMNS: dict[str, tuple[str, ...]] = {
    'format-2 inputs': design_names(True),
    'format-2 inputs and band share': (*design_names(True), *PERIODIC_CONTACT),
    'all inputs': design_names(True, FEATURE_NAMES),
    'without person level': _without(design_names(True, FEATURE_NAMES), PERSON_LEVEL),
    'without person level or shape': _without(design_names(True, FEATURE_NAMES), PERSON_LEVEL + RELATIVE_SHAPE),
    'without person or mean level': _without(design_names(True, FEATURE_NAMES),
                                             (*PERSON_LEVEL, 'mean_level', 'std_level')),
}
#: Candidate training sets of :func:`compare_candidates`: name -> populations.
CANDIDATE_TRAINING: dict[str, tuple[str, ...]] = {
    'script': ('script',), 'hands': ('hands',), 'wide': ('wide',), 'script+wide': ('script', 'wide'),
    'script+hands': ('script', 'hands'), 'script+hands+wide': ('script', 'hands', 'wide'),
}


def compare_candidates(config: EvalConfig, columns: dict[str, tuple[str, ...]] | None = None,
                       training: dict[str, tuple[str, ...]] | None = None,
                       progress: Callable[[str], None] | None = None, C: float = 1.0) -> dict:
    """Every candidate (input columns x training populations, inverse regularisation ``C``) on the held-out
    people of every family.

    Returns ``{'rows': [{'columns', 'training', 'scores': {family: summary without the confusion}}], 'config'}``.
    """
    say = progress or (lambda _m: None)
    columns = CANDIDATE_COLUMNS if columns is None else columns
    training = CANDIDATE_TRAINING if training is None else training
    needed = sorted({p for pops in training.values() for p in pops}, key=POPULATIONS.index)
    train = {p: render(p, config, train_seed(p, config.seed), config.subtype_reps + 1, 1, config.train_people, say)
             for p in needed}
    test = {f: render(f, config, config.seed, config.subtype_reps, config.gesture_reps, config.n_people, say)
            for f in FAMILIES}
    body_map = next(iter(test.values())).recogniser.body_map
    library = GestureLibrary.default(body_map)
    rows = []
    for cname, cols in columns.items():
        for tname, pops in training.items():
            say(f'fitting {cname!r} on {tname}')
            gated = NoTouchGate(_fit([train[p] for p in pops], config.seed, cols, C), ACTIVATION_THRESHOLD)
            scores = {}
            for family, r in test.items():
                codes, events = replay(r, gated, library, body_map)
                summary = _summary({
                    'subtype': score_subtypes(r.scene, r.run, codes, r.recogniser.fitted, body_map, config.rate_hz),
                    'symbolic': score_symbolic(r.scene, r.run, events, library)})
                scores[family] = {k: v for k, v in summary.items() if k not in ('confusion', 'labels')}
            rows.append({'columns': cname, 'training': tname, 'scores': scores})
    return {'data': 'synthetic: simulated people, not recordings of real people', 'rows': rows,
            'columns': {k: list(v) for k, v in columns.items()}, 'training': {k: list(v) for k, v in training.items()},
            'config': {'rate_hz': config.rate_hz, 'buffer_len': config.buffer_len, 'n_people': config.n_people,
                       'train_people': config.train_people, 'seed': config.seed, 'reps': config.subtype_reps, 'C': C}}


def format_candidates(result: dict) -> str:
    """The text table of :func:`compare_candidates`: subtype accuracy / lowest class recall per test family."""
    lines = ['Candidate subtype models across families (SYNTHETIC simulated people; held-out people of each family)',
             f"{'input columns':32s} {'trained on':18s} " + ' '.join(f'{f + ": subtypes / lowest":>26s}'
                                                                   for f in FAMILIES)]
    for row in result['rows']:
        cells = [f"{_pct(row['scores'][f]['subtype_accuracy'])} / {_pct(row['scores'][f]['lowest_class_recall'])}"
                 for f in FAMILIES]
        lines.append(f"{row['columns']:32s} {row['training']:18s} " + ' '.join(f'{c:>26s}' for c in cells))
    return '\n'.join(lines)


#: Subtypes :func:`feature_spread` compares by default: the two the hands family reads as the third.
SPREAD_CLASSES = ('hold', 'shake', 'rub')


def feature_spread(config: EvalConfig, classes: tuple[str, ...] = SPREAD_CLASSES,
                   progress: Callable[[str], None] | None = None) -> dict:
    """Per family, per subtype of ``classes`` and per feature: the median and quartiles of the training rows.

    The rows are those :func:`~.evaluate.collect_training_rows` gives a model (sensor-cycles under a touch of
    that subtype), of ``config.train_people`` people of each family (the training seeds). Returns
    ``{'features', 'classes', 'families', 'rows': {family: {class: n}}, 'quartiles': {family: {class:
    (3, n_features) list [q25, median, q75]}}}``. Synthetic people.
    """
    codes = {c: subtype_index(c) for c in classes}
    quartiles: dict[str, dict] = {}
    counts: dict[str, dict] = {}
    for family in FAMILIES:
        r = render(family, config, train_seed(family, config.seed), config.subtype_reps + 1, 1, config.train_people,
                   progress)
        X, y = collect_training_rows(r.run, r.recogniser.fitted, seed=config.seed)
        quartiles[family], counts[family] = {}, {}
        for name, code in codes.items():
            rows = X[y == code]
            counts[family][name] = int(rows.shape[0])
            quartiles[family][name] = (np.quantile(rows, [0.25, 0.5, 0.75], axis=0).tolist() if rows.size
                                       else None)
    return {'data': 'synthetic: simulated people, not recordings of real people', 'features': list(FEATURE_NAMES),
            'classes': list(classes), 'families': list(FAMILIES), 'rows': counts, 'quartiles': quartiles,
            'config': {'rate_hz': config.rate_hz, 'buffer_len': config.buffer_len,
                       'train_people': config.train_people, 'seed': config.seed, 'reps': config.subtype_reps + 1}}


def format_spread(result: dict) -> str:
    """The text table of :func:`feature_spread`: per feature, ``median [q25, q75]`` per family and class."""
    keys = [(f, c) for c in result['classes'] for f in result['families']]
    lines = ['Feature medians [quartiles] per subtype and family (SYNTHETIC simulated people; training rows)',
             f"{'feature':24s} " + ' '.join(f"{c + ' / ' + f:>22s}" for f, c in keys),
             f"{'rows':24s} " + ' '.join(f"{result['rows'][f][c]:>22d}" for f, c in keys)]
    for i, feature in enumerate(result['features']):
        cells = []
        for f, c in keys:
            q = result['quartiles'][f][c]
            cells.append('n/a' if q is None else f'{q[1][i]:.3g} [{q[0][i]:.3g}, {q[2][i]:.3g}]')
        lines.append(f'{feature:24s} ' + ' '.join(f'{cell:>22s}' for cell in cells))
    return '\n'.join(lines)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Options of ``social-touch eval bear-models``."""
    parser.add_argument('--people', type=positive_int, default=6, help='held-out people of each family (6)')
    parser.add_argument('--train-people', type=positive_int, default=8,
                        help='training people of each population (8)')
    parser.add_argument('--repetitions', type=positive_int, default=2, help='repetitions per subtype and person (2)')
    parser.add_argument('--seed', type=seed, default=0, help='test scene seed (0)')
    parser.add_argument('--columns', nargs='+', choices=CANDIDATE_COLUMNS, help='candidate input columns (all)')
    parser.add_argument('--training', nargs='+', choices=CANDIDATE_TRAINING, help='candidate training sets (all)')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--C', type=positive_float, default=1.0, help='inverse regularisation of every candidate (1)')
    parser.add_argument('--choose-c', action='store_true',
                        help='instead of models: C chosen across families on training people (fit on one family, '
                        'measured on the other), for the first of --columns')
    parser.add_argument('--features', nargs='*', metavar='SUBTYPE', choices=SUBTYPES[1:],
                        help='instead of models: per family, the feature medians and quartiles of these subtypes\' '
                             f'training rows (no SUBTYPE: {" ".join(SPREAD_CLASSES)})')


def run(args: argparse.Namespace) -> int:
    """``social-touch eval bear-models``: the candidate table of :func:`compare_candidates`."""
    config = EvalConfig(n_people=args.people, train_people=args.train_people, seed=args.seed,
                        subtype_reps=args.repetitions, gesture_reps=args.repetitions)
    if args.features is not None:
        result = feature_spread(config, tuple(args.features) or SPREAD_CLASSES, progress=stderr_progress)
        print(json.dumps(result) if args.json else format_spread(result))
        return 0
    if args.choose_c:
        result = choose_c(config, CANDIDATE_COLUMNS[args.columns[0]] if args.columns else None,
                          progress=stderr_progress)
        print(json.dumps(result) if args.json else format_choose_c(result))
        return 0
    columns = {k: CANDIDATE_COLUMNS[k] for k in args.columns} if args.columns else None
    training = {k: CANDIDATE_TRAINING[k] for k in args.training} if args.training else None
    result = compare_candidates(config, columns, training, progress=stderr_progress, C=args.C)
    print(json.dumps(result) if args.json else format_candidates(result))
    return 0
