"""Simulated people at the optoelectronic skin: traced gestures and touches that are none (SYNTHETIC).

A :class:`SkinScene` is a sequence of touches that do not overlap in time, each a skin stimulus
(``contacts(t)``) with its ground truth as a :class:`SceneEvent`; it implements
``touch_sim.skin.contact.SkinStimulus``, so ``skinsim://`` plays it. Touches (``SceneEvent.kind``):

- ``'gesture'``: a codebook gesture traced by a simulated performer (:func:`~.synthetic.synthetic_traces`);
- ``'random'``: a scribble, a zigzag or a dab (:func:`~.synthetic.random_touches`);
- ``'press'``: a finger pressing still for 0.5-2 s;
- ``'two_fingers'``: two fingertips about 20 mm apart stroking side by side;
- ``'resting_hand'``: a press that outlasts the segmenter's limit.

Only ``'gesture'`` touches should fire a command; :func:`people_scene` draws a session from a seed.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from touch_gestures.skin.gesture import ACTIVE_MM
from touch_sim.skin.stimuli import LineStroke, StaticPress, Timeline
from touch_sim.skin.synthetic import SHAPES, random_touches, synthetic_traces
from touch_sim.skin.traces import TraceSample, TraceStimulus, clock_tick, traced_strokes

__all__ = ['KINDS', 'SceneEvent', 'SkinScene', 'people_scene', 'traced_scene']

#: Kinds of touch in a scene (module doc).
KINDS = ('gesture', 'random', 'press', 'two_fingers', 'resting_hand')
_RAMP_S = 0.05        # touch-down and lift ramps of every touch, s (as TraceStimulus's default)
_FORCE_N = 1.5        # tracing force, N (TraceStimulus's default)


@dataclass(frozen=True)
class SceneEvent:
    """Ground truth of one touch.

    Attributes:
        kind: one of :data:`KINDS`.
        label: the gesture name for ``'gesture'``; what the touch is otherwise (``'scribble'``...).
        person: who touches (``'p1'``...), or the synthetic performer of a recorded trace.
        start_s: full force reached (the touch-down ramp of 50 ms comes before), s.
        end_s: the lift begins (50 ms ramp after), s.
    """

    kind: str
    label: str
    person: str
    start_s: float
    end_s: float


class SkinScene:
    """Touches one after the other (see the module doc). Build with :func:`people_scene` or
    :func:`traced_scene`, or from ``(stimulus, event)`` pairs.

    Args:
        parts: ``(stimulus, event)`` pairs; the stimulus gives the contacts of the event in
            scene time and none outside ``[start_s - 0.05, end_s + 0.05]``.
        duration_s: length of the scene, s (default: the last lift + 1 s).

    Raises:
        ValueError: touches that overlap in time, an unknown kind, or a stimulus without ``contacts``.
    """

    synthetic = True

    def __init__(self, parts: Sequence[tuple[Any, SceneEvent]], duration_s: float | None = None) -> None:
        parts = sorted(parts, key=lambda p: p[1].start_s)
        for i, (stim, event) in enumerate(parts):
            if not callable(getattr(stim, 'contacts', None)):
                raise ValueError(f'part {i} needs a contacts(t) method; got {type(stim).__name__}')
            if event.kind not in KINDS:
                raise ValueError(f'event kind must be one of {", ".join(KINDS)}; got {event.kind!r}')
            if not event.end_s >= event.start_s >= _RAMP_S:
                raise ValueError(f'event {event} must have {_RAMP_S} <= start_s <= end_s')
            if i and event.start_s - _RAMP_S < parts[i - 1][1].end_s + _RAMP_S:
                raise ValueError(f'touches overlap: {parts[i - 1][1]} and {event}; leave a gap between them')
        self._stimuli = [p[0] for p in parts]
        self.events: tuple[SceneEvent, ...] = tuple(p[1] for p in parts)
        self._ons = [e.start_s - _RAMP_S for e in self.events]
        last = self.events[-1].end_s + _RAMP_S if self.events else 0.0
        self.duration_s = float(duration_s) if duration_s is not None else last + 1.0

    def contacts(self, t: float) -> list:
        """The contacts at ``t`` s: those of the touch under way, if any."""
        i = bisect.bisect_right(self._ons, t) - 1
        if i < 0 or t > self.events[i].end_s + _RAMP_S:
            return []
        return self._stimuli[i].contacts(t)

    def gestures(self) -> list[SceneEvent]:
        """The events that are traced gestures (the ones that should fire a command)."""
        return [e for e in self.events if e.kind == 'gesture']

    def __repr__(self) -> str:
        kinds = {k: sum(e.kind == k for e in self.events) for k in KINDS}
        return (f'SkinScene({len(self.events)} touches: ' + ', '.join(f'{n} {k}' for k, n in kinds.items() if n)
                + f'; {self.duration_s:.1f} s, synthetic)')


# ----------------------------------------------------------------------------- touches
def _trace_part(sample: TraceSample, at_s: float, kind: str, person: str, force_n: float = _FORCE_N
                ) -> tuple[Any, SceneEvent]:
    """A trace sample in mm (x, y on the skin, t_ms) traced from ``at_s``, strokes as in the sample."""

    t = at_s + (sample.t_ms - float(sample.t_ms.min())) / 1000.0
    strokes = traced_strokes(t, sample.x, sample.y, sample.stroke,
                             clock_tick(sample.t_ms, sample.stroke) / 1000.0)  # strictly increasing times
    stim = TraceStimulus(strokes, force_n=force_n, ramp_s=_RAMP_S, tail_s=0.0)
    label = sample.gesture if kind == 'gesture' else _RANDOM_NAMES[int(sample.sample) % 3]
    return stim, SceneEvent(kind, label, person, at_s, float(strokes[-1][-1, 0]))


_RANDOM_NAMES = ('scribble', 'zigzag', 'dab')   # random_touches draws these in turn


def _press_part(rng: np.random.Generator, at_s: float, for_s: float, kind: str = 'press'
                ) -> tuple[Any, SceneEvent]:

    x, y = rng.uniform(8.0, ACTIVE_MM - 8.0, 2)
    press = StaticPress(float(x), float(y), float(rng.uniform(0.8, 3.0)), at_s=at_s, for_s=for_s, ramp_s=_RAMP_S)
    return press, SceneEvent(kind, 'resting hand' if kind == 'resting_hand' else 'press', 'someone', at_s,
                             at_s + for_s)


def _two_finger_part(rng: np.random.Generator, at_s: float) -> tuple[Any, SceneEvent]:
    """Two fingertips 20 mm apart stroking 25 mm side by side (a line traced with two fingers)."""

    for_s = float(rng.uniform(0.5, 1.2))
    start = float(rng.uniform(6.0, ACTIVE_MM - 31.0))   # along the stroke, mm
    if rng.integers(2):   # side by side across the rows (at y = 13 and 33 mm), or across the columns
        ends = [((start, y), (start + 25.0, y)) for y in (13.0, 33.0)]
    else:
        ends = [((x, start), (x, start + 25.0)) for x in (13.0, 33.0)]
    fingers = Timeline([LineStroke(a, b, _FORCE_N, at_s=at_s, for_s=for_s, ramp_s=_RAMP_S) for a, b in ends])
    return fingers, SceneEvent('two_fingers', 'two fingers', 'someone', at_s, at_s + for_s)


def _check_range(name: str, pair: Sequence[float]) -> tuple[float, float]:
    lo, hi = (float(v) for v in pair)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
        raise ValueError(f'{name} must be (min, max) seconds with 0 <= min <= max; got {tuple(pair)}')
    return lo, hi


def _lay_out(makers: Sequence[Any], lead_s: float, pause_s: tuple[float, float], rng: np.random.Generator,
             tail_s: float) -> SkinScene:
    """Call each ``maker(at_s)`` in turn, one touch after the other with a pause drawn from ``pause_s``."""
    if not (math.isfinite(lead_s) and lead_s >= 0.5):
        raise ValueError(f'lead_s must be >= 0.5 s (the driver tares on untouched skin first); got {lead_s}')
    parts, at = [], lead_s
    for make in makers:
        stim, event = make(at)
        parts.append((stim, event))
        at = event.end_s + 2 * _RAMP_S + float(rng.uniform(*pause_s))
    end = parts[-1][1].end_s + _RAMP_S if parts else lead_s
    return SkinScene(parts, duration_s=end + tail_s)


def traced_scene(samples: Sequence[TraceSample], lead_s: float = 1.0, pause_s: tuple[float, float] = (0.6, 0.6),
                 seed: int = 0, tail_s: float = 1.0) -> SkinScene:
    """The trace samples (x, y in mm on the skin, as :func:`~.synthetic.synthetic_traces` gives them)
    traced one after the other, each a ``'gesture'`` event labelled with its sample's gesture and
    performer; for a simulated codebook recording.

    >>> from touch_sim.skin.synthetic import synthetic_traces
    >>> scene = traced_scene(synthetic_traces(['line_right', 'one'], performers=1, repetitions=2))
    >>> [e.label for e in scene.events], scene.events[0].person
    (['line_right', 'line_right', 'one', 'one'], 'synthetic0')
    """
    pause = _check_range('pause_s', pause_s)
    makers = [lambda at, s=s: _trace_part(s, at, 'gesture', s.subject) for s in samples]
    return _lay_out(makers, lead_s, pause, np.random.default_rng(seed), tail_s)


def people_scene(n_people: int = 2, seed: int = 0, gestures: Sequence[str] = ('line_right', 'line_left'),
                 per_person: int = 4, random_touches_n: int = 1, presses: int = 1, two_fingers: int = 1,
                 resting_hand_s: float = 0.0, pause_s: tuple[float, float] = (1.5, 2.5), lead_s: float = 2.0
                 ) -> SkinScene:
    """People taking turns at the skin (SYNTHETIC): each traces ``per_person`` gestures drawn from
    ``gestures``, and now and then someone touches it without meaning a gesture.

    Args:
        n_people: simulated performers (:func:`~.synthetic.synthetic_traces` with ``seed``: people
            other than those of a codebook recorded with another seed).
        seed: everything is drawn from it.
        gestures: shape names (:data:`~.synthetic.SHAPES`); each person draws ``per_person`` of
            them, all different when there are enough.
        random_touches_n: scribbles, zigzags and dabs (in turn) that are no gesture.
        presses: fingers pressing still for 0.5-2 s.
        two_fingers: lines stroked with two fingers side by side.
        resting_hand_s: if > 0, a hand rests this long on the skin (longer than the skin node's
            ``max_duration_s`` to test its limit), then the session goes on.
        pause_s: (min, max) seconds between one lift and the next touch-down.
        lead_s: untouched seconds first (the driver tares its calibration on them).

    Returns: the scene; its ``events`` give who did what when. The touches that are no gesture
    are spread among the people's gestures.
    """
    unknown = [g for g in gestures if g not in SHAPES]
    if unknown or not gestures:
        raise ValueError(f'gestures must be some of {", ".join(SHAPES)}; got {list(gestures)}')
    counts = {'n_people': n_people, 'per_person': per_person, 'random_touches_n': random_touches_n,
              'presses': presses, 'two_fingers': two_fingers}
    bad = {k: v for k, v in counts.items() if not isinstance(v, int) or v < 0}
    if bad or n_people < 1:
        raise ValueError(f'n_people must be >= 1 and the counts integers >= 0; got {bad or counts}')
    if not (math.isfinite(resting_hand_s) and resting_hand_s >= 0):
        raise ValueError(f'resting_hand_s must be >= 0 s, got {resting_hand_s}')
    pause = _check_range('pause_s', pause_s)
    rng = np.random.default_rng(seed)
    traces = synthetic_traces(list(dict.fromkeys(gestures)), performers=n_people,
                              repetitions=max(1, -(-per_person // len(set(gestures)))), seed=seed)
    makers: list[Any] = []
    for p in range(n_people):
        own = [s for s in traces if s.subject == f'synthetic{p}']
        # Different gestures first, repetitions only when per_person exceeds the gesture set.
        order = sorted(range(len(own)), key=lambda i: (int(own[i].sample), rng.random()))[:per_person]
        makers += [lambda at, s=own[i], p=p: _trace_part(s, at, 'gesture', f'p{p + 1}') for i in order]
    others: list[Any] = []
    if random_touches_n:
        others += [lambda at, s=s: _trace_part(s, at, 'random', 'someone')
                   for s in random_touches(random_touches_n, seed=seed + 1)]
    others += [lambda at: _press_part(rng, at, float(rng.uniform(0.5, 2.0)))] * presses
    others += [lambda at: _two_finger_part(rng, at)] * two_fingers
    for make in others:  # spread among the gestures, never first (the first touch is someone's gesture)
        makers.insert(int(rng.integers(1, len(makers) + 1)) if makers else 0, make)
    if resting_hand_s > 0:
        makers.insert(len(makers) // 2, lambda at: _press_part(rng, at, resting_hand_s, 'resting_hand'))
    return _lay_out(makers, lead_s, pause, rng, tail_s=1.0)
