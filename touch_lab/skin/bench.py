"""Benchmark: microseconds per recognition with a codebook of n gestures x m templates.

Goal (issue 6): at most 50 us per ``predict`` (features + matching + decision) with 16 gestures x 30
templates on one core; issue 13 allows the multi-stroke recognisers 100 us (``goal_us_multistroke``).
``early`` is one candidate of :class:`~touch_gestures.skin.early.PrefixMatcher` on the cloud codebook for the
first half of each gesture. The gestures are synthetic (:func:`~touch_sim.skin.synthetic.synthetic_traces`).
Reported: the median over ``repeats`` (wall and thread CPU time), its ratio to the goal and to the
centroid method, measured in the same run: ``social-touch bench skin [--json]``.

``steps_cpu_us`` splits a ``predict`` into the steps of
:meth:`~touch_gestures.skin.base.TemplateRecogniser.predict` (:func:`predict_steps`): ``features``,
``search`` (``distances``), ``minima``, ``evidence``, ``decision``, ``order`` and ``other`` (the rest of
``predict``); for ``cloud`` also ``raster`` (part of ``search``, not added to the total).
``fused_3_strokes`` times :data:`MULTISTROKE_DEFAULT` on the same gestures cut into three strokes (all
3! orders searched); ``templates`` there counts the trace's rows.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from touch_gestures.skin.base import PREDICT_STEPS, Match, TemplateRecogniser
from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.early import PrefixMatcher
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.bench.timing import gc_paused
from touch_lab.skin.recognisers import MULTISTROKE_RECOGNISER, RECOGNISERS, AutoRecogniser, make_recogniser
from touch_sim.skin.synthetic import SHAPES, synthetic_traces

__all__ = ['GOAL_US', 'GOAL_US_MULTISTROKE', 'LIFT_S', 'STEPS', 'bench_acceptance', 'bench_recognition',
           'in_strokes', 'predict_steps', 'synthetic_codebook']

GOAL_US = 50.0
GOAL_US_MULTISTROKE = 100.0
#: What ``auto`` picks for a multi-stroke vocabulary (:mod:`touch_lab.skin.recognisers.auto`): ``fused_3_strokes``
#: times it.
MULTISTROKE_DEFAULT = AutoRecogniser().order_free
#: The lift (s) between the strokes of ``fused_3_strokes``'s gestures.
LIFT_S = 0.3
#: The steps of a recognition that ``steps_cpu_us`` times (module doc), in predict's order.
STEPS = PREDICT_STEPS


def synthetic_codebook(n_gestures: int = 16, templates_per_gesture: int = 30, seed: int = 0
                       ) -> tuple[list[TouchGesture], list[str]]:
    """``n_gestures`` x ``templates_per_gesture`` synthetic gestures (first shapes of SHAPES), 150 Hz."""
    shapes = list(SHAPES)[:n_gestures]
    if len(shapes) < n_gestures:
        raise ValueError(f'at most {len(SHAPES)} synthetic shapes, asked for {n_gestures}')
    performers = 3
    reps = -(-templates_per_gesture // performers)
    traces = synthetic_traces(shapes, performers=performers, repetitions=reps, seed=seed, rate_hz=150.0)
    gestures, labels, count = [], [], {}
    for s in traces:
        if count.get(s.gesture, 0) >= templates_per_gesture:
            continue
        count[s.gesture] = count.get(s.gesture, 0) + 1
        gestures.append(TouchGesture.from_trajectory(np.column_stack([s.x, s.y]), s.t_ms / 1000.0))
        labels.append(s.gesture)
    return gestures, labels


def in_strokes(gesture: TouchGesture, k: int, lift_s: float = LIFT_S) -> TouchGesture:
    """``gesture`` (one stroke) cut into ``k`` strokes of equal points, the later ones ``lift_s`` s later per lift."""
    n = len(gesture.trajectory)
    stroke = (np.arange(n) * k // max(n, 1)).astype(np.int16)
    return TouchGesture(gesture.binary_map, gesture.peak_map, gesture.trajectory, gesture.times + stroke * lift_s,
                        stroke, frames=gesture.frames, start_s=gesture.start_s,
                        duration_s=gesture.duration_s + (k - 1) * lift_s, strokes=k)


def bench_recognition(names: list[str] | None = None, n_gestures: int = 16, templates_per_gesture: int = 30,
                      queries: int = 64, repeats: int = 7, seed: int = 0) -> dict:
    """Median us per ``predict`` for each recogniser (module doc); returns a JSON-ready dict."""
    names = list(RECOGNISERS) if names is None else names
    gestures, labels = synthetic_codebook(n_gestures, templates_per_gesture, seed)
    probe, _ = synthetic_codebook(n_gestures, max(1, -(-queries // n_gestures)), seed + 1)
    probe = probe[:queries]
    out: dict = {'goal_us': GOAL_US,
                 'goal_us_multistroke': GOAL_US_MULTISTROKE, 'gestures': n_gestures,
                 'templates_per_gesture': templates_per_gesture, 'queries': len(probe), 'repeats': repeats,
                 'data': 'synthetic gestures', 'recognisers': {}}
    for name in names:
        model = make_recogniser(name).fit(gestures, labels)
        us, cpu_us = _median_us(model.predict, probe, repeats)
        out['recognisers'][name] = {'us_per_recognition': us, 'cpu_us_per_recognition': cpu_us,
                                    'ratio_to_goal': us / GOAL_US, 'templates': len(model.templates_),
                                    'steps_cpu_us': _steps_cpu_us(model, probe, repeats, cpu_us)}
        if name in ('cloud', 'ndollar', 'refereed', 'fused', 'oriented', 'fused_oriented', 'auto'):
            out['recognisers'][name]['ratio_to_multistroke_goal'] = us / GOAL_US_MULTISTROKE
        if name == 'cloud':
            halves = [TouchGesture.from_trajectory(g.trajectory[:max(1, len(g.trajectory) // 2)],
                                                   g.times[:max(1, len(g.times) // 2)]) for g in probe]
            early, early_cpu = _median_us(PrefixMatcher(model).candidate, halves, repeats)
            out['early'] = {'recogniser': name, 'us_per_candidate': early, 'cpu_us_per_candidate': early_cpu,
                            'ratio_to_goal': early / GOAL_US_MULTISTROKE}
    if MULTISTROKE_DEFAULT in names:
        cut = [in_strokes(g, 3) for g in gestures]
        model = make_recogniser(MULTISTROKE_DEFAULT).fit(cut, labels)
        us, cpu_us = _median_us(model.predict, [in_strokes(g, 3) for g in probe], repeats)
        out['fused_3_strokes'] = {'recogniser': MULTISTROKE_DEFAULT, 'us_per_recognition': us,
                                  'cpu_us_per_recognition': cpu_us,
                                  'templates': len(model.trace_.templates_),
                                  'ratio_to_multistroke_goal': us / GOAL_US_MULTISTROKE}
    base = out['recognisers'].get('centroid', {}).get('us_per_recognition')
    if base:
        for r in out['recognisers'].values():
            r['ratio_to_centroid'] = r['us_per_recognition'] / base
    return out


def predict_steps(model: TemplateRecogniser, gesture: TouchGesture, clock=time.thread_time_ns
                  ) -> tuple[Match, dict[str, int]]:
    """``model.predict(gesture)`` with the ``clock`` (ns) read after each of its steps (module doc): the
    answer, and the ns of each step (a step not reached takes 0)."""
    model = getattr(model, 'chosen_', model)   # auto predicts with the recogniser it chose
    ns = dict.fromkeys(STEPS, 0)
    last = [clock()]

    def step(name: str) -> None:
        now = clock()
        ns[name] += now - last[0]
        last[0] = now

    return model._predict(gesture, step), ns


def _steps_cpu_us(model: TemplateRecogniser, probe: list[TouchGesture], repeats: int, whole_cpu_us: float
                  ) -> dict[str, float]:
    """Median CPU us of each step of ``model.predict`` over the ``probe`` gestures, and ``other``: the
    whole ``predict``'s ``whole_cpu_us`` less the steps (module doc)."""
    clock = time.thread_time_ns
    reads = [-(clock() - clock()) for _ in range(1001)]
    read_ns = statistics.median(reads)   # one clock read, ns: taken off each step
    for gesture in probe[:3]:
        predict_steps(model, gesture)    # warm up, as _median_us
    runs = []
    with gc_paused():
        for _ in range(repeats):
            total = dict.fromkeys(STEPS, 0.0)
            for gesture in probe:
                for step, ns in predict_steps(model, gesture, clock)[1].items():
                    total[step] += max(ns - read_ns, 0) if ns else 0.0
            runs.append(total)
    steps = {step: statistics.median(r[step] for r in runs) / len(probe) / 1e3 for step in STEPS}
    steps['other'] = whole_cpu_us - sum(steps.values())
    if isinstance(model, CloudRecogniser):
        clouds = [q.reshape(-1, 2).astype(np.float64) for q in map(model.features, probe) if q is not None]
        steps['raster'] = _median_us(model._bounds, clouds, repeats)[1]
    return steps


def _median_us(call, items: list, repeats: int) -> tuple[float, float]:
    """Median over ``repeats`` runs of the mean microseconds of ``call(item)`` over ``items``: wall
    time and this thread's CPU time (on a shared machine the CPU time leaves out the waits for a core)."""
    for item in items[:3]:
        call(item)   # warm up caches and lazy imports
    wall, cpu = [], []
    with gc_paused():
        for _ in range(repeats):
            start, start_cpu = time.perf_counter(), time.thread_time()
            for item in items:
                call(item)
            wall.append((time.perf_counter() - start) / len(items) * 1e6)
            cpu.append((time.thread_time() - start_cpu) / len(items) * 1e6)
    return statistics.median(wall), statistics.median(cpu)


def bench_acceptance(recogniser: str = MULTISTROKE_RECOGNISER, n_gestures: int = 16, templates_per_gesture: int = 30,
                     queries: int = 64, repeats: int = 7, seed: int = 0) -> dict:
    """What the calibrated score costs one recognition (SYNTHETIC gestures; issue 26, the 50 ms goal).

    Median us per ``predict`` on a synthetic codebook, four ways interleaved in one run: the recogniser's own
    thresholds, the product score, the logistic score (:mod:`touch_gestures.skin.doubt`), and the logistic score
    with its context features (``context``: the second opinion, strokes, duration); the acceptance
    records are set by hand (the cost does not depend on them). A JSON-ready dict.
    """
    gestures, labels = synthetic_codebook(n_gestures, templates_per_gesture, seed)
    probe, _ = synthetic_codebook(n_gestures, max(1, -(-queries // n_gestures)), seed + 1)
    probe = probe[:queries]
    models = {}
    for rule in ('thresholds', 'product', 'logistic', 'context'):
        model = make_recogniser(recogniser).fit(gestures, labels)
        n = len(model.classes_)
        if rule != 'thresholds':
            model.set_acceptance({'class_scales': [1.0] * n, 'max_score': 1.0,
                                  **({'score_weights': [0.5, 1.0, 1.0, 0.5, 0.5]} if rule == 'logistic' else
                                     {'score_weights': [0.5, 1.0, 1.0, 0.5, 0.5, 0.5, 0.5, 0.5]} if rule == 'context'
                                     else {})})
        models[rule] = model
    times: dict[str, list[float]] = {rule: [] for rule in models}
    for _ in range(repeats):
        for rule, model in models.items():   # interleaved: the machine's load falls on all three alike
            t0 = time.perf_counter()
            for g in probe:
                model.predict(g)
            times[rule].append((time.perf_counter() - t0) / len(probe) * 1e6)
    us = {rule: float(np.median(v)) for rule, v in times.items()}
    return {'data': 'synthetic gestures (SYNTHETIC)', 'recogniser': recogniser, 'gestures': n_gestures,
            'templates_per_gesture': templates_per_gesture, 'queries': len(probe), 'repeats': repeats,
            'us_per_recognition': us, 'ratio_logistic_to_thresholds': us['logistic'] / us['thresholds'],
            'ratio_logistic_to_product': us['logistic'] / us['product'],
            'ratio_context_to_logistic': us['context'] / us['logistic']}
