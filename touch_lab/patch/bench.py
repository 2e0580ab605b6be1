"""Benchmark: cost per frame of the patch gesture recogniser (for ``social-touch bench patch``).

One frame: update the window features from a (16, 16) activation map, the log posterior of every
class, the event rule; frames of a simulated mixed scene (SYNTHETIC) through the ``patch_driver``
node. Beside it, scikit-learn's ``score_samples`` once per class per frame, and the ratio.
:func:`bench_node` times the ``patch_gestures`` node's frame callback against the bare recogniser.
"""

from __future__ import annotations

import gc
import statistics
import time

import numpy as np

from touch_gestures.patch.classifier import EventDetector
from touch_gestures.patch.features import WindowFeatures, window_features
from touch_gestures.patch.node import PatchGesturesNode
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter
from touch_lab.patch.training import PatchGestureClassifier
from touch_sim.patch.people import demo_scene, simulate_people
from touch_sim.patch.render import FRAME_RATE_HZ, render_scene

__all__ = ['GOAL_US', 'bench_frame', 'bench_node']

#: The goal: features and posterior within 50 us per frame.
GOAL_US = 50.0


def _fitted(window: int, n_components: int, seed: int, people: int = 3, events: int = 3) -> PatchGestureClassifier:
    X, y = [], []
    for i, (_person, gesture, scene) in enumerate(simulate_people(people, events, seed=seed)):
        acts = render_scene(scene, seed=i).activations
        X.append(window_features(acts, window))
        y += [gesture] * len(acts)
    return PatchGestureClassifier(n_components=n_components, random_state=seed).fit(np.concatenate(X), y)


def _median_us(fn, n: int, repeats: int) -> float:
    runs = []
    for _ in range(repeats):
        gc.collect()
        start = time.perf_counter()
        fn()
        runs.append((time.perf_counter() - start) / n * 1e6)
    return statistics.median(runs)


def bench_frame(window: int = 60, n_components: int = 5, repeats: int = 7, frames: int = 2000, seed: int = 0,
                sklearn_frames: int = 200, train_people: int = 3, train_events: int = 3) -> dict:
    """Median microseconds per frame of the recogniser, and of scikit-learn's per-call scoring.

    Args:
        window: window length in frames (paper: 60). n_components: per class (paper: 5).
        repeats: timed runs; medians are reported. frames: frames per run.
        seed: of the simulated people and scene.
        sklearn_frames: frames for the (slow) scikit-learn comparison.
        train_people, train_events: the simulated people the classifier is fitted on (not timed).

    Returns:
        dict with ``us_per_frame`` (features + posterior + event rule, on the scene's mix of
        idle and touched frames), ``us_per_frame_contact`` (the same on touched frames only), ``us_features``,
        ``us_posterior``, ``us_sklearn_score_samples`` (per frame, all classes), ``speedup``
        (sklearn / ours, posterior only), ``goal_us``, ``active_fraction``, settings, and
        ``synthetic: True``.
    """
    clf = _fitted(window, n_components, seed, train_people, train_events)
    scene = demo_scene(seed=seed + 1, n_events=max(4, frames // 160))
    acts = render_scene(scene, seed=seed + 1).activations
    acts = np.resize(acts, (frames, *acts.shape[1:])) if len(acts) < frames else acts[:frames]
    classes = tuple(str(c) for c in clf.classes_)
    feats = window_features(acts, window)

    def full() -> None:
        wf, det = WindowFeatures(window), EventDetector(classes, threshold=clf.threshold, rate_hz=FRAME_RATE_HZ)
        for frame in acts:
            x = wf.update(frame)
            det.update(clf.log_posterior(x), wf.onset_age)

    def features_only() -> None:
        wf = WindowFeatures(window)
        for frame in acts:
            wf.update(frame)

    def posterior_only() -> None:
        for x in feats:
            clf.log_posterior(x)

    params = clf.params_
    z = (feats[:sklearn_frames] - params.feature_mean) / params.feature_scale

    def sklearn_scoring() -> None:
        for row in z:
            row = row[None]
            for gm in clf.mixtures_:
                gm.score_samples(row)

    active_mask = (acts.reshape(len(acts), -1) > 0.08 + 1e-6).any(axis=1)
    busy = np.resize(acts[active_mask], acts.shape) if active_mask.any() else acts

    def full_busy() -> None:  # every frame with contact: the worst case
        wf, det = WindowFeatures(window), EventDetector(classes, threshold=clf.threshold, rate_hz=FRAME_RATE_HZ)
        for frame in busy:
            x = wf.update(frame)
            det.update(clf.log_posterior(x), wf.onset_age)

    full()  # warm up
    us = _median_us(full, len(acts), repeats)
    us_busy = _median_us(full_busy, len(busy), repeats)
    us_features = _median_us(features_only, len(acts), repeats)
    us_posterior = _median_us(posterior_only, len(feats), repeats)
    us_sklearn = _median_us(sklearn_scoring, len(z), max(1, repeats // 2))
    return {
        'us_per_frame': us, 'us_per_frame_contact': us_busy, 'us_features': us_features, 'us_posterior': us_posterior,
        'us_sklearn_score_samples': us_sklearn, 'speedup': us_sklearn / us_posterior,
        'goal_us': GOAL_US, 'meets_goal': us <= GOAL_US, 'frames': len(acts),
        'active_fraction': float(active_mask.mean()),
        'window': window, 'n_components': n_components, 'classes': list(classes), 'repeats': repeats,
        'synthetic': True,
    }


def bench_node(repeats: int = 7, frames: int = 2000, seed: int = 0, model: str | None = None) -> dict:
    """Median microseconds per frame of the ``patch_gestures`` node's callback and of the bare recogniser.

    Frames come from the simulated demo scene (SYNTHETIC) through the patch_driver node, as
    ``PatchFrame`` messages with 20 Hz stamps; the node runs in a simulated-time context with
    no executor (its callback is called directly; the publisher has a subscriber, so events are
    delivered). ``model`` defaults to the package's ``config/patch_gestures.npz``.

    Returns:
        dict with ``us_node`` (callback per frame), ``us_recogniser`` (features + direct posterior +
        event rule on the same frames), ``node_overhead`` (ratio), ``events``, ``frames`` and ``synthetic``.
    """
    patch_frame, header_type = get_message('social_touch_msgs/msg/PatchFrame'), get_message('std_msgs/msg/Header')
    time_type = get_message('builtin_interfaces/msg/Time')
    acts = render_scene(demo_scene(seed=seed + 1, n_events=max(4, frames // 160)), seed=seed + 1).activations
    acts = np.resize(acts, (frames, *acts.shape[1:])) if len(acts) < frames else acts[:frames]
    msgs = [patch_frame(header=header_type(stamp=time_type(sec=1_700_000_000 + i // 20, nanosec=(i % 20) * 50_000_000)),
                        sequence=i & 0xFFFF, activation=a.reshape(-1)) for i, a in enumerate(acts)]
    context = Context('sim')
    context.init()
    try:
        overrides = [Parameter('model', value=model)] if model else []
        node = PatchGesturesNode(context=context, parameter_overrides=overrides,
                                 cli_args=['--ros-args', '--log-level', 'error'])  # each run restarts: quiet
        sink = Node('bench_sink', context=context)
        received: list = []
        sink.create_subscription(get_message('social_touch_msgs/msg/GestureEvent'), '/touch/gesture',
                                 received.append, 10)
        m = node.model

        def through_node() -> None:
            node._last_ns = None
            node._restart('bench run')
            for msg in msgs:
                node._on_frame(msg)

        def recogniser() -> None:
            wf, det, clf = m.features(), node.detector, m.classifier
            det.reset()
            for a in acts:
                det.update(clf.log_posterior(wf.update(a)), wf.onset_age)

        through_node()  # warm up
        us_node = _median_us(through_node, len(msgs), repeats)
        us_recogniser = _median_us(recogniser, len(acts), repeats)
        events = node.events // (repeats + 1)
    finally:
        context.shutdown()
    return {'us_node': us_node, 'us_recogniser': us_recogniser, 'node_overhead': us_node / us_recogniser,
            'events': events, 'frames': len(msgs), 'repeats': repeats, 'synthetic': True}
