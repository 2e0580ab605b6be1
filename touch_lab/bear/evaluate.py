"""Evaluate the bear recognisers on labelled scenes (synthetic people) through the robot's own graph.

``evaluate(EvalConfig(...))`` plays a training scene and a test scene (different simulated people) on a
virtual bear read by the ``bear_driver`` node in simulated time, trains the eight-subtype model on the
first (behind :class:`~touch_gestures.bear.gate.NoTouchGate`, as in the node) and scores the paper's rule
and the trained model on the second. All figures are on **synthetic** data. Scoring:

- *Subtype, per interaction*: the non-'none' subtype the sensor carried most cycles between the touch's
  start and one cycle after its end. Latency: start to the first cycle carrying the true subtype.
  ``reached_threshold``: share of interactions whose sensor reached the activation threshold (a bound
  on recall behind the gate).
- *Subtype, per cycle*: (9 x 9) confusion of every fitted sensor on every cycle, tails included.
- *Symbolic*: detected when a START of the gesture falls between its start and 1 s after its end; else
  the first other START is its confusion. A START outside every gesture is a false alarm, except during
  subtype interactions (``starts_during_subtype_touches``). Latency includes the dwell. CANDIDATE and
  WITHDRAWN are scored in :mod:`.first_word`. ``gestures``: per gesture, trials, detected and false starts
  (STARTs no trial of the gesture explains, by the performed touch that caused them), :mod:`.false_starts`.
- *Table III* (knight2009 VI.C): activated on first try, with explanation (first or second attempt),
  and regional accuracy (share of active sensor-cycles inside the gesture's locational filter).
- *Compute*: median wall time of one recogniser step, microseconds.
"""

from __future__ import annotations

import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field

import numpy as np

from touch_driver.bear.protocol import REAL_RATE_HZ
from touch_gestures.bear.gate import NoTouchGate
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.sensor_level import ACTIVATION_THRESHOLD
from touch_gestures.bear.subtype_labels import SUBTYPES, TOUCH_SUBTYPES, subtype_index
from touch_gestures.bear.symbolic import START, GestureLibrary
from touch_lab.bear.false_starts import gesture_starts, summarise
from touch_lab.bear.first_word import SYMBOLIC_GRACE_S, score_first_word, start_grace_s
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_sim.bear.hand_people import PORT_OPTIONS, HandScene, make_hand_scene
from touch_sim.bear.people import PERFORMANCES, BearScene, make_scene
from touch_sim.bear.render import BearCycles

__all__ = [
    'FAMILIES',
    'EvalConfig',
    'SceneRun',
    'bear_cycles',
    'collect_training_rows',
    'evaluate',
    'family_scene',
    'percent_text',
    'run_scene',
    'score_subtypes',
    'score_symbolic',
    'seconds_text',
    'start_grace_s',
    'train_subtype_model',
]

PAPER_GESTURES = ('head_pat', 'tickle', 'hug', 'foot_rub')
#: The families of simulated people: ``script`` (touch_sim/bear/people.py: level waveforms with knight2009
#: Table II statistics) and ``hands`` (touch_sim/bear/hand_people.py: hands over plates, written
#: independently from knight2009). Both are synthetic.
FAMILIES = ('script', 'hands')


def percent_text(value: float | None) -> str:
    """A fraction (0..1) as a report's percentage, ``'n/a'`` for None."""
    return 'n/a' if value is None else f'{100 * value:5.1f} %'


def seconds_text(value: float | None) -> str:
    """A duration (s) as a report's seconds, ``'n/a'`` for None."""
    return 'n/a' if value is None else f'{value:.2f} s'


@dataclass
class EvalConfig:
    """What to evaluate.

    Attributes:
        rate_hz: scan rate (3.4 Hz real, knight2009 VI.B).
        buffer_len: cycles per sensor buffer (20, knight2009 V.A).
        n_people: simulated people in the test scene; ``train_people`` in the training scene.
        seed: test scene seed; the training scene uses ``seed + 1000`` (different people).
        subtype_reps, gesture_reps: repetitions per person (gesture_reps >= 2 gives Table III's second column).
        device_options: extra ``BearDevice`` keywords a ``bearsim://`` URL carries (noise, faults, scan, ...).
        detrend: feature detrending, see :mod:`.features`.
        no_touch_gate: the trained model answers 'none' where the buffer never reached the threshold
            (knight2009 V.D's first rule line, :class:`~.gate.NoTouchGate`), as the node does.
        family: the family of simulated people of the test scene (:data:`FAMILIES`).
        train_families: the families of the training scene (one scene of ``train_people`` each).
        gestures: the symbolic gesture library file (None: config/bear_gestures.yaml), e.g. to score
            another version of it on the same people.
    """

    rate_hz: float = REAL_RATE_HZ
    buffer_len: int = 20
    n_people: int = 6
    train_people: int = 8
    seed: int = 0
    subtype_reps: int = 2
    gesture_reps: int = 2
    device_options: dict = field(default_factory=dict)
    detrend: str = 'constant'
    no_touch_gate: bool = True
    family: str = 'script'
    train_families: tuple[str, ...] = ('script',)
    gestures: str | None = None

    def __post_init__(self) -> None:
        for name in (self.family, *self.train_families):
            if name not in FAMILIES:
                raise ValueError(f'unknown family of simulated people {name!r}; families: {", ".join(FAMILIES)}')


def family_scene(family: str, n_people: int, seed: int, subtype_reps: int, gesture_reps: int):
    """A labelled scene of ``n_people`` of ``family`` (:data:`FAMILIES`). Synthetic."""
    if family == 'hands':
        return make_hand_scene(n_people=n_people, seed=seed, subtype_reps=subtype_reps, gesture_reps=gesture_reps)
    return make_scene(n_people=n_people, seed=seed, subtype_reps=subtype_reps, gesture_reps=gesture_reps)


def bear_cycles(stimulus, config: EvalConfig, seed: int) -> BearCycles:
    """The virtual bear and its driver node for ``stimulus`` at the configured rate."""
    options = dict(config.device_options)
    # The real bear reads its 56 channels one by one (5 ms each): that fits up to ~3.57 Hz. Faster
    # rates need the Midplanes read in parallel (8 x 5 ms = 40 ms, the ideal 25 Hz).
    options.setdefault('scan', 'sequential' if config.rate_hz <= 1 / (56 * 0.005) + 1e-9 else 'parallel')
    port = PORT_OPTIONS if isinstance(stimulus, HandScene) else None     # that family's link drops frames
    return BearCycles(stimulus, config.rate_hz, seed=seed, device_options=options, port_options=port)


@dataclass
class SceneRun:
    """Per-cycle record of one scene through the graph and one or more recognisers.

    Attributes:
        times: (n,) float64 cycle times, s.
        truth: (n, 64) int8 true subtype codes per channel.
        active: (n, 64) bool active sensors.
        codes: recogniser name -> (n, 64) int8 predicted codes.
        events: recogniser name -> symbolic events.
        step_us: recogniser name -> (n,) float64 step times, microseconds.
        features: (n, 64, F) float32 feature tables when requested, else None.
    """

    times: np.ndarray
    truth: np.ndarray
    active: np.ndarray
    codes: dict[str, np.ndarray]
    events: dict[str, list]
    step_us: dict[str, np.ndarray]
    features: np.ndarray | None = None


def run_scene(scene: BearScene, source: BearCycles, recognisers: dict[str, BearRecogniser], keep_features: bool = False,
              progress: Callable[[str], None] | None = None) -> SceneRun:
    """Run every cycle of ``scene`` from ``source`` through each recogniser."""
    times, truth, active, feats = [], [], [], []
    codes = {k: [] for k in recognisers}
    events = {k: [] for k in recognisers}
    steps = {k: [] for k in recognisers}
    clock = time.perf_counter_ns
    next_report = 0.0
    for cycle in source.cycles(scene.duration_s):
        row = np.zeros(64, dtype=np.int8)
        for ch, sub in scene.subtype_truth(cycle.t).items():
            row[ch] = subtype_index(sub)
        times.append(cycle.t)
        truth.append(row)
        for name, rec in recognisers.items():
            t0 = clock()
            out = rec.update(cycle.t, cycle.levels, cycle.faulty)
            steps[name].append((clock() - t0) / 1e3)
            codes[name].append(out.codes)
            events[name].extend(out.symbolic_events)
        active.append(out.active)
        if keep_features:
            feats.append(out.features.table)
        if progress is not None and cycle.t >= next_report:
            progress(f'{cycle.t:7.0f} / {scene.duration_s:.0f} s of scene')
            next_report += 300.0
    return SceneRun(np.array(times), np.array(truth), np.array(active),
                    {k: np.array(v) for k, v in codes.items()}, events,
                    {k: np.array(v) for k, v in steps.items()}, np.array(feats) if keep_features else None)


def collect_training_rows(run: SceneRun, fitted: np.ndarray, idle_fraction: float = 0.02,
                          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Feature rows and true codes for training: every fitted sensor-cycle under a contact or with a
    touch still in its buffer, plus ``idle_fraction`` of the idle ones (so 'none' is learnt without
    swamping the rest)."""
    if run.features is None:
        raise ValueError('run_scene(..., keep_features=True) is needed to collect training rows')
    F = run.features[:, fitted]           # (n, k, F)
    y = run.truth[:, fitted]
    busy = (y > 0) | (F[:, :, 0] >= 0.3)
    idle = np.random.default_rng(seed).random(y.shape) < idle_fraction
    keep = busy | idle
    return F[keep], y[keep]


def train_subtype_model(config: EvalConfig, progress: Callable[[str], None] | None = None) -> SubtypeClassifier:
    """Train the eight-subtype model on a training scene of each of ``config.train_families`` (people other
    than the test scene's: seed + 1000)."""
    rows, codes = [], []
    for family in config.train_families:
        scene = family_scene(family, config.train_people, config.seed + 1000, config.subtype_reps + 1, 1)
        rec = BearRecogniser(config.rate_hz, config.buffer_len, detrend=config.detrend, named_outputs=False)
        run = run_scene(scene, bear_cycles(scene, config, config.seed + 1000), {'features': rec}, keep_features=True,
                        progress=progress)
        X, y = collect_training_rows(run, rec.fitted, seed=config.seed)
        rows.append(X)
        codes.append(y)
    return SubtypeClassifier().fit(np.concatenate(rows), np.concatenate(codes))


def _confusion(truth: list[str], pred: list[str], labels: list[str]) -> np.ndarray:
    index = {name: i for i, name in enumerate(labels)}
    out = np.zeros((len(labels), len(labels)), dtype=np.int64)
    for a, b in zip(truth, pred, strict=True):
        out[index[a], index[b]] += 1
    return out


def _precision_recall(confusion: np.ndarray, labels: list[str]) -> dict[str, dict[str, float | None]]:
    out = {}
    for i, name in enumerate(labels):
        predicted, actual = confusion[:, i].sum(), confusion[i].sum()
        out[name] = {'precision': float(confusion[i, i] / predicted) if predicted else None,
                     'recall': float(confusion[i, i] / actual) if actual else None,
                     'support': int(actual)}
    return out


def score_subtypes(scene: BearScene, run: SceneRun, codes: np.ndarray, fitted: np.ndarray, body_map,
                   rate_hz: float) -> dict:
    """Per-interaction and per-cycle subtype scores of one recogniser (see the module docstring)."""
    truth_names, pred_names, latencies = [], [], {s: [] for s in TOUCH_SUBTYPES}
    reached = {s: [] for s in TOUCH_SUBTYPES}
    for label in scene.labels:
        if label.kind != 'subtype':
            continue
        ch = body_map.by_name(label.sensors[0]).channel
        window = (run.times >= label.start_s) & (run.times < label.end_s + 1.0 / rate_hz)
        seen = codes[window, ch]
        reached[label.label].append(bool(run.active[window, ch].any()))
        counts = np.bincount(seen[seen > 0], minlength=len(SUBTYPES))
        pred = SUBTYPES[int(counts.argmax())] if counts.any() else 'none'
        truth_names.append(label.label)
        pred_names.append(pred)
        hits = np.flatnonzero(seen == subtype_index(label.label))
        if hits.size:
            latencies[label.label].append(float(run.times[window][hits[0]] - label.start_s))
    labels = list(SUBTYPES)
    confusion = _confusion(truth_names, pred_names, labels)
    frame = np.zeros((len(SUBTYPES), len(SUBTYPES)), dtype=np.int64)
    np.add.at(frame, (run.truth[:, fitted].ravel(), codes[:, fitted].ravel()), 1)
    all_latencies = [v for vs in latencies.values() for v in vs]
    return {
        'accuracy': float(np.mean([a == b for a, b in zip(truth_names, pred_names, strict=True)]))
        if truth_names else None,
        'interactions': len(truth_names),
        'labels': labels,
        'confusion': confusion.tolist(),
        'per_class': _precision_recall(confusion, labels),
        'frame_accuracy': float(np.trace(frame) / frame.sum()) if frame.sum() else None,
        'frame_confusion': frame.tolist(),
        'median_latency_s': float(np.median(all_latencies)) if all_latencies else None,
        'median_latency_by_subtype_s': {k: (float(np.median(v)) if v else None) for k, v in latencies.items()},
        'reached_threshold': {k: (float(np.mean(v)) if v else None) for k, v in reached.items()},
    }


def score_symbolic(scene: BearScene, run: SceneRun, events: list, library: GestureLibrary) -> dict:
    """Symbolic gesture scores of one recogniser, and the Table III-shaped table."""
    names = [g.name for g in library.detectable]
    starts = [e for e in events if e.state == START]
    used = np.zeros(len(starts), dtype=bool)
    sym = [lab for lab in scene.labels if lab.kind == 'symbolic' and lab.label in names]
    truth, pred, latencies = [], [], {n: [] for n in names}
    detected_by_attempt: dict[tuple[str, int, int], bool] = {}
    for lab in sym:
        lo, hi = lab.start_s, lab.end_s + start_grace_s(library[lab.label])
        inside = [i for i, e in enumerate(starts) if lo <= e.t <= hi]
        for i in inside:
            used[i] = True
        own = [i for i in inside if starts[i].gesture == lab.label]
        if own:
            guess = lab.label
            latencies[lab.label].append(starts[own[0]].t - lab.start_s)
        else:
            guess = starts[inside[0]].gesture if inside else 'none'
        truth.append(lab.label)
        pred.append(guess)
        detected_by_attempt[(lab.label, lab.person, lab.attempt)] = guess == lab.label
    subtype_spans = [(lab.start_s, lab.end_s + SYMBOLIC_GRACE_S) for lab in scene.labels if lab.kind == 'subtype']
    during_subtype = 0
    for i, e in enumerate(starts):
        if used[i]:
            continue
        if any(lo <= e.t <= hi for lo, hi in subtype_spans):
            during_subtype += 1
        else:
            truth.append('none')
            pred.append(e.gesture)
    labels = [*names, 'none']
    confusion = _confusion(truth, pred, labels)
    trials = [(lab.start_s, lab.end_s + (start_grace_s(library[lab.label]) if lab.kind == 'symbolic' else
                                         SYMBOLIC_GRACE_S), lab.kind, lab.label)
              for lab in scene.labels if lab.kind == 'subtype' or lab.label in names]
    own = {n: perf.subtype for n, perf in PERFORMANCES.items()}
    gestures = summarise(gesture_starts(trials, [(e.gesture, e.t) for e in starts], names, own))
    n_labelled = len(sym)
    correct = sum(1 for a, b in zip(truth, pred, strict=True) if a == b and a != 'none')
    all_latencies = [v for vs in latencies.values() for v in vs]
    return {
        'accuracy': float(correct / n_labelled) if n_labelled else None,
        'labelled': n_labelled,
        'labels': labels,
        'confusion': confusion.tolist(),
        'per_class': _precision_recall(confusion, labels),
        'false_alarms': int(confusion[-1, :-1].sum()),
        'starts_during_subtype_touches': during_subtype,
        'median_latency_s': float(np.median(all_latencies)) if all_latencies else None,
        'median_latency_by_gesture_s': {k: (float(np.median(v)) if v else None) for k, v in latencies.items()},
        'table_iii': _table_iii(scene, run, library, detected_by_attempt),
        'gestures': gestures,
    }


def _table_iii(scene: BearScene, run: SceneRun, library: GestureLibrary, detected: dict) -> dict:
    out = {}
    for name in PAPER_GESTURES:
        if name not in library.names:
            continue
        people = sorted({p for (g, p, _) in detected if g == name})
        if not people:
            continue
        first = [detected.get((name, p, 1), False) for p in people]
        explained = [detected.get((name, p, 1), False) or detected.get((name, p, 2), False) for p in people]
        member = np.zeros(64, dtype=bool)
        member[library[name].channels] = True
        inside = total = 0
        for lab in scene.labels:
            if lab.kind == 'symbolic' and lab.label == name:
                window = (run.times >= lab.start_s) & (run.times < lab.end_s)
                act = run.active[window]
                inside += int(act[:, member].sum())
                total += int(act.sum())
        out[name] = {'activated_first_try': float(np.mean(first)),
                     'activated_with_explanation': float(np.mean(explained)),
                     'regional_accuracy': float(inside / total) if total else None,
                     'people': len(people)}
    return out


def evaluate(config: EvalConfig, progress: Callable[[str], None] | None = None,
             model: SubtypeClassifier | None = None) -> dict:
    """Train on one synthetic scene, score rule and model on another; one JSON-ready dict.

    ``model``, when given, is scored as it is (no training scene).

    Top-level keys (the trained model's figures): ``subtype_accuracy``, ``symbolic_accuracy``,
    ``symbolic_false_starts`` (:mod:`.false_starts`),
    ``median_detection_latency_s`` (symbolic START from gesture start), ``median_first_message_s``
    (the gesture's first CANDIDATE or START, :mod:`.first_word`), ``median_subtype_latency_s``,
    ``us_per_cycle``; then ``model`` and ``rule`` with the full scores of each, and the config.
    """
    say = progress or (lambda msg: None)
    library = GestureLibrary.load(config.gestures) if config.gestures else None   # a typo fails before training
    if model is None:
        say(f'training scene: {config.train_people} simulated people at {config.rate_hz} Hz, '
            f'buffer {config.buffer_len}')
        model = train_subtype_model(config, progress=say)
    classifier = NoTouchGate(model, ACTIVATION_THRESHOLD) if config.no_touch_gate else model
    scene = family_scene(config.family, config.n_people, config.seed, config.subtype_reps, config.gesture_reps)
    say(f'test scene: {config.n_people} simulated people ({config.family}), {len(scene.labels)} labelled interactions, '
        f'{scene.duration_s:.0f} s')
    recognisers = {
        'model': BearRecogniser(config.rate_hz, config.buffer_len, classifier=classifier, library=library,
                                detrend=config.detrend),
        'rule': BearRecogniser(config.rate_hz, config.buffer_len, library=library, detrend=config.detrend),
    }
    source = bear_cycles(scene, config, config.seed)
    run = run_scene(scene, source, recognisers, progress=say)
    body_map = recognisers['model'].body_map
    fitted = recognisers['model'].fitted
    library = recognisers['model'].symbolic.library
    results = {}
    for name, _rec in recognisers.items():
        results[name] = {
            'subtype': score_subtypes(scene, run, run.codes[name], fitted, body_map, config.rate_hz),
            'symbolic': score_symbolic(scene, run, run.events[name], library),
            'first_word': score_first_word(scene, run.events[name], library),
            'us_per_cycle': float(np.median(run.step_us[name])),
        }
    best = results['model']
    return {
        'data': f'synthetic: simulated people of the {config.family!r} family (test) and '
                f'{"+".join(config.train_families)!r} (training), not recordings of real people',
        'subtype_accuracy': best['subtype']['accuracy'],
        'symbolic_accuracy': best['symbolic']['accuracy'],
        'median_detection_latency_s': best['symbolic']['median_latency_s'],
        'median_first_message_s': best['first_word']['median_first_message_s'],
        'median_subtype_latency_s': best['subtype']['median_latency_s'],
        'us_per_cycle': best['us_per_cycle'],
        'symbolic_false_starts': best['symbolic']['gestures']['false_starts'],
        'rule_subtype_accuracy': results['rule']['subtype']['accuracy'],
        'rule_symbolic_accuracy': results['rule']['symbolic']['accuracy'],
        'cycles': len(run.times),
        'scene_s': scene.duration_s,
        'driver': dict(source.counters),
        'config': asdict(config),
        'model': results['model'],
        'rule': results['rule'],
    }


def stderr_progress(message: str) -> None:
    """Progress printer for long runs (stderr, so --json output stays clean)."""
    print(f'[eval bear] {message}', file=sys.stderr, flush=True)
