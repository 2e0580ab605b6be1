"""Simulated people touching the Sensate Bear: labelled, reproducible, **synthetic** scenes.

A :class:`Person` has their own style for every touch subtype, drawn from knight2009 Table II
(tickle, poke, pet, hold); pat, tap, shake and rub use the assumed statistics in
:data:`SUBTYPE_STATS` (``paper=False``). A share ``person_share`` of the variance lies between
people, the rest between one person's repetitions.

A person performs single-sensor subtypes and the symbolic gestures of :data:`PERFORMANCES`, with
pauses between them. A contact may *stray* to a neighbouring sensor outside the gesture's filter
(``stray_prob``); a second attempt "with explanation" (Table III) strays four times less.

Where knight2009 leaves a person open (how large and firm their contact is, their tempo, rhythm and
persistence, a noisy or drifting level, when in the scan each sensor is read), ``make_scene(...,
population=WIDE)`` draws every person's :class:`Style` from a :class:`Population` of ranges, so a
model can be trained on people wider than Table II's spread alone. The default (``population=None``)
keeps the people of earlier versions, draw for draw.

:class:`BearScene` implements ``touch_sim.scenes.BearStimulus`` (``proximity(t) -> (64,) float32 in
[0, 1]``) and carries the ground truth as :class:`Label` rows.

>>> scene = make_scene(n_people=1, seed=3, subtype_reps=1, gesture_reps=1)
>>> scene.synthetic, scene.proximity(0.0).shape, scene.proximity(0.0).dtype
(True, (64,), dtype('float32'))
>>> sorted({label.kind for label in scene.labels})
['subtype', 'symbolic']
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field, replace

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES

__all__ = ['PERFORMANCES', 'SUBTYPE_STATS', 'SYMBOLIC_PREFIX', 'WIDE', 'BearScene', 'Contact', 'GesturePerformance',
           'Label', 'Person', 'Population', 'Style', 'SubtypeStats', 'make_scene', 'split_label', 'symbolic_label',
           'trial_scene']

N_CHANNELS = 64


@dataclass(frozen=True)
class SubtypeStats:
    """Population statistics of one subtype (amplitude 0..1, frequency Hz, duration s) and hard limits.

    ``paper`` is True when the numbers come from knight2009 Table II, False when they are our assumption.
    """

    amplitude: tuple[float, float]          # mean, std dev (level 0..1)
    frequency_hz: tuple[float, float]       # mean, std dev
    duration_s: tuple[float, float]         # mean, std dev
    amplitude_range: tuple[float, float]
    frequency_range: tuple[float, float]
    duration_range: tuple[float, float]
    paper: bool


#: Table II (knight2009 V.D): tickle 60±10 %, 5-10 Hz (σ 5 Hz), 3-20 s (σ 8 s); poke >30 % (σ 30 %),
#: 0-1 Hz (σ 0.5), 1 s (σ 0.2); pet 100±10 %, 0.5-2 Hz (σ 0.75), >4 s (σ 15 s); hold 100 %, 0 Hz, >4 s (σ 20 s).
#: Ranges stated as intervals use their midpoint as mean; the limits keep draws physical (a finger does
#: not wiggle at 30 Hz) and scenes short (long touches are cut at 20 s). Pat, tap, shake and rub are not in
#: Table II: their numbers are assumptions (``paper=False``), chosen so each differs from its neighbours
#: in at least one of the paper's features (pat: repeated lifts at 1-3 Hz; tap: a 0.25 s contact; shake:
#: a firm grip modulated at 2-5 Hz; rub: continuous contact, shallow 1.5-4 Hz modulation).
SUBTYPE_STATS: dict[str, SubtypeStats] = {
    'tickle': SubtypeStats((0.60, 0.10), (7.5, 5.0), (8.0, 8.0), (0.35, 0.85), (3.0, 12.0), (3.0, 20.0), True),
    'poke': SubtypeStats((0.65, 0.30), (0.5, 0.5), (1.0, 0.2), (0.35, 1.0), (0.0, 1.0), (0.4, 2.0), True),
    'pet': SubtypeStats((1.00, 0.10), (1.25, 0.75), (9.0, 15.0), (0.7, 1.0), (0.4, 2.5), (4.0, 20.0), True),
    'hold': SubtypeStats((1.00, 0.00), (0.0, 0.0), (9.0, 20.0), (0.95, 1.0), (0.0, 0.0), (4.0, 20.0), True),
    'pat': SubtypeStats((0.80, 0.15), (1.6, 0.5), (3.5, 1.5), (0.4, 1.0), (0.7, 3.0), (1.5, 8.0), False),
    'tap': SubtypeStats((0.60, 0.15), (0.0, 0.0), (0.25, 0.08), (0.35, 0.9), (0.0, 0.0), (0.1, 0.5), False),
    'shake': SubtypeStats((0.90, 0.10), (3.0, 1.0), (3.5, 1.5), (0.6, 1.0), (1.5, 5.0), (1.5, 8.0), False),
    'rub': SubtypeStats((0.85, 0.10), (2.5, 0.8), (5.0, 2.0), (0.6, 1.0), (1.5, 4.0), (2.0, 12.0), False),
}


@dataclass(frozen=True)
class GesturePerformance:
    """How a simulated person performs a symbolic gesture (knight2009 Table I, V.E).

    Attributes:
        sensors: sensor names the person aims at (the gesture's locational filter, or part of it).
        touched: (min, max) number of those sensors touched at once.
        subtype: the touch subtype of each contact.
        duration_s: (min, max) seconds the gesture lasts.
        stray: nearby sensors outside the filter where a straying contact lands.
        both_sides: the contacts include at least one sensor on the bear's left and one on its right.
    """

    sensors: tuple[str, ...]
    touched: tuple[int, int]
    subtype: str
    duration_s: tuple[float, float]
    stray: tuple[str, ...]
    both_sides: bool = False


_SIDES = ('side_left_upper', 'side_left_lower', 'side_right_upper', 'side_right_lower')
_HUG = ('chest_left', 'chest_right', 'belly_upper', 'back_upper', 'back_middle', 'back_lower', *_SIDES)

#: The gestures simulated people perform. The four the paper implemented (head_pat, hug, tickle, foot_rub)
#: aim at the sensors of its filters (knight2009 V.E); the others at the sensors named in
#: config/bear_gestures.yaml. Go-to-sleep, wake-up, rocking and dance are not simulated: touch alone
#: cannot tell them (see the config).
PERFORMANCES: dict[str, GesturePerformance] = {
    'head_pat': GesturePerformance(('head1', 'head2', 'head3'), (1, 2), 'pat', (3.0, 6.0),
                                   ('head4', 'ear_left', 'ear_right', 'neck_back')),
    'hug': GesturePerformance(_HUG, (5, 8), 'hold', (4.0, 8.0),
                              ('shoulder_left', 'shoulder_right', 'neck_back', 'belly_middle', 'bottom'),
                              both_sides=True),
    'tickle': GesturePerformance(_SIDES, (2, 3), 'tickle', (4.0, 8.0),
                                 ('belly_left', 'belly_right', 'belly_middle', 'upper_arm_left_inner',
                                  'upper_arm_right_inner', 'chest_left', 'chest_right')),
    'foot_rub': GesturePerformance(('foot_left_sole', 'foot_right_sole'), (1, 1), 'rub', (4.0, 8.0),
                                   ('foot_left_top', 'foot_right_top', 'shin_left', 'shin_right')),
    'handshake': GesturePerformance(('paw_right_palm', 'paw_right_back'), (2, 2), 'shake', (2.5, 5.0),
                                    ('forearm_right',)),
    'shoulder_tap': GesturePerformance(('shoulder_left', 'shoulder_right'), (1, 1), 'tap', (0.3, 0.6),
                                       ('upper_arm_left_outer', 'upper_arm_right_outer', 'neck_back')),
    'belly_tickle': GesturePerformance(('belly_upper', 'belly_middle', 'belly_lower', 'belly_left', 'belly_right'),
                                       (1, 2), 'tickle', (4.0, 8.0), ('chest_left', 'chest_right')),
    'foot_tickle': GesturePerformance(('foot_left_sole', 'foot_right_sole', 'foot_left_toe', 'foot_right_toe'),
                                      (1, 2), 'tickle', (4.0, 8.0), ('foot_left_top', 'foot_right_top')),
    'feeding': GesturePerformance(('mouth', 'snout'), (1, 2), 'hold', (3.0, 6.0), ('chin', 'cheek_left',
                                                                                  'cheek_right')),
}


#: A session label (``/touch/label``) of a symbolic gesture is ``'symbolic/<gesture>'``: the bear's touch
#: subtypes and its gestures share names ('tickle' is both), and one session holds both kinds.
SYMBOLIC_PREFIX = 'symbolic/'


def symbolic_label(gesture: str) -> str:
    """The session label of the symbolic gesture ``gesture``: ``symbolic_label('hug') == 'symbolic/hug'``."""
    return SYMBOLIC_PREFIX + gesture


def split_label(label: str) -> tuple[str, str]:
    """``('symbolic', gesture)`` for a symbolic gesture's session label, else ``('subtype', label)``.

    >>> split_label('symbolic/tickle'), split_label('tickle')
    (('symbolic', 'tickle'), ('subtype', 'tickle'))
    """
    if label.startswith(SYMBOLIC_PREFIX):
        return 'symbolic', label[len(SYMBOLIC_PREFIX):]
    return 'subtype', label


@dataclass(frozen=True)
class Label:
    """Ground truth of one interaction (synthetic).

    Attributes:
        start_s, end_s: when the touch starts and ends, scene seconds.
        kind: ``'subtype'`` (one sensor) or ``'symbolic'`` (a gesture over regions).
        label: the subtype or gesture name.
        sensors: names of the sensors actually touched (including any that strayed).
        person: index of the simulated person.
        attempt: 1 for a first try, 2 for a try "with explanation" (Table III).
    """

    start_s: float
    end_s: float
    kind: str
    label: str
    sensors: tuple[str, ...]
    person: int
    attempt: int = 1


@dataclass(frozen=True)
class Contact:
    """One hand contact on one channel: a level waveform between ``start_s`` and ``end_s``.

    ``amplitude`` is the peak proximity (0..1), ``frequency_hz`` the base frequency of the motion,
    ``depth`` the modulation depth, ``phase`` radians; ``ratio`` and ``phase2`` shape tickle's second
    component; ``taps`` the number of taps of a tap contact. A :class:`Style` adds (all 0 by default:
    the contact is then exactly that of earlier versions): ``rhythm``, the relative swing of the motion's
    tempo within the contact; ``noise``, level noise as a fraction of the peak; ``drift``, the level's
    change from the start to the end of the contact as a fraction of the peak (leaning in or easing off);
    ``jitter_s``, how far (s) the time a sensor is read strays from the scan's schedule.
    """

    channel: int
    start_s: float
    end_s: float
    subtype: str
    amplitude: float
    frequency_hz: float = 0.0
    depth: float = 0.0
    phase: float = 0.0
    ratio: float = 1.6
    phase2: float = 0.0
    taps: int = 1
    rhythm: float = 0.0
    noise: float = 0.0
    drift: float = 0.0
    jitter_s: float = 0.0

    def level(self, t: np.ndarray | float) -> np.ndarray:
        """Proximity of this contact at times ``t`` (s, any shape), float64 in [0, 1]; 0 outside the contact."""
        t = np.asarray(t, dtype=np.float64)
        if self.jitter_s:
            t = t + self.jitter_s * _hash_noise(t, self.channel)
        u = t - self.start_s
        d = self.end_s - self.start_s
        inside = (u >= 0) & (u < d)
        a = self.amplitude
        # Hand approach and release: 0.15 s smooth ramps (capacitive level grows with proximity, IV.D).
        ramp = np.clip(np.minimum(u, d - u) / 0.15, 0.0, 1.0)
        env = ramp * ramp * (3 - 2 * ramp)
        out = self._motion(u, d, env)
        if self.drift:
            out = out * (1 + self.drift * (np.clip(u / max(d, 1e-9), 0, 1) - 0.5))
        if self.noise:
            out = out + self.noise * a * env * _hash_noise(t, self.channel + 101)
        return np.where(inside, np.clip(out, 0.0, 1.0), 0.0)

    def _motion(self, u: np.ndarray, d: float, env: np.ndarray) -> np.ndarray:
        """The level of this subtype's motion at contact times ``u`` (s), before drift, noise and clipping."""
        a, f, s = self.amplitude, self.frequency_hz, self.subtype
        um = u                # motion time: runs faster and slower than u when the tempo swings
        if self.rhythm:
            um = u + self.rhythm * np.sin(2 * np.pi * _RHYTHM_HZ * u + self.phase2) / (2 * np.pi * _RHYTHM_HZ)
        if s == 'hold':
            out = a * env * (1 - 0.02 * (1 - np.cos(2 * np.pi * 0.2 * u)))   # a steady hand sways 2 %
        elif s in ('pet', 'rub'):   # a stroke / rub passes over the sensor: level dips by `depth` each cycle
            out = a * env * (1 - self.depth * 0.5 * (1 - np.cos(2 * np.pi * f * um + self.phase)))
        elif s == 'tickle':         # wiggling fingers: two incommensurate components ("noise", Table II)
            out = a * env * (0.55 + 0.25 * np.sin(2 * np.pi * f * um + self.phase)
                             + 0.2 * np.sin(2 * np.pi * f * self.ratio * um + self.phase2))
        elif s == 'shake':
            out = a * env * (1 - self.depth * 0.5 * (1 - np.sin(2 * np.pi * f * um + self.phase)))
        elif s == 'poke':           # one blip
            out = a * np.sin(np.pi * np.clip(u / d, 0, 1)) ** 2
        elif s == 'pat':            # the hand lifts off between pats: raised-cosine contacts, duty `depth`
            cycle = np.mod(um * f, 1.0)
            out = a * np.where(cycle < self.depth, np.sin(np.pi * cycle / max(self.depth, 1e-6)) ** 2, 0.0)
        elif s == 'tap':            # `taps` short contacts of d / taps seconds each
            width = d / self.taps
            out = a * np.sin(np.pi * np.mod(um, width) / width) ** 2
        else:
            raise ValueError(f'unknown subtype {s!r} in a contact')
        return out


#: How often a person's tempo swings (``Contact.rhythm``), Hz: a slow drift of pace, not a tremor.
_RHYTHM_HZ = 0.3


def _hash_noise(t: np.ndarray, salt: int) -> np.ndarray:
    """Deterministic noise in [-1, 1] for times ``t`` (s): the same scene reads the same, run after run."""
    x = np.sin(np.round(np.asarray(t) * 1e4) * 12.9898 + salt * 78.233) * 43758.5453
    return 2.0 * (x - np.floor(x)) - 1.0


def _draw(rng: np.random.Generator, mean: float, sd: float, lo: float, hi: float) -> float:
    """A normal draw clipped to [lo, hi] (reflection would distort the table's means less than
    rejection does for wide std devs; clipping is simplest and keeps the limits exact)."""
    return float(np.clip(rng.normal(mean, sd), lo, hi))


@dataclass(frozen=True)
class Style:
    """What knight2009 leaves open about one person, drawn from a :class:`Population`.

    Attributes:
        pressure: factor on every contact's peak proximity (contact size and how firmly they press).
        tempo: factor on the frequency of every motion (pets, rubs, pats, tickles, shakes).
        persistence: factor on how long each touch lasts.
        rhythm: relative swing of their tempo within a touch (0: a metronome).
        noise: level noise, fraction of a contact's peak.
        drift: (signed) change of the level from the start to the end of a touch, fraction of the peak.
        jitter_s: how far (s) the reading of a sensor strays from the scan's schedule.
    """

    pressure: float = 1.0
    tempo: float = 1.0
    persistence: float = 1.0
    rhythm: float = 0.0
    noise: float = 0.0
    drift: float = 0.0
    jitter_s: float = 0.0


@dataclass(frozen=True)
class Population:
    """Ranges (min, max; each person draws uniformly) of every :class:`Style` field, and ``person_share``
    (the share of Table II's variance that lies between people). Assumptions, not from the paper: wide
    enough to hold people who press lightly or hard, touch slowly or briskly, briefly or at length.
    """

    pressure: tuple[float, float] = (0.55, 1.2)
    tempo: tuple[float, float] = (0.65, 1.5)
    persistence: tuple[float, float] = (0.6, 1.6)
    rhythm: tuple[float, float] = (0.0, 0.35)
    noise: tuple[float, float] = (0.0, 0.12)
    drift: tuple[float, float] = (-0.4, 0.4)
    jitter_s: tuple[float, float] = (0.0, 0.06)
    person_share: float = 0.5

    def draw(self, rng: np.random.Generator) -> Style:
        """One person's style."""
        return Style(**{name: float(rng.uniform(*getattr(self, name))) for name in Style.__dataclass_fields__})


#: The wide population of simulated people (:class:`Population`'s defaults).
WIDE = Population()


@dataclass
class Person:
    """A simulated person: their own mean of every Table II quantity, and how often they stray.

    Args:
        index: person number (labels carry it).
        rng: the person's random generator (seeded by the scene).
        person_share: fraction of Table II's variance that lies between people (assumption: 0.25).
        stray_prob: chance that a contact of a symbolic gesture lands outside the filter.
        style: what the paper leaves open (:class:`Style`; None: Table II's people, as in earlier versions).
    """

    index: int
    rng: np.random.Generator
    person_share: float = 0.25
    stray_prob: float = 0.15
    means: dict[str, tuple[float, float, float]] = field(default_factory=dict)
    style: Style | None = None

    def __post_init__(self) -> None:
        k = math.sqrt(self.person_share)
        for name, st in SUBTYPE_STATS.items():
            self.means[name] = (
                _draw(self.rng, st.amplitude[0], k * st.amplitude[1], *st.amplitude_range),
                _draw(self.rng, st.frequency_hz[0], k * st.frequency_hz[1], *st.frequency_range),
                _draw(self.rng, st.duration_s[0], k * st.duration_s[1], *st.duration_range),
            )

    def contact(self, subtype: str, channel: int, start_s: float, duration_s: float | None = None) -> Contact:
        """One contact of ``subtype`` on ``channel`` in this person's style (duration drawn unless given)."""
        st = SUBTYPE_STATS[subtype]
        rng = self.rng
        k = math.sqrt(1.0 - self.person_share)
        amp_mean, freq_mean, dur_mean = self.means[subtype]
        amplitude = _draw(rng, amp_mean, k * st.amplitude[1], *st.amplitude_range)
        frequency = _draw(rng, freq_mean, k * st.frequency_hz[1], *st.frequency_range)
        duration = duration_s if duration_s is not None else _draw(rng, dur_mean, k * st.duration_s[1],
                                                                   *st.duration_range)
        depth, taps = 0.0, 1
        if subtype == 'pet':
            depth = rng.uniform(0.4, 0.7)
        elif subtype == 'rub':
            depth = rng.uniform(0.15, 0.35)
        elif subtype == 'shake':
            depth = rng.uniform(0.2, 0.4)
        elif subtype == 'pat':
            depth = rng.uniform(0.3, 0.5)     # duty cycle of each pat
        elif subtype == 'tap':
            taps = int(rng.integers(1, 3))
            duration = duration * taps
        contact = Contact(channel, start_s, start_s + duration, subtype, amplitude, frequency, depth,
                          phase=float(rng.uniform(0, 2 * np.pi)), ratio=float(rng.uniform(1.3, 1.9)),
                          phase2=float(rng.uniform(0, 2 * np.pi)), taps=taps)
        if self.style is None:
            return contact
        st = self.style
        # A given duration (a gesture's) is the gesture's own; otherwise the person keeps at it longer or less.
        held = duration if duration_s is not None else duration * st.persistence
        return replace(contact, end_s=start_s + held, amplitude=min(1.0, amplitude * st.pressure),
                       frequency_hz=frequency * st.tempo, rhythm=st.rhythm, noise=st.noise, drift=st.drift,
                       jitter_s=st.jitter_s)


class BearScene:
    """A scripted scene: contacts (the stimulus) plus ground-truth labels. Synthetic data.

    Implements ``touch_sim.scenes.BearStimulus``: :meth:`proximity`.

    Args:
        contacts: every contact of the scene.
        labels: the ground truth, one row per interaction.
        duration_s: scene length, s.
        description: what the scene is, for reports.
    """

    synthetic = True

    def __init__(self, contacts: list[Contact], labels: list[Label], duration_s: float, description: str = '') -> None:
        self.contacts = sorted(contacts, key=lambda c: c.start_s)
        self.labels = sorted(labels, key=lambda lab: lab.start_s)
        self.duration_s = float(duration_s)
        self.description = description
        self._starts = [c.start_s for c in self.contacts]
        self._longest = max((c.end_s - c.start_s for c in self.contacts), default=0.0)

    def active_contacts(self, t: float) -> list[Contact]:
        """Contacts under way at time ``t`` (s)."""
        hi = bisect.bisect_right(self._starts, t)
        lo = bisect.bisect_left(self._starts, t - self._longest)
        return [c for c in self.contacts[lo:hi] if c.start_s <= t < c.end_s]

    def proximity(self, t: float) -> np.ndarray:
        """(64,) float32 in [0, 1]: proximity of a hand to every channel at time ``t`` (s).

        Overlapping contacts on one channel combine as the larger of the two (a second hand on a
        sensor already covered adds no area).
        """
        out = np.zeros(N_CHANNELS, dtype=np.float32)
        for c in self.active_contacts(t):
            out[c.channel] = max(out[c.channel], float(c.level(t)))
        return out

    def subtype_truth(self, t: float) -> dict[int, str]:
        """Channel -> subtype of the contacts under way at ``t`` (channels not listed: 'none')."""
        return {c.channel: c.subtype for c in self.active_contacts(t)}


def make_scene(n_people: int = 6, seed: int = 0, subtype_reps: int = 2, gesture_reps: int = 2,
               pause_s: tuple[float, float] = (2.0, 5.0), gestures: tuple[str, ...] | None = None,
               subtypes: tuple[str, ...] = TOUCH_SUBTYPES, body_map=None, person_share: float = 0.25,
               stray_prob: tuple[float, float] = (0.0, 0.35), lead_in_s: float = 4.0,
               population: Population | None = None) -> BearScene:
    """Script a scene: each of ``n_people`` performs every subtype ``subtype_reps`` times on a random
    fitted sensor, and every gesture ``gesture_reps`` times (attempt 1 = first try, later attempts "with
    explanation", straying a quarter as often), in a shuffled order with pauses. Synthetic.

    Args:
        n_people: simulated people, one after the other.
        seed: makes the scene reproducible (same seed, same scene).
        subtype_reps, gesture_reps: repetitions per person.
        pause_s: (min, max) pause between interactions, s.
        gestures: gesture names from :data:`PERFORMANCES` (default: all).
        subtypes: subtypes to perform (default: Table I's eight).
        body_map: a ``BodyMap`` (default: the package's).
        person_share: share of Table II variance between people.
        stray_prob: (min, max) of each person's stray probability (uniform).
        lead_in_s: untouched seconds at the start (the calibrator learns its baseline there).
        population: draw each person's :class:`Style` from it (and its ``person_share`` replaces
            ``person_share``); None: the people of earlier versions, unchanged.
    """
    if n_people < 1:
        raise ValueError(f'n_people must be >= 1; got {n_people}')
    if body_map is None:
        body_map = BodyMap.default()
    gestures = tuple(PERFORMANCES) if gestures is None else tuple(gestures)
    for name in gestures:
        if name not in PERFORMANCES:
            raise ValueError(f'no performance scripted for gesture {name!r}; known: {", ".join(PERFORMANCES)}')
    for name in subtypes:
        if name not in SUBTYPE_STATS:
            raise ValueError(f'unknown subtype {name!r}; expected some of: {", ".join(SUBTYPE_STATS)}')
    root = np.random.default_rng(seed)
    channels = np.array([s.channel for s in body_map.sensors])
    contacts: list[Contact] = []
    labels: list[Label] = []
    t = lead_in_s
    for p in range(n_people):
        rng = np.random.default_rng(root.integers(1 << 63))
        stray = float(rng.uniform(*stray_prob))
        if population is None:
            person = Person(p, rng, person_share=person_share, stray_prob=stray)
        else:   # styles from their own generator: the other draws stay those of population=None
            person = Person(p, rng, person_share=population.person_share, stray_prob=stray,
                            style=population.draw(np.random.default_rng((seed, p, 28))))
        plan = [('subtype', s, 1) for s in subtypes for _ in range(subtype_reps)]
        order = rng.permutation(len(plan))
        plan = [plan[i] for i in order]
        # Gesture attempts keep their order per gesture (first try before the explained one).
        for attempt in range(1, gesture_reps + 1):
            for g in rng.permutation(len(gestures)):
                plan.insert(int(rng.integers(0, len(plan) + 1)), ('symbolic', gestures[g], attempt))
        seen: dict[tuple[str, str], int] = {}
        for kind, name, _ in plan:
            attempt = seen.get((kind, name), 0) + 1     # the subtype 'tickle' and the gesture 'tickle' differ
            seen[(kind, name)] = attempt
            if kind == 'subtype':
                ch = int(rng.choice(channels))
                c = person.contact(name, ch, t)
                contacts.append(c)
                labels.append(Label(t, c.end_s, 'subtype', name, (body_map.by_channel(ch).name,), p, attempt))
                end = c.end_s
            else:
                new, touched, end = _perform_gesture(person, PERFORMANCES[name], t, attempt, body_map)
                contacts.extend(new)
                labels.append(Label(t, end, 'symbolic', name, touched, p, attempt))
            t = end + float(rng.uniform(*pause_s))
    styles = 'Table II styles' if population is None else 'Table II styles and a wide population of styles'
    return BearScene(contacts, labels, t + pause_s[1],
                     f'synthetic: {n_people} simulated people (seed {seed}), {styles}')


def _perform_gesture(person: Person, perf: GesturePerformance, t: float, attempt: int,
                     body_map) -> tuple[list[Contact], tuple[str, ...], float]:
    rng = person.rng
    stray = person.stray_prob if attempt == 1 else person.stray_prob / 4
    k = int(rng.integers(perf.touched[0], perf.touched[1] + 1))
    aim = list(rng.permutation(perf.sensors)[:k])
    if perf.both_sides:
        sides = {body_map.by_name(n).side for n in aim}
        for need in ('left', 'right'):
            if need not in sides:
                options = [n for n in perf.sensors if body_map.by_name(n).side == need and n not in aim]
                aim[int(rng.integers(len(aim)))] = options[int(rng.integers(len(options)))]
                sides = {body_map.by_name(n).side for n in aim}
    touched = [str(perf.stray[int(rng.integers(len(perf.stray)))]) if rng.random() < stray else str(n)
               for n in aim]
    touched = list(dict.fromkeys(touched))       # a stray contact may land on a sensor already touched
    duration = float(rng.uniform(*perf.duration_s))
    contacts = []
    for name in touched:
        delay = float(rng.uniform(0.0, 0.4))     # hands do not land on every sensor at once
        contacts.append(person.contact(perf.subtype, body_map.by_name(name).channel, t + delay,
                                       duration_s=None if perf.subtype == 'tap' else duration - delay))
    end = max(c.end_s for c in contacts)
    return contacts, tuple(touched), end


def trial_scene(person_index: int, trials: list[tuple[str, float]], seed: int = 0, lead_in_s: float = 4.0,
                pause_s: tuple[float, float] = (2.0, 5.0), person_share: float = 0.25, body_map=None,
                stray_prob: tuple[float, float] = (0.0, 0.35)) -> BearScene:
    """One person's recording session (``social-touch collect bear --simulate``), SYNTHETIC: single-sensor
    subtypes and symbolic gestures (``'symbolic/<gesture>'``, :func:`symbolic_label`) in the protocol's order.

    Args:
        person_index: the person (their style is drawn from ``(seed, person_index)``).
        trials: ``(name, amplitude_scale)`` in the order the protocol prompts them: a subtype of
            :data:`SUBTYPE_STATS` (performed on one random fitted sensor) or a symbolic gesture of
            :data:`PERFORMANCES` (performed over its sensors, as in :func:`make_scene`); the scale
            multiplies every contact's peak proximity (a "gentle" or "rough" variant), clipped to 1.
        seed: the session's randomness.
        lead_in_s: untouched seconds first (the calibrator learns its baseline there).
        pause_s: (min, max) pause between trials, s.
        person_share: share of Table II variance between people.
        body_map: a ``BodyMap`` (default: the package's).
        stray_prob: (min, max) of the person's chance that a gesture's contact strays outside its filter
            (drawn from its own generator, so subtype-only sessions are those of earlier versions).

    Returns: the scene; one :class:`Label` per trial, in order (kind ``'subtype'`` or ``'symbolic'``;
    a symbolic label carries the gesture's name without the prefix).
    """
    unknown = sorted({name for name, _ in trials if split_label(name)[0] == 'subtype'} - set(SUBTYPE_STATS)
                     | {name for name, _ in trials if split_label(name)[0] == 'symbolic'
                        and split_label(name)[1] not in PERFORMANCES})
    if unknown:
        raise ValueError(f'unknown subtypes or gestures {unknown}; the simulated people perform the subtypes '
                         f'{", ".join(SUBTYPE_STATS)} and the gestures '
                         f'{", ".join(symbolic_label(g) for g in PERFORMANCES)}')
    if body_map is None:
        body_map = BodyMap.default()
    rng = np.random.default_rng((seed, person_index))
    person = Person(person_index, rng, person_share=person_share)
    person.stray_prob = float(np.random.default_rng((seed, person_index, 1)).uniform(*stray_prob))
    channels = np.array([s.channel for s in body_map.sensors])
    contacts: list[Contact] = []
    labels: list[Label] = []
    t = float(lead_in_s)
    for name, scale in trials:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f'amplitude scale must be a positive number; got {scale}')
        kind, label = split_label(name)
        if kind == 'symbolic':
            new, touched, end = _perform_gesture(person, PERFORMANCES[label], t, 1, body_map)
            contacts.extend(replace(c, amplitude=min(1.0, c.amplitude * scale)) for c in new)
            labels.append(Label(t, end, 'symbolic', label, touched, person_index))
            t = end + float(rng.uniform(*pause_s))
            continue
        ch = int(rng.choice(channels))
        c = person.contact(name, ch, t)
        c = replace(c, amplitude=min(1.0, c.amplitude * scale))
        contacts.append(c)
        labels.append(Label(t, c.end_s, 'subtype', name, (body_map.by_channel(ch).name,), person_index))
        t = c.end_s + float(rng.uniform(*pause_s))
    return BearScene(contacts, labels, t + pause_s[1], f'synthetic: simulated person {person_index} (seed {seed})')
