"""Simulated people touching the textile patch: stroke, tickle, push, slap (SYNTHETIC data).

A :class:`PatchScene` implements ``touch_sim.scenes.PatchStimulus``: ``pressure(t)`` is a (16, 16)
float32 map in N/cm^2 and ``panels(t)`` an (11,) float32 hand proximity per panel in [0, 1]. It
carries the ground truth (:class:`TouchEvent`, panel contacts). Everything is drawn from a seed at
construction. Sessions follow sympartner2018 6.3: one class per session, at least 4 s between
events; :func:`demo_scene` mixes classes.

The hand is a set of *tracks*: contact patches with a position (row, col cells), a radius (cm) and
a normal force (N) on a 200 Hz grid. A cell (pitch 1.75 cm) sees ``p0 (1 - d^2/a_eff^2)`` with
``a_eff^2 = a^2 + (pitch/2)^2`` and p0 set so the force is kept. Gestures:

- **stroke**: two to four finger pads or the palm sliding 6-14 cm at 8-25 cm/s, 2-8 N, one to
  three passes;
- **tickle**: two to four fingertips tapping and scratching 1-2 cm at 4-10 contacts/s, 0.4-2 N,
  for 1-3 s;
- **push**: palm or fist ramping to 10-40 N over 0.2-0.8 s, held 0.5-3 s; often a panel contact;
- **slap**: flat hand, peak 15-60 N within 20-50 ms, contact 80-250 ms, sometimes twice.

Each person (:class:`PersonStyle`) has their own place, hand size, force, speed, duration and
habits; every event varies around them, with a small tremor and force fluctuation.
"""

from __future__ import annotations

import bisect
import itertools
import math
from dataclasses import dataclass, field

import numpy as np

__all__ = ['GESTURES', 'PatchScene', 'PersonStyle', 'TouchEvent', 'demo_scene', 'make_people', 'people_scene',
           'simulate_people', 'simulate_session', 'trial_scene']

#: The four gesture classes of sympartner2018 6.3.
GESTURES: tuple[str, ...] = ('stroke', 'tickle', 'push', 'slap')
GRID = (16, 16)
N_PANELS = 11
#: Cell pitch of the matrix, cm (13 mm electrodes + 4-5 mm gap, sympartner2018 5.1).
CELL_PITCH_CM = 1.75
#: Time step of the contact tracks, s (finer than the 100 Hz scan).
TRACK_DT = 0.005
#: Panels beside the patch on the back (back_left, back_right in config/panels.yaml): a hand on
#: the patch comes near them without touching.
BACK_PANELS = (0, 1)
#: Panels a person grabs to move the robot: the sides and the compartment beneath the display,
#: "the first choice for grabbing the robot" (sympartner2018 4; side_*, compartment_* in config/panels.yaml).
GRAB_PANELS = (4, 5, 6, 7, 8)


@dataclass(frozen=True)
class PersonStyle:
    """How one simulated person touches (SYNTHETIC).

    Attributes:
        name: an identifier ("p3"), the "subject" of evaluation.
        centre: preferred place on the patch, (row, col) in cells.
        place_spread: how far events scatter around it, cells (standard deviation).
        hand: hand size factor (1 = average adult: palm radius 4 cm).
        force: force factor (1 = the middle of each gesture's range).
        speed: speed factor for strokes and tickles.
        duration: duration factor for strokes, tickles and pushes.
        stroke_angle: preferred stroke direction, rad (0 = along the columns).
        stroke_palm: strokes with the palm rather than finger pads.
        fingers: fingers used for tickling and stroking (2-4).
        tickle_rate: fingertip contacts per second while tickling.
        push_fist: pushes with the fist rather than the palm.
        double_slap: probability of a second slap.
    """

    name: str
    centre: tuple[float, float]
    place_spread: float
    hand: float
    force: float
    speed: float
    duration: float
    stroke_angle: float
    stroke_palm: bool
    fingers: int
    tickle_rate: float
    push_fist: bool
    double_slap: float


@dataclass(frozen=True)
class TouchEvent:
    """Ground truth of one gesture (SYNTHETIC): label and contact interval in scene seconds."""

    gesture: str
    onset_s: float
    offset_s: float
    person: str


@dataclass
class _Track:
    """A contact patch: 200 Hz samples of position (cells), force (N) and radius (cm) from t0."""

    t0: float
    rows: np.ndarray
    cols: np.ndarray
    force: np.ndarray
    radius: float

    @property
    def t1(self) -> float:
        return self.t0 + (len(self.force) - 1) * TRACK_DT


@dataclass
class _PanelHold:
    panel: int
    t0: float
    t1: float
    level: float


@dataclass
class PatchScene:
    """A scripted patch scene: tracks, panel holds and ground truth (SYNTHETIC).

    Implements ``touch_sim.scenes.PatchStimulus``.
    """

    duration_s: float
    events: list[TouchEvent] = field(default_factory=list)
    tracks: list[_Track] = field(default_factory=list)
    holds: list[_PanelHold] = field(default_factory=list)
    grid: tuple[int, int] = GRID
    synthetic: bool = True

    def __post_init__(self) -> None:
        self._index()

    def _index(self) -> None:
        self.tracks.sort(key=lambda tr: tr.t0)
        self._starts = [tr.t0 for tr in self.tracks]
        self._longest = max((tr.t1 - tr.t0 for tr in self.tracks), default=0.0)
        rows, cols = np.indices(self.grid, dtype=np.float64)
        self._rows, self._cols = rows, cols

    def pressure(self, t: float) -> np.ndarray:
        """(16, 16) float32 pressure per cell at scene time ``t`` s, N/cm^2 (>= 0)."""
        out = np.zeros(self.grid, dtype=np.float64)
        hi = bisect.bisect_right(self._starts, t)
        lo = bisect.bisect_left(self._starts, t - self._longest - TRACK_DT)
        half_pitch2 = (CELL_PITCH_CM / 2) ** 2
        for tr in self.tracks[lo:hi]:
            if not tr.t0 <= t <= tr.t1:
                continue
            x = (t - tr.t0) / TRACK_DT
            i = min(int(x), len(tr.force) - 2) if len(tr.force) > 1 else 0
            frac = x - i if len(tr.force) > 1 else 0.0
            j = min(i + 1, len(tr.force) - 1)
            force = tr.force[i] + frac * (tr.force[j] - tr.force[i])
            if force <= 0:
                continue
            row = tr.rows[i] + frac * (tr.rows[j] - tr.rows[i])
            col = tr.cols[i] + frac * (tr.cols[j] - tr.cols[i])
            a_eff2 = tr.radius ** 2 + half_pitch2                  # cm^2
            p0 = 2.0 * force / (math.pi * a_eff2)                  # paraboloid keeps the force
            d2 = ((self._rows - row) ** 2 + (self._cols - col) ** 2) * CELL_PITCH_CM ** 2
            out += p0 * np.clip(1.0 - d2 / a_eff2, 0.0, None)
        return out.astype(np.float32)

    def panels(self, t: float) -> np.ndarray:
        """(11,) float32 hand proximity per panel at ``t`` s, in [0, 1] (1 = full contact)."""
        out = np.zeros(N_PANELS, dtype=np.float32)
        for hold in self.holds:
            if hold.t0 <= t <= hold.t1:
                ramp = min(1.0, (t - hold.t0) / 0.1, (hold.t1 - t) / 0.1)  # 100 ms approach and leave
                out[hold.panel] = max(out[hold.panel], hold.level * ramp)
        return out

    def panel_contacts(self, level: float = 0.5) -> list[tuple[int, float, float]]:
        """Ground truth (panel, start s, end s) of holds whose proximity reaches ``level``."""
        return [(h.panel, h.t0, h.t1) for h in self.holds if h.level >= level]


# ---------------------------------------------------------------------- people
def make_people(n: int, seed: int = 0) -> list[PersonStyle]:
    """``n`` simulated people with their own styles, drawn from ``seed`` (SYNTHETIC)."""
    rng = np.random.default_rng(seed)
    people = []
    for i in range(n):
        people.append(PersonStyle(
            name=f'p{i + 1}',
            centre=(float(rng.uniform(5.0, 10.0)), float(rng.uniform(5.0, 10.0))),
            place_spread=float(rng.uniform(0.5, 2.0)),
            hand=float(rng.uniform(0.8, 1.2)),
            force=float(np.exp(rng.normal(0.0, 0.3))),
            speed=float(np.exp(rng.normal(0.0, 0.25))),
            duration=float(np.exp(rng.normal(0.0, 0.25))),
            stroke_angle=float(rng.uniform(-math.pi, math.pi)),
            stroke_palm=bool(rng.random() < 0.4),
            fingers=int(rng.integers(2, 5)),
            tickle_rate=float(rng.uniform(4.0, 10.0)),
            push_fist=bool(rng.random() < 0.3),
            double_slap=float(rng.uniform(0.0, 0.5)),
        ))
    return people


def _smooth_noise(rng: np.random.Generator, n: int, scale: float, corr_s: float = 0.3) -> np.ndarray:
    """(n,) low-pass Gaussian noise of std ~scale, correlation time corr_s (tremor, force wobble)."""
    alpha = TRACK_DT / corr_s
    noise = rng.normal(0.0, scale * math.sqrt(2 * alpha), n)
    start = rng.normal(0.0, scale) * (1 - alpha)
    keep = 1.0 - alpha
    if n < 1:
        return noise
    # x[0] = e[0] + start, x[i] = (1-alpha) x[i-1] + e[i]: the recursion in plain floats, no scipy in the driver
    out = itertools.accumulate(noise[1:].tolist(), lambda x, e: e + keep * x, initial=float(noise[0] + start))
    return np.fromiter(out, dtype=np.float64, count=n)


def _envelope(n: int, rise: int, fall: int) -> np.ndarray:
    """(n,) 0..1 envelope with raised-cosine rise and fall of the given sample counts."""
    env = np.ones(n)
    if rise > 0:
        env[:rise] = 0.5 - 0.5 * np.cos(np.linspace(0, math.pi, rise))
    if fall > 0:
        env[n - fall:] = np.minimum(env[n - fall:], 0.5 + 0.5 * np.cos(np.linspace(0, math.pi, fall)))
    return env


def _track(t0: float, rows: np.ndarray, cols: np.ndarray, force: np.ndarray, radius: float) -> _Track:
    return _Track(t0, rows.astype(np.float64), cols.astype(np.float64), np.maximum(force, 0.0), radius)


def _place(rng: np.random.Generator, person: PersonStyle) -> tuple[float, float]:
    r, c = person.centre
    return (float(np.clip(r + rng.normal(0, person.place_spread), 2, GRID[0] - 3)),
            float(np.clip(c + rng.normal(0, person.place_spread), 2, GRID[1] - 3)))


def _stroke(rng: np.random.Generator, person: PersonStyle, t0: float) -> tuple[list[_Track], float]:
    tracks: list[_Track] = []
    t = t0
    for _ in range(int(rng.integers(1, 4))):
        angle = person.stroke_angle + rng.normal(0, 0.25)
        length_cm = rng.uniform(6.0, 14.0) * person.duration ** 0.5
        speed_cm_s = rng.uniform(8.0, 25.0) * person.speed
        dur = length_cm / speed_cm_s
        n = max(int(dur / TRACK_DT), 4)
        r0, c0 = _place(rng, person)
        s = np.linspace(-0.5, 0.5, n) * length_cm / CELL_PITCH_CM
        rows = r0 + s * math.sin(angle) + _smooth_noise(rng, n, 0.1)
        cols = c0 + s * math.cos(angle) + _smooth_noise(rng, n, 0.1)
        force = rng.uniform(2.0, 8.0) * person.force * _envelope(n, n // 6, n // 6) * (1 + _smooth_noise(rng, n, 0.1))
        if person.stroke_palm:
            tracks.append(_track(t, rows, cols, force, 4.0 * person.hand))
        else:
            k = person.fingers
            for f in range(k):  # finger pads side by side, across the motion
                off = (f - (k - 1) / 2) * 1.1 * person.hand
                tracks.append(_track(t, rows + off * math.cos(angle), cols - off * math.sin(angle),
                                     force / k, 0.8 * person.hand))
        t += dur + rng.uniform(0.2, 0.6)  # lift and return
    return tracks, t


def _tickle(rng: np.random.Generator, person: PersonStyle, t0: float) -> tuple[list[_Track], float]:
    total = rng.uniform(1.0, 3.0) * person.duration
    rate = person.tickle_rate * rng.uniform(0.8, 1.25) * person.speed
    r0, c0 = _place(rng, person)
    drift = rng.normal(0, 1.0, 2)  # cells per second
    tracks = []
    t, f = t0, 0
    while t < t0 + total:
        dur = rng.uniform(0.05, 0.2)
        n = max(int(dur / TRACK_DT), 3)
        finger_off = (f % person.fingers - (person.fingers - 1) / 2) * 1.0 * person.hand
        scratch = rng.uniform(0.5, 1.2) * rng.choice([-1, 1])  # cells, along the hand
        s = np.linspace(0, scratch, n)
        base_r = r0 + drift[0] * (t - t0) + rng.normal(0, 0.4)
        base_c = c0 + drift[1] * (t - t0) + finger_off + rng.normal(0, 0.4)
        force = rng.uniform(0.4, 2.0) * person.force * _envelope(n, n // 3, n // 3)
        tracks.append(_track(t, base_r + s, base_c + 0 * s, force, 0.5 * person.hand))
        t += 1.0 / rate
        f += 1
    return tracks, t


def _push(rng: np.random.Generator, person: PersonStyle, t0: float) -> tuple[list[_Track], float]:
    rise, hold, fall = rng.uniform(0.2, 0.8), rng.uniform(0.5, 3.0) * person.duration, rng.uniform(0.2, 0.5)
    n = int((rise + hold + fall) / TRACK_DT)
    r0, c0 = _place(rng, person)
    drift = rng.normal(0, 0.3, 2) * np.linspace(0, rise + hold + fall, n)[:, None]
    force = rng.uniform(10.0, 40.0) * person.force * _envelope(n, int(rise / TRACK_DT), int(fall / TRACK_DT))
    force *= 1 + _smooth_noise(rng, n, 0.08)
    radius = (2.5 if person.push_fist else 4.0) * person.hand
    rows = r0 + drift[:, 0] + _smooth_noise(rng, n, 0.05)
    cols = c0 + drift[:, 1] + _smooth_noise(rng, n, 0.05)
    return [_track(t0, rows, cols, force, radius)], t0 + n * TRACK_DT


def _slap(rng: np.random.Generator, person: PersonStyle, t0: float) -> tuple[list[_Track], float]:
    tracks = []
    t = t0
    for i in range(2 if rng.random() < person.double_slap else 1):
        rise, contact = rng.uniform(0.02, 0.05), rng.uniform(0.08, 0.25)
        n = int(contact / TRACK_DT)
        r0, c0 = _place(rng, person)
        force = rng.uniform(15.0, 60.0) * person.force * _envelope(n, int(rise / TRACK_DT), n - int(rise / TRACK_DT))
        tracks.append(_track(t, np.full(n, r0), np.full(n, c0), force, rng.uniform(3.5, 5.0) * person.hand))
        t += contact
        if i == 0:
            t += rng.uniform(0.3, 0.7)
    return tracks, t


_MAKERS = {'stroke': _stroke, 'tickle': _tickle, 'push': _push, 'slap': _slap}


def _add_event(scene_tracks: list[_Track], holds: list[_PanelHold], events: list[TouchEvent],
               rng: np.random.Generator, person: PersonStyle, gesture: str, t0: float) -> float:
    tracks, _ = _MAKERS[gesture](rng, person, t0)
    onset = min(tr.t0 for tr in tracks)
    offset = max(tr.t1 for tr in tracks)
    scene_tracks.extend(tracks)
    events.append(TouchEvent(gesture, onset, offset, person.name))
    # The hand on the patch comes near a back panel (proximity well below contact) ...
    holds.append(_PanelHold(int(rng.choice(BACK_PANELS)), onset, offset, float(rng.uniform(0.05, 0.15))))
    # ... and while pushing the robot into place the other hand often grabs the shell.
    if gesture == 'push' and rng.random() < 0.7:
        holds.append(_PanelHold(int(rng.choice(GRAB_PANELS)), onset - rng.uniform(0.2, 1.0),
                                offset + rng.uniform(0.0, 1.0), float(rng.uniform(0.7, 1.0))))
    return offset


def simulate_session(person: PersonStyle, gesture: str, n_events: int = 6, seed: int = 0,
                     lead_s: tuple[float, float] = (2.0, 4.0), pause_s: tuple[float, float] = (4.0, 8.0)) -> PatchScene:
    """One recording session: ``n_events`` gestures of one class with pauses (SYNTHETIC).

    Args:
        person: who touches. gesture: one of :data:`GESTURES`.
        n_events: gestures in the session.
        seed: randomness of this session.
        lead_s: silence before the first event, s (range).
        pause_s: silence between the end of one event and the start of the next, s (range);
            at least 4 s, as in the paper's recordings (sympartner2018 6.3).
    """
    if gesture not in _MAKERS:
        raise ValueError(f"unknown gesture '{gesture}'; expected one of {', '.join(GESTURES)}")
    if pause_s[0] < 4.0:
        raise ValueError(f'pauses must be at least 4 s as in the paper recordings; got {pause_s}')
    rng = np.random.default_rng(seed)
    tracks: list[_Track] = []
    holds: list[_PanelHold] = []
    events: list[TouchEvent] = []
    t = rng.uniform(*lead_s)
    for _ in range(n_events):
        t = _add_event(tracks, holds, events, rng, person, gesture, t) + rng.uniform(*pause_s)
    return PatchScene(duration_s=t, events=events, tracks=tracks, holds=holds)


def simulate_people(n_people: int = 8, events_per_session: int = 6, seed: int = 0,
                    gestures: tuple[str, ...] = GESTURES) -> list[tuple[PersonStyle, str, PatchScene]]:
    """One session per person and gesture, as the paper's data set (SYNTHETIC).

    The defaults (8 people x 4 gestures x 6 events = 192 events) match the size of the
    paper's set (8 persons, 200 events, sympartner2018 6.3).

    Returns:
        (person, gesture, scene) triples, people in order.
    """
    people = make_people(n_people, seed)
    out = []
    for i, person in enumerate(people):
        for j, gesture in enumerate(gestures):
            out.append((person, gesture, simulate_session(person, gesture, events_per_session,
                                                          seed=seed * 1_000_003 + i * 101 + j + 1)))
    return out


def demo_scene(seed: int = 0, n_events: int = 12, person: PersonStyle | None = None) -> PatchScene:
    """A mixed scene for the demo: gestures of all classes in random order, and grabs (SYNTHETIC).

    Between gestures someone sometimes grabs the robot without touching the patch (a panel
    contact only), the "being handled" signal a driving robot stops on.
    """
    rng = np.random.default_rng(seed)
    person = person or make_people(1, seed)[0]
    tracks: list[_Track] = []
    holds: list[_PanelHold] = []
    events: list[TouchEvent] = []
    t = rng.uniform(2.0, 3.0)
    for _ in range(n_events):
        gesture = str(rng.choice(GESTURES))
        t = _add_event(tracks, holds, events, rng, person, gesture, t) + rng.uniform(4.0, 6.0)
        if rng.random() < 0.25:
            grab = rng.uniform(0.5, 2.0)
            holds.append(_PanelHold(int(rng.choice(GRAB_PANELS)), t, t + grab, float(rng.uniform(0.8, 1.0))))
            t += grab + 2.0
    return PatchScene(duration_s=t, events=events, tracks=tracks, holds=holds)


def people_scene(n_people: int = 2, seed: int = 0, gestures: tuple[str, ...] = GESTURES, events_per_gesture: int = 1,
                 order: str = 'shuffled', pause_s: tuple[float, float] = (4.0, 6.0), lead_s: float = 3.0,
                 grab_prob: float = 0.25, grab_s: tuple[float, float] = (0.5, 2.0)) -> PatchScene:
    """Simulated people taking turns at the patch, for a launch file's scene (SYNTHETIC).

    A ``generator`` of ``touch_sim.scenes`` (``config/scenes/patch_people.yaml``): each of
    ``n_people`` performs every gesture of ``gestures`` ``events_per_gesture`` times, then the
    next person comes. After a gesture someone sometimes grabs the robot's shell without
    touching the patch (a panel contact only, "being handled").

    Args:
        n_people: people, one after the other (styles from :func:`make_people` with ``seed``).
        seed: makes the scene reproducible.
        gestures: classes each person performs (of :data:`GESTURES`).
        events_per_gesture: repetitions of each class per person.
        order: ``'shuffled'`` (each person's gestures in random order) or ``'sessions'`` (one class
            after the other, in the order given, as the paper's recordings, sympartner2018 6.3).
        pause_s: (min, max) seconds from the end of one gesture to the next; pauses shorter than
            the recogniser's 3 s window let a gesture share a window with the one before.
        lead_s: untouched seconds at the start (the driver's calibrator starts its minima there).
        grab_prob: probability of a grab after a gesture, in [0, 1].
        grab_s: (min, max) duration of a grab, s.

    Raises:
        ValueError: for an unknown gesture or order, or a negative or inverted range.
    """
    unknown = [g for g in gestures if g not in _MAKERS]
    if unknown or not gestures:
        raise ValueError(f"gestures must be some of {', '.join(GESTURES)}; got {list(gestures)}")
    if order not in ('shuffled', 'sessions'):
        raise ValueError(f"order must be 'shuffled' or 'sessions'; got {order!r}")
    if int(n_people) != n_people or n_people < 1 or int(events_per_gesture) != events_per_gesture \
            or events_per_gesture < 1:
        raise ValueError(f'n_people and events_per_gesture must be integers >= 1; got {n_people}, '
                         f'{events_per_gesture}')
    for name, pair in (('pause_s', pause_s), ('grab_s', grab_s)):
        if len(pair) != 2 or not 0 <= pair[0] <= pair[1] or not math.isfinite(pair[1]):
            raise ValueError(f'{name} must be (min, max) seconds with 0 <= min <= max; got {pair}')
    if not 0 <= lead_s < math.inf or not 0 <= grab_prob <= 1:
        raise ValueError(f'lead_s must be >= 0 s and grab_prob in [0, 1]; got {lead_s}, {grab_prob}')
    rng = np.random.default_rng((seed, 0x9E0))
    tracks: list[_Track] = []
    holds: list[_PanelHold] = []
    events: list[TouchEvent] = []
    t = float(lead_s)
    for person in make_people(int(n_people), seed):
        todo = [g for g in gestures for _ in range(int(events_per_gesture))]
        if order == 'shuffled':
            todo = [todo[i] for i in rng.permutation(len(todo))]
        for gesture in todo:
            t = _add_event(tracks, holds, events, rng, person, gesture, t) + rng.uniform(*pause_s)
            if rng.random() < grab_prob:
                grab = rng.uniform(*grab_s)
                holds.append(_PanelHold(int(rng.choice(GRAB_PANELS)), t, t + grab, float(rng.uniform(0.8, 1.0))))
                t += grab + rng.uniform(*pause_s) / 2
    return PatchScene(duration_s=t, events=events, tracks=tracks, holds=holds)


def trial_scene(person: PersonStyle, trials: list[tuple[str, float]], seed: int = 0, lead_s: float = 3.0,
                pause_s: tuple[float, float] = (4.0, 6.0)) -> PatchScene:
    """One person's recording session (``social-touch collect patch --simulate``), SYNTHETIC.

    Args:
        person: who touches.
        trials: ``(gesture, force_scale)`` in the order the protocol prompts them; ``force_scale``
            multiplies the person's force for the trial (a "gentle" or "rough" variant, as in CoST).
        seed: randomness of this session.
        lead_s: untouched seconds first (the driver's minima start there).
        pause_s: (min, max) seconds from the end of one gesture to the next.

    Returns: the scene; its ``events`` are the trials' contact intervals, in order.
    """
    unknown = sorted({g for g, _ in trials} - set(_MAKERS))
    if unknown:
        raise ValueError(f"unknown gestures {unknown}; expected some of {', '.join(GESTURES)}")
    rng = np.random.default_rng((seed, 0x7A1))
    tracks: list[_Track] = []
    holds: list[_PanelHold] = []
    events: list[TouchEvent] = []
    t = float(lead_s)
    for gesture, scale in trials:
        if not (math.isfinite(scale) and scale > 0):
            raise ValueError(f'force scale must be a positive number; got {scale}')
        first = len(tracks)
        t = _add_event(tracks, holds, events, rng, person, gesture, t)
        for track in tracks[first:]:
            track.force = track.force * scale
        t += rng.uniform(*pause_s)
    return PatchScene(duration_s=t, events=events, tracks=tracks, holds=holds)
