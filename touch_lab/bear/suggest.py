"""Suggested locational-filter settings (``min_active``, ``dwell_s``) of the bear's symbolic gestures, learnt
from labelled trials (``social-touch collect bear --symbolic``, labels ``symbolic/<gesture>``).

Per gesture ``g`` and trial of ``g``, counted as :class:`~touch_gestures.bear.symbolic.SymbolicRecogniser`
counts: *count* (the filter's active sensors in a cycle), *match m* (count >= m), *peak* (the largest
count). ``min_active`` = the :data:`QUANTILE` quantile of the peaks (>= 1), raised while that loses
fewer of ``g``'s trials than it stops matching other gestures' trials. For that ``m``, of the trial's
longest episode (matches with no lift longer than ``lift_s`` between them): *reach* (start of the trial
to the episode's first match, s) and *hold* (its first to last match, s); ``dwell_s`` = min(QUANTILE quantile
of the holds, :data:`REACTION_S` - (1 - QUANTILE) quantile of the reaches), >= 0, rounded down to
:data:`DWELL_STEP_S`. Other settings stay as configured.

:func:`leave_one_person_out` checks the suggestion on people it was not made from, through the real
recogniser, against the configured settings.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_labels import SUBTYPES
from touch_gestures.bear.symbolic import DEFAULT_DWELL_S, START, GestureFilter, GestureLibrary, SymbolicRecogniser
from touch_graph.yamlconf import did_you_mean

from .false_starts import runs_gesture_starts
from .sessions import BearTrials

__all__ = ['DWELL_STEP_S', 'QUANTILE', 'REACTION_S', 'GestureStats', 'Suggestion', 'gesture_stats',
           'leave_one_person_out', 'suggest', 'suggested_library']

#: Low quantile of the trials' peaks and holds (and 1 - it of the reaches): settings most trials meet.
QUANTILE = 0.1
#: The START must come within this many seconds of the gesture's start for most trials: the paper's
#: dwell, "chosen to parallel human recognition time" (knight2009 V.E).
REACTION_S = DEFAULT_DWELL_S
#: Suggested dwells are rounded down to this step, s (a config a person reads and edits).
DWELL_STEP_S = 0.05
#: Fewest trials of a gesture to suggest its settings from.
MIN_TRIALS = 2


@dataclass
class GestureStats:
    """What one gesture's labelled trials showed.

    Attributes:
        name: the gesture.
        people: per trial, the person.
        peaks: (trials,) int, largest count of active filter sensors in each trial.
        counts: per trial, (cycles,) int counts; ``times`` per trial, (cycles,) s from the trial's start.
        sides: per trial, (cycles,) bool, both sides active (True throughout when the gesture does not ask).
        active_sensors: sensor name -> trials in which it was active (inside the filter or not).
        other_peaks: per trial of *another* gesture, the largest count of this gesture's filter in it.
    """

    name: str
    people: list[str] = field(default_factory=list)
    peaks: list[int] = field(default_factory=list)
    counts: list[np.ndarray] = field(default_factory=list)
    times: list[np.ndarray] = field(default_factory=list)
    sides: list[np.ndarray] = field(default_factory=list)
    active_sensors: dict[str, int] = field(default_factory=dict)
    other_peaks: list[int] = field(default_factory=list)

    def reach_hold(self, m: int, lift_s: float) -> tuple[np.ndarray, np.ndarray]:
        """(trials,) reach and hold seconds at ``min_active = m`` (NaN: the trial never matched) of each trial's
        longest episode: a lift longer than ``lift_s`` s ends an episode, as it restarts the recogniser's
        dwell, and the gesture STARTs in the longest if in any."""
        reach, hold = np.full(len(self.counts), np.nan), np.full(len(self.counts), np.nan)
        for i, (count, t, sides) in enumerate(zip(self.counts, self.times, self.sides, strict=True)):
            hits = np.flatnonzero((count >= m) & sides)
            if not hits.size:
                continue
            matched = t[hits]
            # The recogniser restarts at a cycle without a match more than lift_s after the last match: between
            # two matches, the latest cycle before the second (1e-9: float time steps, as the recogniser).
            breaks = np.flatnonzero((np.diff(hits) > 1) & (t[hits[1:] - 1] - matched[:-1] > lift_s + 1e-9))
            firsts = matched[np.concatenate([[0], breaks + 1])]
            lasts = matched[np.concatenate([breaks, [len(matched) - 1]])]
            longest = int(np.argmax(lasts - firsts))
            reach[i], hold[i] = firsts[longest], lasts[longest] - firsts[longest]
        return reach, hold


@dataclass(frozen=True)
class Suggestion:
    """Suggested settings of one gesture, and what they rest on.

    Attributes:
        name: the gesture.
        min_active, dwell_s: the suggestion (None: too little data; the configured values stay).
        trials, people: how many trials and people it comes from.
        reason: why there is no suggestion (empty when there is one).
    """

    name: str
    min_active: int | None
    dwell_s: float | None
    trials: int
    people: int
    reason: str = ''


def trial_codes(run: BearTrials, predictor) -> np.ndarray | None:
    """(n, 64) int8 subtype codes of ``run`` by ``predictor`` (``predict_codes``; None gives None)."""
    if predictor is None:
        return None
    rows = run.features.reshape(-1, run.features.shape[-1])
    codes = predictor.predict_codes(rows)[0].reshape(run.features.shape[:2]).astype(np.int8)
    codes[:, ~run.fitted] = 0
    return codes


def gesture_stats(runs: list[BearTrials], codes: list[np.ndarray | None], library: GestureLibrary,
                  body_map: BodyMap, warn: Callable[[str], None]) -> dict[str, GestureStats]:
    """Per detectable gesture of ``library``, the statistics of its trials in ``runs`` (module doc).

    ``codes[i]`` are ``runs[i]``'s subtype codes (None: gestures that need a subtype never count).
    Labels of gestures not in the library (or not detectable) are warned about, naming the bag and time.
    """
    names = {s.channel: s.name for s in body_map.sensors}
    left_mask, right_mask = np.zeros(64, dtype=bool), np.zeros(64, dtype=bool)
    for s in body_map.sensors:
        left_mask[s.channel], right_mask[s.channel] = s.side == 'left', s.side == 'right'
    known = {g.name: g for g in library.detectable}
    stats = {name: GestureStats(name) for name in known}
    for run, run_codes in zip(runs, codes, strict=True):
        period = 1.0 / run.session.rate_hz('/bear/frame')
        for lab in run.gestures:
            name = lab.gesture.split('/', 1)[1]
            g = known.get(name)
            if g is None:
                warn(f'{run.session.path} at {lab.start_s:.2f} s: gesture {name!r} is not a detectable gesture of '
                     f'{library.source}{did_you_mean(name, known)}; left out')
                continue
            inside = (run.times >= lab.start_s) & (run.times <= lab.end_s + period)
            active = run.active[inside]
            count, sides = _counts(active, run_codes, inside, g, left_mask, right_mask)
            st = stats[name]
            st.people.append(lab.person)
            st.peaks.append(int(count[sides].max()) if sides.any() else 0)
            st.counts.append(count)
            st.times.append(run.times[inside] - lab.start_s)
            st.sides.append(sides)
            for other in known.values():   # how far the other gestures' filters counted during this trial
                if other.name != name and other.name not in g.supersedes:   # (superseded ones cannot START)
                    stats[other.name].other_peaks.append(_peak(active, run_codes, inside, other, left_mask,
                                                               right_mask))
            for c in np.flatnonzero(active.any(axis=0)):
                sensor = names.get(int(c), str(c))
                st.active_sensors[sensor] = st.active_sensors.get(sensor, 0) + 1
    return stats


def _counts(active: np.ndarray, codes: np.ndarray | None, inside: np.ndarray, g: GestureFilter,
            left_mask: np.ndarray, right_mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cycles,) int counts of ``g``'s filter sensors counting, and (cycles,) bool both sides (module doc)."""
    counting = active[:, g.channels]
    if g.subtypes:
        if codes is None:
            counting = np.zeros_like(counting)
        else:
            wanted = [i for i, s in enumerate(SUBTYPES) if s in g.subtypes]
            counting &= np.isin(codes[np.ix_(inside, g.channels)], wanted)
    sides = np.ones(counting.shape[0], dtype=bool)
    if g.both_sides:
        sides = (counting & left_mask[g.channels]).any(axis=1) & (counting & right_mask[g.channels]).any(axis=1)
    return counting.sum(axis=1), sides


def _peak(active, codes, inside, g, left_mask, right_mask) -> int:
    """The largest count of ``g``'s filter in the cycles ``inside`` (with both sides, where ``g`` needs them)."""
    count, sides = _counts(active, codes, inside, g, left_mask, right_mask)
    count = count[sides]
    return int(count.max()) if count.size else 0


def suggest(st: GestureStats, g: GestureFilter) -> Suggestion:
    """The suggested ``min_active`` and ``dwell_s`` of ``g`` from its statistics ``st`` (module doc)."""
    people = len(set(st.people))
    n = len(st.peaks)
    if n < MIN_TRIALS:
        why = 'never labelled' if n == 0 else f'one labelled trial ({st.people[0]})'
        return Suggestion(g.name, None, None, n, people, f'{why}: too few to suggest from')
    peaks = np.array(st.peaks)
    if not peaks.any():
        what = f'a sensor carrying {"/".join(g.subtypes)}' if g.subtypes else 'a sensor'
        sides = ' on both sides' if g.both_sides else ''
        return Suggestion(g.name, None, None, n, people, f'no trial of it activated {what} of its filter{sides}')
    reached = peaks[peaks > 0]
    m = int(np.clip(math.floor(np.quantile(reached, QUANTILE)), 1, len(g.channels)))
    others = np.array(st.other_peaks, dtype=np.int64)
    # Raise it while that loses fewer of the gesture's own trials than other gestures' trials it stops matching.
    gain = [int((peaks >= k).sum()) - int((others >= k).sum()) for k in range(m, int(peaks.max()) + 1)]
    m += int(np.argmax(gain))
    reach, hold = st.reach_hold(m, g.lift_s)     # the dwell goes on through lifts up to lift_s
    ok = ~np.isnan(reach)
    dwell = min(float(np.quantile(hold[ok], QUANTILE)), REACTION_S - float(np.quantile(reach[ok], 1 - QUANTILE)))
    dwell = max(0.0, math.floor(dwell / DWELL_STEP_S + 1e-9) * DWELL_STEP_S)
    return Suggestion(g.name, m, round(dwell, 2), n, people)


def suggested_library(library: GestureLibrary, suggestions: Iterable[Suggestion]) -> GestureLibrary:
    """A copy of ``library`` with the suggested settings (gestures without a suggestion unchanged)."""
    by_name = {s.name: s for s in suggestions if s.min_active is not None}
    gestures = [replace(g, min_active=by_name[g.name].min_active, dwell_s=by_name[g.name].dwell_s)
                if g.name in by_name else g for g in library.gestures]
    return GestureLibrary(gestures, library.source, library.default_dwell_s, library.default_gap_s,
                          library.default_lift_s)


def _run_library(run: BearTrials, codes: np.ndarray | None, library: GestureLibrary,
                 body_map: BodyMap) -> list[tuple[str, float]]:
    """(gesture, t) of every START the recogniser with ``library`` emits over ``run``."""
    rec = SymbolicRecogniser(library, body_map)
    starts = []
    for i, t in enumerate(run.times):
        for e in rec.update(float(t), run.active[i], None if codes is None else codes[i]):
            if e.state == START:
                starts.append((e.gesture, float(t)))
    return starts


def persons_trials(run: BearTrials, person: str) -> BearTrials:
    """``run`` with only ``person``'s trials (subtype and symbolic) labelled."""
    return replace(run, labels=[lab for lab in run.labels if lab.person == person],
                   gestures=[lab for lab in run.gestures if lab.person == person])


def leave_one_person_out(runs: list[BearTrials], library: GestureLibrary, body_map: BodyMap,
                         fold_predictors: dict[str, object] | None,
                         progress: Callable[[str], None]) -> dict:
    """Suggestions from every person but one, scored on that one, against the configured settings.

    Args:
        runs: the sessions (:func:`~.sessions.bear_trials`).
        library: the configured gestures.
        body_map: the bear's body map.
        fold_predictors: person -> subtype predictor trained without them (None: no subtype codes).
        progress: lines of progress and warnings.

    Returns: ``{'people': [...], 'suggested': per gesture scores, 'configured': per gesture scores}``, or
    None for fewer than two people. The scores, pooled over the held-out people, are what ``eval bear``
    reports (:func:`~.false_starts.runs_gesture_starts`: detected, false starts by cause and by touch) plus
    ``median_start_latency_s`` over the detected trials.
    """
    people = sorted({lab.person for run in runs for lab in run.gestures})
    if len(people) < 2:
        progress(f'warning: suggested gesture settings are checked leave-one-person-out, which needs trials of '
                 f'two people or more; got {people}: not checked')
        return None
    names = [g.name for g in library.detectable]
    held: dict[str, tuple[list[BearTrials], list]] = {'suggested': ([], []), 'configured': ([], [])}
    for k, person in enumerate(people):
        progress(f'gesture settings, person {person} ({k + 1}/{len(people)}): suggested from the others')
        predictor = (fold_predictors or {}).get(person)
        codes = [trial_codes(r, predictor) for r in runs]
        mine = [i for i, r in enumerate(runs) if any(lab.person == person for lab in r.gestures)]
        others = [i for i in range(len(runs)) if i not in mine]
        stats = gesture_stats([runs[i] for i in others], [codes[i] for i in others], library, body_map,
                              lambda _m: None)
        fold = suggested_library(library, [suggest(stats[n], library[n]) for n in names])
        for which, lib in (('suggested', fold), ('configured', library)):
            held[which][0].extend(persons_trials(runs[i], person) for i in mine)
            held[which][1].extend(_run_library(runs[i], codes[i], lib, body_map) for i in mine)
    pooled = {which: runs_gesture_starts(held_runs, starts, library) for which, (held_runs, starts) in held.items()}
    for which in pooled.values():
        for s in which.values():
            s['median_start_latency_s'] = float(np.median(s['latencies_s'])) if s['latencies_s'] else None
            del s['latencies_s']
    return {'people': people, **pooled}
