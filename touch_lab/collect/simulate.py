"""``social-touch collect SENSOR --simulate N``: the session protocol performed by simulated people (SYNTHETIC).

Each simulated person performs the protocol's shuffled trials on a virtual device
(``bearsim://``, ``patchsim://``, ``skinsim://``) read by the sensor's real driver node in the
:class:`~touch_sim.harness.Harness` (simulated time, as fast as the work allows); what the driver
publishes is recorded with the trials' labels into one session bag per person, exactly as a live
session records it. A label's start and end are the true contact interval of the trial.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from touch_sim.bear.people import trial_scene
from touch_sim.bear.render import url_options
from touch_sim.harness import DeviceRun, stamp_ns, wire_frames_before
from touch_sim.patch import people as patch_people
from touch_sim.skin.people import traced_scene
from touch_sim.skin.synthetic import synthetic_traces

from .protocol import Protocol, Trial
from .session_bag import SENSOR_TOPICS, SessionWriter

__all__ = ['SimulatedSession', 'person_name', 'simulate_session']

_NS = 1_000_000_000


def person_name(index: int) -> str:
    """The name of simulated person ``index`` (from 0): ``'p01'``, ``'p02'``, ..."""
    return f'p{index + 1:02d}'


@dataclass(frozen=True)
class SimulatedSession:
    """A simulated person's session: what the device plays and the trials' labels.

    Attributes:
        stimulus: the scene the virtual device plays (scene seconds from 0).
        labels: ``(trial, start_s, end_s)`` per trial, scene seconds.
        duration_s: scene length, s.
    """

    stimulus: Any
    labels: list[tuple[Trial, float, float]]
    duration_s: float


def _bear(index: int, n_people: int, trials: list[Trial], protocol: Protocol, seed: int) -> SimulatedSession:
    scene = trial_scene(index, [(t.gesture, protocol.scale(t.variant)) for t in trials], seed=seed,
                        pause_s=(protocol.pause_s / 2, protocol.pause_s))
    return SimulatedSession(scene, [(t, lab.start_s, lab.end_s) for t, lab in zip(trials, scene.labels, strict=True)],
                            scene.duration_s)


def _patch(index: int, n_people: int, trials: list[Trial], protocol: Protocol, seed: int) -> SimulatedSession:
    person = patch_people.make_people(n_people, seed)[index]
    # The paper's recordings pause at least 4 s between gestures (sympartner2018 6.3).
    pause = max(4.0, protocol.pause_s)
    scene = patch_people.trial_scene(person, [(t.gesture, protocol.scale(t.variant)) for t in trials],
                        seed=seed * 1009 + index, pause_s=(pause, pause + 2.0))
    return SimulatedSession(scene, [(t, e.onset_s, e.offset_s) for t, e in zip(trials, scene.events, strict=True)],
                            scene.duration_s)


def _skin(index: int, n_people: int, trials: list[Trial], protocol: Protocol, seed: int) -> SimulatedSession:
    samples = {}
    for variant in protocol.variants:   # the variant scales the tracing speed (slow / normal / fast)
        for s in synthetic_traces(list(protocol.gestures), performers=n_people, repetitions=protocol.repetitions,
                                  seed=seed, speed=protocol.scale(variant)):
            if s.subject == f'synthetic{index}':
                samples[(s.gesture, variant, int(s.sample))] = s
    reps = sorted({k[2] for k in samples})
    chosen = [samples[(t.gesture, t.variant, reps[t.repetition - 1])] for t in trials]
    scene = traced_scene(chosen, lead_s=2.0, pause_s=(protocol.pause_s / 2, protocol.pause_s), seed=seed + index)
    return SimulatedSession(scene, [(t, e.start_s, e.end_s) for t, e in zip(trials, scene.events, strict=True)],
                            scene.duration_s)


_SCENES: dict[str, Callable[..., SimulatedSession]] = {'bear': _bear, 'patch': _patch, 'skin': _skin}


def simulate_session(sensor: str, protocol: Protocol, index: int, n_people: int, out: str | Path, seed: int = 0,
                     device_options: dict[str, str] | None = None,
                     progress: Callable[[str], None] | None = None) -> Path:
    """Record simulated person ``index`` of ``n_people`` performing ``protocol`` to the bag ``out``.

    Args:
        sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
        protocol: the session protocol (its seed is mixed with the person's, so orders differ).
        index: the person, from 0 (named :func:`person_name`).
        n_people: people of the simulated population (styles are drawn for all of them).
        out: the bag directory to create.
        seed: the population's seed.
        device_options: more URL options of the virtual device (``rate`` for the bear, noise, ...).
        progress: called with a line of text per phase.

    Returns: the bag path.
    """
    say = progress or (lambda _m: None)
    own = Protocol(protocol.gestures, protocol.variants, protocol.repetitions, protocol.pause_s,
                   seed=protocol.seed * 7919 + index)
    trials = own.trials()
    session = _SCENES[sensor](index, n_people, trials, own, seed)
    name = person_name(index)
    say(f'{name}: {len(trials)} trials, {session.duration_s:.0f} s of simulated session (SYNTHETIC)')
    options = dict(device_options or {})
    driver_parameters: dict[str, Any] = {}
    if sensor == 'bear':
        rate = float(options.pop('rate', 3.4))
        options = {**url_options(rate, {'scan': 'sequential' if rate <= 3.57 else 'parallel'}), **options}
        driver_parameters['expected_rate_hz'] = rate
    run = DeviceRun(sensor, session.stimulus, seed=seed * 31 + index, url_options=options,
                    driver_parameters=driver_parameters)
    topics = [(topic, type_name.rsplit('/', 1)[1]) for topic, type_name in SENSOR_TOPICS[sensor].items()]
    origin_ns = None
    last_ns = 0
    with SessionWriter(out, sensor, synthetic=True, flush_period_s=None) as writer:
        for topic, msg, t in run.messages(wire_frames_before(session.duration_s), topics):
            ns = stamp_ns(msg)
            if origin_ns is None:
                origin_ns = ns - round(t * _NS)  # scene second 0 in ROS time
            writer.write(topic, msg, ns)
            last_ns = max(last_ns, ns)
        if origin_ns is None:
            raise RuntimeError(f'the {sensor} driver published nothing for {name}: {run.counters}')
        for trial, start_s, end_s in session.labels:
            end_ns = min(origin_ns + round(end_s * _NS), last_ns)
            writer.label(name, trial.gesture, trial.variant, origin_ns + round(start_s * _NS), end_ns, end_ns)
    say(f'{name}: wrote {out} ({writer.labels} labels)')
    return Path(out)
