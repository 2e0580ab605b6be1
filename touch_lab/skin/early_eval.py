"""How early the answer is right: the early-decision figures of ``social-touch eval skin --early``.

Per person left out, a :class:`~touch_gestures.skin.early.PrefixMatcher` fitted on the others follows each
held-out gesture as it is traced (the candidate after 10 %, 20 %, ... of its points). Reported: the
**stable fraction** (of the gesture traced from which the candidate is right to the end: median, 75th
and 90th percentile over gestures finally right), **right by half** and **final right** (shares of all
gestures). Only samples cut into one gesture count; ``every`` keeps one sample in so many.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from touch_gestures.skin.base import TemplateRecogniser
from touch_gestures.skin.early import PrefixMatcher, stable_fraction
from touch_gestures.skin.gesture import TouchGesture
from touch_sim.skin.render import RenderedSample

from .evaluate import choose_codebook

__all__ = ['STEPS', 'early_decisions', 'prefix', 'summary']

#: The fractions of a gesture at which the candidate is taken.
STEPS = tuple(np.round(np.arange(1, 11) / 10, 2))


def prefix(gesture: TouchGesture, fraction: float) -> TouchGesture:
    """The gesture as it was when ``fraction`` of its trajectory points had been traced (at least one)."""
    k = max(1, round(len(gesture.trajectory) * fraction))
    return TouchGesture(binary_map=gesture.binary_map, peak_map=gesture.peak_map, trajectory=gesture.trajectory[:k],
                        times=gesture.times[:k], stroke=gesture.stroke[:k], frames=k, start_s=gesture.start_s,
                        duration_s=float(gesture.times[k - 1] - gesture.times[0]),
                        strokes=int(gesture.stroke[k - 1]) + 1)


def early_decisions(rendered: Sequence[RenderedSample], make: Callable[[], TemplateRecogniser],
                    templates_per_gesture: int | None = None, seed: int = 0, every: int = 4,
                    progress: Callable[[str], None] | None = None) -> dict:
    """The early-decision figures (module doc) for the recogniser ``make`` builds."""
    subjects = sorted({r.subject for r in rendered})
    if len(subjects) < 2:
        raise ValueError(f'leave-one-subject-out needs at least 2 subjects; got {subjects}')
    if every < 1:
        raise ValueError(f'every must be >= 1, got {every}')
    stable: list[float | None] = []
    for fold, subject in enumerate(subjects):
        train = choose_codebook([r for r in rendered if r.subject != subject], templates_per_gesture,
                                np.random.default_rng([seed, fold]))
        recogniser = make().fit([r.gestures[0] for r in train], [r.label for r in train])
        matcher = PrefixMatcher(recogniser)
        test = [r for r in rendered if r.subject == subject and len(r.gestures) == 1][::every]
        for r in test:
            g = r.gestures[0]
            if len(g.trajectory) == 0:
                stable.append(None)
                continue
            labels = [matcher.candidate(prefix(g, f)).label for f in STEPS[:-1]]
            labels.append(recogniser.predict(g).nearest)
            stable.append(stable_fraction(labels, r.label))
        if progress is not None:
            progress(f'early decisions: fold {fold + 1}/{len(subjects)} (subject {subject}), {len(test)} gestures')
    right = np.array([s for s in stable if s is not None], dtype=np.float64)
    n = len(stable)
    return {
        'gestures': n, 'steps': list(STEPS),
        'final_right': len(right) / n if n else float('nan'),
        'right_by_half': float(np.sum(right <= 0.5)) / n if n else float('nan'),
        'stable_fraction': ({f'p{q}': float(np.percentile(right, q)) for q in (50, 75, 90)} if len(right) else {}),
    }


def summary(early: dict) -> str:
    """One sentence of the figures of :func:`early_decisions`, for the text and Markdown reports."""
    st = early['stable_fraction']
    text = (f"{early['gestures']} gestures: final answer right {100 * early['final_right']:.2f} %; right and stable "
            f"once half the gesture is traced: {100 * early['right_by_half']:.2f} %")
    if st:
        text += (f"; fraction traced when the candidate became right for good: median {st['p50']:.2f}, 75th "
                 f"percentile {st['p75']:.2f}, 90th {st['p90']:.2f}")
    return text + '.'
