"""Benchmark: what the calibrated score costs one recognition (SYNTHETIC gestures; issue 26, the 50 ms goal).

One ``predict`` on a synthetic codebook (:func:`.bench.synthetic_codebook`), three ways interleaved in
one run, medians of ``repeats``: the recogniser's own thresholds, the product score, the logistic score
(:mod:`touch_gestures.skin.doubt`); the acceptance records are set by hand (the cost does not depend on them).
"""

from __future__ import annotations

import time

import numpy as np

from .bench import synthetic_codebook
from .recognisers import MULTISTROKE_RECOGNISER, make_recogniser

__all__ = ['bench_acceptance']


def bench_acceptance(recogniser: str = MULTISTROKE_RECOGNISER, n_gestures: int = 16, templates_per_gesture: int = 30,
                     queries: int = 64, repeats: int = 7, seed: int = 0) -> dict:
    """Median us per ``predict`` with each rule (module doc); a JSON-ready dict."""
    gestures, labels = synthetic_codebook(n_gestures, templates_per_gesture, seed)
    probe, _ = synthetic_codebook(n_gestures, max(1, -(-queries // n_gestures)), seed + 1)
    probe = probe[:queries]
    models = {}
    for rule in ('thresholds', 'product', 'logistic'):
        model = make_recogniser(recogniser).fit(gestures, labels)
        n = len(model.classes_)
        if rule != 'thresholds':
            model.set_acceptance({'class_scales': [1.0] * n, 'max_score': 1.0,
                                  **({'score_weights': [0.5, 1.0, 1.0, 0.5, 0.5]} if rule == 'logistic' else {})})
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
            'ratio_logistic_to_product': us['logistic'] / us['product']}
