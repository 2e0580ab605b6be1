"""A second family of simulated people touching the Sensate Bear: hands over plates (**synthetic**).

Written from knight2009 independently of :mod:`.people` (level waveforms with Table II statistics),
so a model made from one family can be measured on the other. A person moves a *hand* over the
bear and each sensor's level is what a shielded plate would see:

- *contact size*: a palm is a disc of the hand radius; poke, tap and tickle use fingertips;
  plates are 1.5"x2" or 3"x2" (IV.C) at the body map's positions;
- *coupling*: the level grows with the share of the plate covered and falls off with distance from
  its centre and height above the fur (about 1 inch, IV.A); full contact saturates (IV.D);
- *subtypes* (Table I): hold = a still palm; pet = palm strokes, lifting on the way back; rub =
  back and forth; pat = the palm landing and lifting; tap = one or two brief fingertip touches;
  poke = one fingertip pressed; tickle = fingertips wiggling fast; shake = a rhythmic squeeze;
- *per person*: hand and fingertip size, pressure, tempo, persistence, rhythm and aim;
- *the sensing chain* (IV.A, IV.D): channels read 5 ms apart within a scan (the device reads
  ``proximity`` at each channel's time); baseline drift, rare glitches, cross-talk within a
  Midplane, the bear's clock error (``clock_error``); dropped frames are the port's ``drop``
  (:data:`PORT_OPTIONS`).

:class:`HandScene` implements ``touch_sim.scenes.BearStimulus`` and carries :class:`~.people.Label`
rows, as :class:`~.people.BearScene` does.

>>> scene = make_hand_scene(n_people=1, seed=2, subtype_reps=1, gesture_reps=1)
>>> scene.synthetic, scene.proximity(10.0).shape
(True, (64,))
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.subtype_labels import TOUCH_SUBTYPES

from .people import PERFORMANCES, Label, split_label

__all__ = ['PORT_OPTIONS', 'HandPerson', 'HandScene', 'HandTouch', 'hand_trial_scene', 'make_hand_scene']

N_CHANNELS = 64
INCH = 0.0254
#: Plate sizes, metres (knight2009 IV.C: 1.5"x2" and 3"x2").
PLATE_M = {'small': (1.5 * INCH, 2 * INCH), 'large': (3 * INCH, 2 * INCH)}
#: Height above the fur at which a hand stops being sensed (IV.A: "approximately 1 inch").
SENSE_HEIGHT_M = INCH
#: Level of a plate a contact covers wholly is 1 - exp(-gain): direct touch saturates (IV.D); a fingertip
#: covering a tenth of a plate reads about 0.45.
COUPLING_GAIN = 6.0
#: Virtual port faults of this family's sessions: a frame is lost now and then on the USB link.
PORT_OPTIONS = {'drop': '0.01'}


@dataclass(frozen=True)
class HandPerson:
    """One person's way of touching (every trait is open in knight2009, so each is drawn per person).

    Attributes:
        palm_m: radius of the palm's contact disc, m.
        finger_m: radius of one fingertip's contact disc, m.
        pressure: 0.5 (light) .. 1.5 (firm): scales the contact area and the poke's press.
        tempo: multiplies every rhythm (pats, strokes, rubs, wiggles, squeezes).
        persistence: multiplies how long each touch lasts.
        rhythm: irregularity of each period (standard deviation as a fraction of it).
        aim_m: standard deviation of where the hand lands from the target plate's centre, m.
    """

    index: int
    palm_m: float
    finger_m: float
    pressure: float
    tempo: float
    persistence: float
    rhythm: float
    aim_m: float

    @classmethod
    def draw(cls, index: int, rng: np.random.Generator) -> HandPerson:
        return cls(index, palm_m=float(rng.uniform(0.03, 0.055)), finger_m=float(rng.uniform(0.007, 0.012)),
                   pressure=float(rng.uniform(0.5, 1.5)), tempo=float(rng.uniform(0.6, 1.6)),
                   persistence=float(rng.uniform(0.5, 1.8)), rhythm=float(rng.uniform(0.0, 0.35)),
                   aim_m=float(rng.uniform(0.0, 0.03)))


#: Per subtype: base duration range, s (before persistence), and base rhythm, Hz (before tempo). From
#: Table I's descriptions and Table II's poke (1 s); nothing here is taken from :mod:`.people`.
#: Brief touches (tap, poke) vary with the square root of persistence: a poke stays a poke.
_STYLE = {
    'hold': ((4.0, 12.0), 0.0), 'pet': ((4.0, 12.0), 0.8), 'rub': ((3.0, 9.0), 2.5), 'pat': ((2.0, 6.0), 2.0),
    'tap': ((0.15, 0.35), 0.0), 'poke': ((0.8, 1.2), 0.0), 'tickle': ((3.0, 10.0), 7.0), 'shake': ((2.0, 6.0), 3.0),
}


@dataclass
class HandTouch:
    """One hand on one target plate between ``start_s`` and ``end_s``: a trajectory and contact size.

    ``anchor`` is where the hand aims (m, body frame); ``axis`` the unit direction it moves along;
    ``beats`` the (k,) start times, s, of each stroke / pat / squeeze (irregular rhythm).
    """

    subtype: str
    channel: int
    start_s: float
    end_s: float
    anchor: np.ndarray
    axis: np.ndarray
    radius_m: float
    fingers: int
    pressure: float
    beats: np.ndarray
    reach: tuple[int, ...] = ()
    wiggle: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))

    def pose(self, t: float) -> tuple[np.ndarray, float, float]:
        """(centres (k, 3) m of the contact discs, height above the fur m, area factor) at time ``t``."""
        u = t - self.start_s
        d = self.end_s - self.start_s
        ramp = min(1.0, u / 0.2, (d - u) / 0.2) if d > 0.4 else math.sin(math.pi * min(max(u / d, 0.0), 1.0))
        height = SENSE_HEIGHT_M * (1.0 - max(ramp, 0.0))      # approaching and leaving
        centre = self.anchor.copy()
        squeeze = 1.0
        if self.beats.size:
            i = max(0, int(np.searchsorted(self.beats, u, side='right')) - 1)
            last = self.beats[i] - self.beats[i - 1] if i else 0.5
            period = self.beats[i + 1] - self.beats[i] if i + 1 < self.beats.size else last
            phase = (u - self.beats[i]) / max(period, 1e-3)
            s = self.subtype
            if s == 'pet':        # stroke across the plate in contact, return lifted
                centre = centre + self.axis * 0.06 * ((phase / 0.6) - 0.5 if phase < 0.6 else 0.5 - (phase - 0.6) / 0.4)
                height = max(height, 0.0 if phase < 0.6 else 0.6 * SENSE_HEIGHT_M)
            elif s == 'rub':      # back and forth in contact
                centre = centre + self.axis * 0.015 * math.sin(2 * math.pi * phase)
            elif s == 'pat':      # land, stay briefly, lift high
                height = max(height, 0.0 if phase < 0.35 else 1.2 * SENSE_HEIGHT_M * math.sin(math.pi * (phase - 0.35)
                                                                                             / 0.65))
            elif s == 'shake':    # a grip squeezing and easing
                squeeze = 0.75 + 0.25 * math.cos(2 * math.pi * phase)
            elif s == 'tickle':   # fingertips scuttle around the anchor, lifting now and then
                k = i % max(len(self.wiggle), 1)
                centre = centre + self.wiggle[k] * math.sin(math.pi * phase)
                height = max(height, 0.5 * SENSE_HEIGHT_M * (0.5 - 0.5 * math.cos(2 * math.pi * phase)))
        offsets = np.linspace(-1, 1, self.fingers)[:, None] * self.axis[None, :] * 0.018 if self.fingers > 1 else \
            np.zeros((1, 3))
        return centre[None, :] + offsets, height, squeeze * self.pressure


class HandScene:
    """Hands over the bear's plates, with the sensing chain's own faults; labelled. Synthetic data.

    Implements ``touch_sim.scenes.BearStimulus``; ``labels``, ``duration_s`` and :meth:`subtype_truth`
    as :class:`~.people.BearScene`.
    """

    synthetic = True

    def __init__(self, touches: list[HandTouch], labels: list[Label], duration_s: float, body_map, seed: int,
                 description: str = '', sessions: tuple[float, ...] = (0.0,)) -> None:
        self.touches = sorted(touches, key=lambda c: c.start_s)
        self.labels = sorted(labels, key=lambda lab: lab.start_s)
        self.duration_s = float(duration_s)
        self.description = description
        rng = np.random.default_rng((seed, 0x4A4D))
        self.channels = np.array([s.channel for s in body_map.sensors])
        self._unfitted = ~np.isin(np.arange(N_CHANNELS), self.channels)
        self.centres = np.zeros((N_CHANNELS, 3))
        self.half = np.full((N_CHANNELS, 2), 0.02)
        for s in body_map.sensors:
            self.centres[s.channel] = s.position if s.position is not None else (0.0, 0.0, 0.0)
            self.half[s.channel] = np.array(PLATE_M[s.size]) / 2
        self.plate_r = np.sqrt(self.half[:, 0] * self.half[:, 1] / math.pi * 4)   # equal-area disc radius
        # The sensing chain: per-channel drift (level units), glitches, board cross-talk, clock error.
        self.drift_level = rng.uniform(0.0, 0.06, N_CHANNELS)
        self.drift_omega = 2 * np.pi / rng.uniform(60.0, 400.0, N_CHANNELS)
        self.drift_phase = rng.uniform(0, 2 * np.pi, N_CHANNELS)
        self.crosstalk = float(rng.uniform(0.0, 0.03))   # shielded plates: little cross-triggering (IV.D)
        # A cheap resonator: within +-0.05 % (500 ppm) of the people's clock, from each session's start.
        self.clock_error = float(rng.uniform(-5e-4, 5e-4))
        self.sessions = np.asarray(sessions, dtype=np.float64)
        per_hour = rng.uniform(0.0, 1.0, N_CHANNELS)
        self.glitches = [(float(t), int(ch), float(rng.uniform(0.2, 0.7)))
                         for ch in self.channels for t in np.sort(rng.uniform(0, duration_s,
                                                                              rng.poisson(per_hour[ch] * duration_s /
                                                                                          3600)))]
        self._starts = np.array([c.start_s for c in self.touches])
        self._longest = max((c.end_s - c.start_s for c in self.touches), default=0.0)

    def _under_way(self, t: float) -> list[HandTouch]:
        hi = int(np.searchsorted(self._starts, t, side='right'))
        lo = int(np.searchsorted(self._starts, t - self._longest, side='left'))
        return [c for c in self.touches[lo:hi] if c.start_s <= t < c.end_s]

    def true_time(self, t: float) -> float:
        """The people's time at the bear's time ``t``: the bear's clock runs ``clock_error`` fast or slow from
        the start of each session (a session is one person's, recorded from its own start)."""
        start = self.sessions[max(int(np.searchsorted(self.sessions, t, side='right')) - 1, 0)]
        return t + self.clock_error * (t - start)

    def proximity(self, t: float) -> np.ndarray:
        """(64,) float64 levels in [0, 1] the plates see at the bear's time ``t`` (s)."""
        true_t = self.true_time(t)
        out = np.zeros(N_CHANNELS)
        for c in self._under_way(true_t):
            centres, height, press = c.pose(true_t)
            if height >= SENSE_HEIGHT_M:
                continue
            near = 1.0 - height / SENSE_HEIGHT_M
            radius = c.radius_m * math.sqrt(max(press, 0.1))
            for centre in centres:
                gap = self.centres - centre[None, :]
                dist = np.sqrt(np.einsum('ij,ij->i', gap, gap))
                # Overlap of the contact disc with the plate's equal-area disc, smoothed, over the plate's area.
                overlap = np.clip((radius + self.plate_r - dist) / (2 * np.minimum(radius, self.plate_r)), 0.0, 1.0)
                covered = overlap * np.minimum(1.0, radius ** 2 / self.plate_r ** 2)
                out += 1.0 - np.exp(-COUPLING_GAIN * covered * near * near)
        out[self._unfitted] = 0.0
        if self.crosstalk:
            boards = out.reshape(-1, 8)
            out = out + self.crosstalk * (boards.sum(axis=1, keepdims=True) - boards).ravel()
        out = out + self.drift_level * (0.5 + 0.5 * np.sin(self.drift_omega * t + self.drift_phase))
        for when, ch, size in self.glitches:
            if when <= t < when + 0.25:
                out[ch] += size
        return np.clip(out, 0.0, 1.0)

    def subtype_truth(self, t: float) -> dict[int, str]:
        """Channel -> subtype of the touches under way at ``t`` (their target plate and the plates they reach)."""
        out = {}
        for c in self._under_way(self.true_time(t)):
            for ch in (c.channel, *c.reach):
                out[ch] = c.subtype
        return out


def _touch(person: HandPerson, subtype: str, channel: int, start_s: float, rng: np.random.Generator, scene_ctx,
           duration_s: float | None = None) -> HandTouch:
    """One touch of ``subtype`` by ``person`` aimed at ``channel``."""
    centres, plate_r = scene_ctx
    (lo, hi), rate = _STYLE[subtype]
    brief = subtype in ('tap', 'poke')
    stretch = math.sqrt(person.persistence) if brief else person.persistence
    duration = duration_s if duration_s is not None and not brief else float(rng.uniform(lo, hi)) * stretch
    anchor = centres[channel] + rng.normal(0.0, person.aim_m, 3)
    edge = np.where(plate_r > 0, np.linalg.norm(centres - anchor[None, :], axis=1) - plate_r, np.inf)
    channel = int(np.argmin(edge))           # the plate the hand lands on (aim may miss the target)
    axis = rng.normal(size=3)
    axis /= np.linalg.norm(axis)
    fingertip = subtype in ('poke', 'tap', 'tickle')
    fingers = {'poke': 1, 'tap': int(rng.integers(1, 3)), 'tickle': int(rng.integers(2, 5))}.get(subtype, 1)
    radius = person.finger_m if fingertip else person.palm_m * (0.7 if subtype == 'rub' and rng.random() < 0.5 else 1)
    pressure = person.pressure * (1.6 if subtype == 'poke' else 1.0)   # a poke presses in
    beats = np.zeros(0)
    if rate:
        mean = 1.0 / (rate * person.tempo)
        periods = mean * np.clip(1.0 + person.rhythm * rng.normal(size=int(duration / mean) + 3), 0.4, 2.0)
        beats = np.concatenate([[0.0], np.cumsum(periods)])
    wiggle = rng.normal(0.0, 0.01, (8, 3)) if subtype == 'tickle' else np.zeros((0, 3))
    dist = np.linalg.norm(centres - anchor[None, :], axis=1)
    reach = tuple(int(ch) for ch in np.flatnonzero(dist < radius + plate_r) if ch != channel and plate_r[ch] > 0)
    return HandTouch(subtype, channel, start_s, start_s + duration, anchor, axis, radius, fingers, pressure, beats,
                     reach, wiggle)


def _gesture(person: HandPerson, name: str, t: float, rng, body_map, ctx) -> tuple[list[HandTouch], tuple, float]:
    """The hands of symbolic gesture ``name`` (aimed at the sensors named in :data:`~.people.PERFORMANCES`:
    which body parts a gesture touches is Table I's, the sensor names the body map's)."""
    perf = PERFORMANCES[name]
    k = int(rng.integers(perf.touched[0], perf.touched[1] + 1))
    aim = [str(s) for s in rng.permutation(perf.sensors)[:k]]
    if perf.both_sides:
        for need in ('left', 'right'):
            if need not in {body_map.by_name(n).side for n in aim}:
                aim[0 if need == 'left' else -1] = next(n for n in perf.sensors if body_map.by_name(n).side == need)
    base = float(rng.uniform(*perf.duration_s)) * (person.persistence if perf.subtype != 'tap' else 1.0)
    touches = []
    for n in dict.fromkeys(aim):
        delay = float(rng.uniform(0.0, 0.5))
        touches.append(_touch(person, perf.subtype, body_map.by_name(n).channel, t + delay, rng, ctx,
                              None if perf.subtype == 'tap' else max(base - delay, 0.5)))
    end = max(c.end_s for c in touches)
    touched = tuple(dict.fromkeys(body_map.by_channel(ch).name for c in touches for ch in (c.channel, *c.reach)))
    return touches, touched, end


def _context(body_map):
    centres = np.zeros((N_CHANNELS, 3))
    plate_r = np.zeros(N_CHANNELS)
    for s in body_map.sensors:
        centres[s.channel] = s.position if s.position is not None else (0.0, 0.0, 0.0)
        w, h = PLATE_M[s.size]
        plate_r[s.channel] = math.sqrt(w * h / math.pi)
    return centres, plate_r


def hand_trial_scene(person_index: int, trials: list[tuple[str, float]], seed: int = 0, lead_in_s: float = 4.0,
                     pause_s: tuple[float, float] = (2.0, 5.0), body_map=None) -> HandScene:
    """One person's session in the protocol's order (as :func:`~.people.trial_scene`), SYNTHETIC.

    ``trials``: ``(name, scale)``, a subtype or ``'symbolic/<gesture>'``; ``scale`` multiplies the
    person's pressure (a "gentle" or "rough" variant).
    """
    if body_map is None:
        body_map = BodyMap.default()
    rng = np.random.default_rng((seed, person_index, 0x4A4D))
    base = HandPerson.draw(person_index, rng)
    ctx = _context(body_map)
    touches, labels = [], []
    t = float(lead_in_s)
    for name, scale in trials:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f'amplitude scale must be a positive number; got {scale}')
        person = HandPerson(**{**base.__dict__, 'pressure': base.pressure * scale})
        kind, label = split_label(name)
        if kind == 'symbolic':
            if label not in PERFORMANCES:
                raise ValueError(f'unknown gesture {label!r}; known: {", ".join(PERFORMANCES)}')
            new, touched, end = _gesture(person, label, t, rng, body_map, ctx)
            touches += new
            labels.append(Label(t, end, 'symbolic', label, touched, person_index))
        else:
            if label not in TOUCH_SUBTYPES:
                raise ValueError(f'unknown subtype {label!r}; known: {", ".join(TOUCH_SUBTYPES)}')
            c = _touch(person, label, int(rng.choice([s.channel for s in body_map.sensors])), t, rng, ctx)
            touches.append(c)
            labels.append(Label(t, c.end_s, 'subtype', label, (body_map.by_channel(c.channel).name,), person_index))
            end = c.end_s
        t = end + float(rng.uniform(*pause_s))
    return HandScene(touches, labels, t + pause_s[1], body_map, seed * 1009 + person_index,
                     f'synthetic: hand-model person {person_index} (seed {seed})')


def make_hand_scene(n_people: int = 6, seed: int = 0, subtype_reps: int = 2, gesture_reps: int = 2,
                    pause_s: tuple[float, float] = (2.0, 5.0), body_map=None) -> HandScene:
    """``n_people`` hand-model people one after the other, each doing every subtype ``subtype_reps`` times
    and every gesture of :data:`~.people.PERFORMANCES` ``gesture_reps`` times, shuffled. Synthetic."""
    if n_people < 1:
        raise ValueError(f'n_people must be >= 1; got {n_people}')
    root = np.random.default_rng((seed, 0x4A4E))
    touches, labels = [], []
    t, starts = 4.0, []
    for p in range(n_people):
        starts.append(t if p else 0.0)
        plan = [(s, 1.0) for s in TOUCH_SUBTYPES for _ in range(subtype_reps)]
        plan += [(f'symbolic/{g}', 1.0) for g in PERFORMANCES for _ in range(gesture_reps)]
        plan = [plan[i] for i in root.permutation(len(plan))]
        one = hand_trial_scene(p, plan, seed=seed, lead_in_s=t, pause_s=pause_s, body_map=body_map)
        touches += one.touches
        labels += one.labels
        t = one.duration_s
    if body_map is None:
        body_map = BodyMap.default()
    return HandScene(touches, labels, t, body_map, seed, f'synthetic: {n_people} hand-model people (seed {seed})',
                     sessions=tuple(starts))
