"""Benchmark of the bear recognisers: compute per scan cycle for all 56 sensors with every feature.

``bench_cycle()`` feeds calibrated levels of a synthetic scene through a fresh
:class:`~.pipeline.BearRecogniser` per repeat: the mean time of one ``update`` per repeat, the median
over repeats (``social-touch bench bear --json``). Goal (issue 4): at most 200 us per cycle on one core.
"""

from __future__ import annotations

import time

import numpy as np

from touch_driver.bear.protocol import REAL_RATE_HZ
from touch_gestures.bear.pipeline import BearRecogniser
from touch_lab.bear.evaluate import collect_training_rows, run_scene
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_sim.bear.people import make_scene
from touch_sim.bear.render import BearCycles

__all__ = ['GOAL_US_PER_CYCLE', 'bench_cycle']

#: Compute budget per cycle for all 56 sensors (issue 4).
GOAL_US_PER_CYCLE = 200.0


def _levels(rate_hz: float, cycles: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    scene = make_scene(n_people=1, seed=seed, subtype_reps=1, gesture_reps=1)
    source = BearCycles(scene, rate_hz, seed=seed, device_options={'scan': 'parallel'})
    rows = [(c.t, c.levels) for c in source.cycles(min(scene.duration_s, cycles / rate_hz))]
    return np.array([t for t, _ in rows]), np.array([lv for _, lv in rows], dtype=np.float32)


def _small_model(rate_hz: float, buffer_len: int, seed: int) -> SubtypeClassifier:
    """A model trained on a short synthetic scene: its weights do not change the cost, only its shape."""
    scene = make_scene(n_people=1, seed=seed + 7, subtype_reps=1, gesture_reps=0)
    rec = BearRecogniser(rate_hz, buffer_len, named_outputs=False)
    run = run_scene(scene, BearCycles(scene, rate_hz, seed=seed, device_options={'scan': 'parallel'}), {'f': rec},
                    keep_features=True)
    X, y = collect_training_rows(run, rec.fitted, seed=seed)
    return SubtypeClassifier(max_iter=300).fit(X, y)


def bench_cycle(buffer_len: int = 20, rate_hz: float = REAL_RATE_HZ, repeats: int = 7, cycles: int = 400,
                seed: int = 0, model: SubtypeClassifier | None = None) -> dict:
    """Median microseconds per recogniser cycle for all 56 sensors, features + subtype + symbolic.

    Args:
        buffer_len: cycles per sensor buffer.
        rate_hz: scan rate (only changes the scene sampling and frequency grid).
        repeats: timed repeats (a fresh recogniser each); the median is reported.
        cycles: cycles per repeat.
        seed: scene seed.
        model: the trained subtype model to time (default: one trained on a short synthetic scene).

    Returns:
        dict with ``us_per_cycle`` (trained model), ``us_per_cycle_rule`` (paper rule),
        ``us_features`` (ring buffer + features alone), the spread over repeats, and the settings.
    """
    if repeats < 1 or cycles < 1:
        raise ValueError(f'repeats and cycles must be >= 1; got {repeats}, {cycles}')
    times, levels = _levels(rate_hz, cycles, seed)
    model = model if model is not None else _small_model(rate_hz, buffer_len, seed)
    clock = time.perf_counter_ns

    def one_run(classifier) -> float:
        rec = BearRecogniser(rate_hz, buffer_len, classifier=classifier)
        t0 = clock()
        for t, row in zip(times, levels, strict=True):
            rec.update(float(t), row)
        return (clock() - t0) / 1e3 / len(times)

    def features_only() -> float:
        rec = BearRecogniser(rate_hz, buffer_len)
        t0 = clock()
        for row in levels:
            rec.buffer.update(row)
            rec.extractor.update(rec.buffer.window())
        return (clock() - t0) / 1e3 / len(times)

    one_run(model)   # warm caches and lazy imports
    with_model = [one_run(model) for _ in range(repeats)]
    with_rule = [one_run(None) for _ in range(repeats)]
    feats = [features_only() for _ in range(repeats)]
    us = float(np.median(with_model))
    return {
        'us_per_cycle': us,
        'us_per_cycle_rule': float(np.median(with_rule)),
        'us_features': float(np.median(feats)),
        'us_per_cycle_min_max': [float(np.min(with_model)), float(np.max(with_model))],
        'sensors': 56,
        'features': 12,
        'buffer_len': buffer_len,
        'rate_hz': rate_hz,
        'cycles': len(times),
        'repeats': repeats,
        'goal_us': GOAL_US_PER_CYCLE,
        'within_goal': us <= GOAL_US_PER_CYCLE,
        'data': 'synthetic scene levels',
    }
