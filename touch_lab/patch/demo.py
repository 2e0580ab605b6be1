"""Play the patch demo scene through the sensor chain and the recogniser, printing events as they happen.

The recogniser without the graph, frame by frame (SYNTHETIC data); the same on the node graph
is ``social-touch launch launch/patch.launch.yaml --sim-time --rate 10 --duration 60``::

    python -m touch_lab.patch.demo [--model FILE.npz] [--seed N] [--events N]

Without ``--model`` a model is trained first on simulated people (other seeds than the
scene's). Each line is what the robot would publish at that moment: a gesture event
(/touch/gesture) or a change of panel contact (/patch/panels any_contact), next to the
scene's ground truth.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np

from touch_gestures.patch.classifier import PatchGestureClassifier
from touch_gestures.patch.features import window_features
from touch_gestures.patch.model_io import PatchModel, load_model
from touch_gestures.patch.sensor_chain import FRAME_RATE_HZ, render_scene
from touch_sim.patch.people import PatchScene, demo_scene, simulate_people

__all__ = ['DemoLine', 'main', 'play', 'train_simulated']


@dataclass(frozen=True)
class DemoLine:
    """One thing the robot reports: ``kind`` is 'gesture', 'handled' or 'released'; time in scene seconds."""

    time_s: float
    kind: str
    text: str


def train_simulated(people: int = 6, events: int = 4, seed: int = 100, chain: str = 'auto',
                    n_components: int = 3, hold: int = 8) -> PatchModel:
    """A model trained on simulated people (SYNTHETIC), for demos and tests."""
    X, y = [], []
    for i, (_p, gesture, scene) in enumerate(simulate_people(people, events, seed=seed)):
        acts = render_scene(scene, seed=seed + i, chain=chain).activations
        X.append(window_features(acts, 60))
        y += [gesture] * len(acts)
    clf = PatchGestureClassifier(n_components=n_components, random_state=seed).fit(np.concatenate(X), y)
    return PatchModel(clf, window=60, rate_hz=FRAME_RATE_HZ, hold=hold)


def play(model: PatchModel, scene: PatchScene, seed: int = 0, chain: str = 'auto') -> Iterator[DemoLine]:
    """Frame by frame, as the nodes will run: yield gesture events and panel contact changes."""
    out = render_scene(scene, seed=seed, chain=chain)
    features, detector = model.features(), model.detector()
    handled = False
    for frame, (activation, panels) in enumerate(zip(out.activations, out.panel_contact, strict=True)):
        t = frame / model.rate_hz
        if bool(panels.any()) != handled:
            handled = not handled
            which = ', '.join(str(int(p)) for p in np.flatnonzero(panels))
            yield DemoLine(t, 'handled' if handled else 'released',
                           f'panels {which}: someone is handling the robot' if handled else 'panels free')
        hit = detector.update(model.classifier.log_posterior(features.update(activation)), features.onset_age)
        if hit is not None:
            yield DemoLine(t, 'gesture', f'{hit.gesture} (p={hit.probability:.3f}, {hit.latency_s:.2f} s after onset)')


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--model', help='model file (.npz); default: train one on simulated people first')
    parser.add_argument('--seed', type=int, default=7, help='seed of the demo scene')
    parser.add_argument('--events', type=int, default=10, help='gestures in the scene')
    parser.add_argument('--chain', choices=('auto', 'driver', 'simple'), default='auto')
    args = parser.parse_args(argv)
    if args.model:
        model = load_model(args.model)
    else:
        print('training on simulated people (SYNTHETIC) ...', file=sys.stderr, flush=True)
        model = train_simulated(chain=args.chain)
    scene = demo_scene(seed=args.seed, n_events=args.events)
    print('SYNTHETIC demo scene; truth: ' + ', '.join(f'{e.gesture}@{e.onset_s:.1f}s' for e in scene.events))
    for line in play(model, scene, seed=args.seed, chain=args.chain):
        truth = [e.gesture for e in scene.events if e.onset_s - 0.25 <= line.time_s <= e.offset_s + 3.0]
        note = f'   [truth: {truth[0]}]' if line.kind == 'gesture' and truth else ''
        print(f'{line.time_s:7.2f} s  {line.kind:<8} {line.text}{note}')
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
