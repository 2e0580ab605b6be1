"""``social-touch bench training``: how long training on an hour of sessions takes, per sensor (SYNTHETIC data).

Two simulated people record a session each; their bags are listed again until they hold an hour of
frames, and the whole path of ``train SENSOR --bags`` runs on the list (reading, features, fitting).
``bear+symbolic`` adds the symbolic gestures and their suggested settings. Run it on one core::

    OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1 taskset -c 0 social-touch bench training --repeats 1
"""

from __future__ import annotations

import contextlib
import io
import math
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from touch_gestures.bear.symbolic import GestureLibrary
from touch_gestures.patch.features import window_features
from touch_lab.bear.sessions import fit_model, load_runs
from touch_lab.cli.main import main as cli_main
from touch_lab.collect.coverage import read_checked
from touch_lab.collect.protocol import DEFAULT_GESTURES, Protocol
from touch_lab.collect.session_bag import read_session
from touch_lab.collect.simulate import simulate_session
from touch_lab.patch.session_bags import trial_sessions
from touch_lab.patch.training import PatchGestureClassifier
from touch_lab.skin.sessions import fit_codebook, load_trials
from touch_sim.bear.people import symbolic_label

__all__ = ['bench_training']

HOUR_S = 3600.0


def _say(msg: str) -> None:
    print(f'[bench training] {msg}', file=sys.stderr, flush=True)


def _train_patch(bags: list[str]) -> None:
    sessions = trial_sessions(read_checked(bags, 'patch', lambda _m: None))
    window = round(3.0 * sessions[0].rate_hz)
    X = np.concatenate([window_features(s.activations, window) for s in sessions])
    y = np.concatenate([[s.gesture] * s.n_frames for s in sessions])
    PatchGestureClassifier(n_components=5).fit(X, y)


def _train_bear(bags: list[str]) -> None:
    fit_model(load_runs(bags, 3.4, 20, lambda _m: None), drop_thin=lambda _m: None)


def _train_skin(bags: list[str]) -> None:
    fit_codebook(load_trials(bags, lambda _m: None)[0], 'trace')


def _train_bear_symbolic(bags: list[str]) -> None:
    with tempfile.TemporaryDirectory(prefix='bench-training-model-') as out, \
            contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        code = cli_main(['train', 'bear', '--bags', *bags, '--output', str(Path(out) / 'bear.npz')])
    if code != 0:
        raise RuntimeError(f'train bear --bags failed with exit code {code}')


def _protocol_gestures(sensor: str) -> tuple[str, ...]:
    if sensor in ('patch', 'skin'):
        return tuple(DEFAULT_GESTURES[sensor])
    # At 3.4 Hz the bear misses most taps (docs/learning.md): a session of them would not train.
    subtypes = tuple(g for g in DEFAULT_GESTURES['bear'] if g != 'tap')
    if sensor == 'bear':
        return subtypes
    return subtypes + tuple(symbolic_label(g.name) for g in GestureLibrary.default().detectable)


_TRAIN = {'bear': _train_bear, 'bear+symbolic': _train_bear_symbolic, 'patch': _train_patch, 'skin': _train_skin}


def bench_training(repeats: int = 1, sensors: tuple[str, ...] = ('bear', 'bear+symbolic', 'patch', 'skin')) -> dict:
    """Median seconds (wall and CPU) to train on an hour of session bags, per sensor (module doc)."""
    out: dict = {'synthetic': True, 'hour_of_frames_s': HOUR_S}
    with tempfile.TemporaryDirectory(prefix='bench-training-') as tmp:
        for sensor in sensors:
            device = sensor.split('+')[0]
            protocol = Protocol(_protocol_gestures(sensor), repetitions=3, pause_s=2.0)
            bags = [str(simulate_session(device, protocol, i, 2, Path(tmp) / f'{sensor}_{i}', progress=_say))
                    for i in range(2)]
            seconds = sum(read_session(b, device).duration_s for b in bags)
            hour = bags * math.ceil(HOUR_S / seconds)
            times, cpu = [], []
            for r in range(repeats):
                _say(f'{sensor}: training on {len(hour)} session bags ({len(hour) * seconds / len(bags) / 60:.0f} '
                     f'min of frames), run {r + 1}/{repeats}')
                t0, c0 = time.perf_counter(), time.process_time()
                _TRAIN[sensor](hour)
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)   # what the work took of the CPU, on a shared machine too
            out[sensor] = {'train_s': statistics.median(times), 'cpu_s': statistics.median(cpu), 'bags': len(hour),
                           'minutes_of_frames': len(hour) * seconds / len(bags) / 60, 'runs': repeats}
            _say(f'{sensor}: {out[sensor]["train_s"]:.1f} s wall, {out[sensor]["cpu_s"]:.1f} s CPU')
    return out
