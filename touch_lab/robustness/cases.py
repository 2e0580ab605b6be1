"""Bad input tried as a new user and a broken robot would, each classified by what the stack did.

A case is a callable or a CLI argv; its outcome (:mod:`.outcomes`): ``clear error`` (a
``SocialTouchError`` or a ``ValueError`` naming what is wrong; a command exiting non-zero without a
traceback), ``handled`` (it returned and its check held), ``traceback`` (any other exception),
``crash`` (killed by a signal), ``wrong`` (it returned but its check failed). ``social-touch report
robustness`` runs :func:`all_cases`; ``test/test_robustness_*.py`` check the same behaviours one by one.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import threading
import traceback
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from touch_driver.bear.body_map import BodyMap
from touch_driver.bear.protocol import encode_scan
from touch_driver.skin.node import SkinDriverNode
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.patch.model_io import load_model
from touch_gestures.skin.codebook import load_codebook
from touch_graph.errors import SocialTouchError
from touch_graph.launch.safe_eval import safe_eval
from touch_graph.messages import get_message
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.bear.subtype_training import SubtypeClassifier
from touch_lab.robustness import pty_run as p
from touch_sim.harness import Harness, node_class

from .cases_input import input_cases
from .cases_stray import stray_cases
from .cases_web import web_cases
from .outcomes import CASE_TIMEOUT_S, CLEAR, CRASH, HANDLED, HANG, LOST, TRACEBACK, WRONG, DataLost

__all__ = ['CLEAR', 'CRASH', 'HANDLED', 'HANG', 'LOST', 'TRACEBACK', 'WRONG', 'DataLost', 'Outcome', 'all_cases',
           'run_case', 'run_cli']


class _Hung(BaseException):
    """A case that ran past its time (a BaseException: the case's own ``except Exception`` lets it pass)."""


def _hung(signum: int, frame: Any) -> None:
    raise _Hung


@dataclass
class Outcome:
    """What one case did."""

    area: str
    case: str
    result: str
    detail: str


def run_case(area: str, case: str, fn: Callable[[], Any], timeout_s: float = CASE_TIMEOUT_S) -> Outcome:
    """Run ``fn``; a return of False is ``wrong``, any other return ``handled``; exceptions are classified
    (:class:`DataLost`: ``data lost``); not done in ``timeout_s``: ``hang`` (timed by SIGALRM in the main
    thread, where the cases run: some start nodes that install signal handlers, which only it may do)."""
    timed = threading.current_thread() is threading.main_thread()
    if timed:
        previous = signal.signal(signal.SIGALRM, _hung)
        signal.setitimer(signal.ITIMER_REAL, timeout_s)
    try:
        ok = fn()
    except _Hung:
        return Outcome(area, case, HANG, f'not done after {timeout_s:g} s')
    except DataLost as err:
        return Outcome(area, case, LOST, str(err).splitlines()[0][:200])
    except (SocialTouchError, ValueError) as err:
        return Outcome(area, case, CLEAR, f'{type(err).__name__}: {err}'.splitlines()[0][:200])
    except Exception as err:  # the point of the report: any other exception is a traceback a user would see
        return Outcome(area, case, TRACEBACK, ''.join(traceback.format_exception_only(err)).strip()[:200])
    finally:
        if timed:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
    if ok is False:
        return Outcome(area, case, WRONG, 'returned, but the check on what it did failed')
    return Outcome(area, case, HANDLED, str(ok)[:200] if ok not in (None, True) else 'counted or kept going')


def run_cli(area: str, case: str, argv: list[str], timeout_s: float = 120.0) -> Outcome:
    """``social-touch ARGV`` in a fresh process in an empty directory; classified by exit and stderr."""
    with tempfile.TemporaryDirectory() as cwd:
        try:
            run = subprocess.run([sys.executable, '-c', 'from touch_lab.cli.main import main; raise SystemExit(main())',
                                  *argv], capture_output=True, text=True, timeout=timeout_s, cwd=cwd)
        except subprocess.TimeoutExpired:
            return Outcome(area, case, HANG, f'no exit after {timeout_s:g} s (killed)')
    last = (run.stderr.strip().splitlines() or [''])[-1][:200]
    if run.returncode < 0:
        return Outcome(area, case, CRASH, f'died of signal {-run.returncode}')
    if 'Traceback' in run.stderr:
        return Outcome(area, case, TRACEBACK, last)
    if run.returncode != 0:
        return Outcome(area, case, CLEAR, f'exit {run.returncode}: {last}')
    return Outcome(area, case, WRONG, 'exit 0: accepted')


# ---------------------------------------------------------------------- the cases
def _driver(sensor: str, parameters: dict) -> Callable[[], Any]:
    def start() -> Any:
        with Harness() as harness:
            node = harness.add_node(node_class(f'{sensor}_driver'), namespace=sensor, parameters=parameters)
            return f'started, port {"open" if node.driver.is_open else "absent: reconnect loop"}'
    return start


DRIVER_PARAMETERS = [
    ('bear', {'poll_rate_hz': -5.0}), ('bear', {'expected_rate_hz': float('nan')}), ('bear', {'status_period_s': 0.0}),
    ('bear', {'reconnect_period_s': 0.0}), ('bear', {'port': ''}), ('bear', {'threshold': 1.5}),
    ('bear', {'baseline_frames': 0}), ('patch', {'tau': -0.5}), ('patch', {'k': 2.0}), ('patch', {'decimation': 0}),
    ('patch', {'average_window': 0}), ('patch', {'gain': 0.0}), ('skin', {'baudrate': -9600}),
    ('skin', {'warn_error_fraction': 0.5, 'error_error_fraction': 0.1}),
]
PORTS = [('skin', 'foo://x'), ('skin', 'skinsim://x?nosie=3'), ('skin', 'bearsim://bear'), ('bear', 'skinsim://skin'),
         ('patch', 'patchsim://p?rate=abc'), ('bear', 'bearsim://b?seed=1.5')]

_PANELS = '\n'.join(f'  - {{name: p{i}}}' for i in range(11))
PANEL_FILES = {
    'negative threshold': f'threshold: -40.0\npanels:\n{_PANELS}\n',
    'release_fraction: 1.5': f'release_fraction: 1.5\npanels:\n{_PANELS}\n',
    'window_s: 0': f'window_s: 0\npanels:\n{_PANELS}\n',
    '12 panels': f'panels:\n{_PANELS}\n  - {{name: p11}}\n',
    'a panel with threshold -1': f'panels:\n{_PANELS.replace("{name: p3}", "{name: p3, threshold: -1}")}\n',
    'a typo (treshold)': f'treshold: 40\npanels:\n{_PANELS}\n',
    'empty file': '',
}


def _panels_file(text: str) -> Callable[[], Any]:
    def start() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / 'panels.yaml'
            path.write_text(text)
            return _driver('patch', {'panels': str(path)})()
    return start


def _bear_model(damage: str) -> Callable[[], Any]:
    def load() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / 'model.npz'
            rng = np.random.default_rng(0)
            X = rng.random((40, 12), dtype=np.float32)
            SubtypeClassifier().fit(X, np.where(X[:, 0] < 0.5, 'none', 'hold')).save(path, rate_hz=3.4,
                                                                                      buffer_len=20)
            data = path.read_bytes()
            if damage == 'empty':
                path.write_bytes(b'')
            elif damage == 'truncated':
                path.write_bytes(data[:len(data) // 2])
            else:
                with np.load(path, allow_pickle=False) as z:
                    arrays = {k: z[k] for k in z.files}
                arrays[damage] = np.full_like(arrays[damage], np.nan)
                np.savez(path, **arrays)
            SubtypeClassifier.load(path)
            return False                # loading a damaged model is wrong
    return load


def _codebook(damage: str) -> Callable[[], Any]:
    def load() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / 'codebook.npz'
            np.savez(path, format=np.array('x'), data=np.arange(1000))
            data = path.read_bytes()
            path.write_bytes(b'' if damage == 'empty' else data[:len(data) // 2])
            load_codebook(path)
            return False
    return load


def _patch_model(damage: str) -> Callable[[], Any]:
    def load() -> Any:
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / 'model.npz'
            path.write_bytes(b'' if damage == 'empty' else b'PK\x03\x04' + os.urandom(200))
            load_model(path)
            return False
    return load


BEAR_RATE_HZ = 3.4
BEAR_EPOCH_S = 1_700_000_000


def _feed_levels(level: float, seconds: float = 2.0, channel: int = 5) -> tuple[int, int]:
    """``level`` on ``channel`` for ``seconds`` of bear frames at 3.4 Hz, between two quiet frames.
    Returns (frames the node skipped, /touch/subtype and /touch/symbolic messages it published)."""
    BearFrame = get_message('BearFrame')
    Header = get_message('std_msgs/msg/Header')
    Time = get_message('builtin_interfaces/msg/Time')
    fitted = BodyMap.default().fitted_mask().tolist()  # bool[64]: Python bools, as rclpy needs
    ctx = Context('sim')
    ctx.init()
    try:
        node = BearGesturesNode(context=ctx, namespace='bear',
                                parameter_overrides=[Parameter('subtype_classifier', value='rule')])
        feeder = Node('feeder', context=ctx)
        pub = feeder.create_publisher(BearFrame, '/bear/frame', 100)
        events: list = []
        for topic, kind in (('subtype', 'TouchSubtype'), ('symbolic', 'SymbolicGesture')):
            feeder.create_subscription(get_message(kind), f'/touch/{topic}', events.append, 1000)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.add_node(feeder)
        n = int(seconds * BEAR_RATE_HZ) + 2
        for i in range(n):
            levels = np.zeros(64, np.float32)
            if 0 < i < n - 1:
                levels[channel] = level
            ns = round(i / BEAR_RATE_HZ * 1e9)
            header = Header(stamp=Time(sec=BEAR_EPOCH_S + ns // 10**9, nanosec=ns % 10**9), frame_id='bear_link')
            pub.publish(BearFrame(header=header, sequence=i, level=levels, active=(levels >= 0.3).tolist(),
                                  fitted=fitted, faults=np.zeros(64, np.uint8)))
            executor.spin_for(0.0)
        skipped = sum(node.skipped.values())
        node.destroy_node()
    finally:
        ctx.shutdown()
    return skipped, len(events)


def _bear_level(level: float) -> Callable[[], Any]:
    def feed() -> Any:
        skipped, events = _feed_levels(level)
        return f'{skipped} frames skipped as out of range, {events} events' if events == 0 and skipped else False
    return feed


def _pty(kind: str) -> Callable[[], Any]:
    """A bear driver on a real pty fed one kind of faulty stream; the check is what its diagnostics say."""
    def run() -> Any:
        good = [encode_scan(i, p.RAW) for i in range(40)]
        node_class = p.FailingBearDriver if kind == 'handler raises' else p.BearDriverNode
        wire = {
            'garbage only': os.urandom(4096),
            '20 % frames with bits 10-15 set': b''.join(p.bad_bits_frame(i) if i % 5 == 0 else good[i]
                                                       for i in range(40)),
            'only frames with bits 10-15 set': b''.join(p.bad_bits_frame(i) for i in range(40)),
            'a protocol-1 device': b''.join(p.v1_frame(i) for i in range(40)),
            'truncated frames between whole ones': b''.join(w[:len(w) // 2] if i % 4 == 1 else w
                                                            for i, w in enumerate(good)),
            'handler raises': b''.join(good),
        }[kind]
        _, statuses, diagnostics = p.run_bear(wire, node_class=node_class)
        first, level = statuses[0], p.level_of(diagnostics[0])
        if first.frames == 0 and level == p.OK:
            return False                      # a dead driver reporting healthy
        if kind == 'truncated frames between whole ones' and first.frames != 30:
            return False
        return (f'{first.frames} frames published; /diagnostics {("OK", "WARN", "ERROR")[level]}: '
                f'{diagnostics[0].message}')
    return run


def _skin_pty(kind: str) -> Callable[[], Any]:
    """A skin driver on a real pty fed frames that must each be data once; the check is its accounting."""
    def run() -> Any:
        rate = SkinDriverNode.frame_rate_hz
        if kind == 'one frame replayed 733 times':
            writes, expected, lost = p.paced(p.skin_frames([4711]) * 733, rate), 1, 0
        elif kind == 'a reboot: counter back to 0 after 300 frames':
            writes, expected, lost = p.paced(p.skin_frames(range(300)) * 2, rate), 600, 0
        elif kind == '25 % of 1500 frames corrupted':
            wire, lost = p.corrupt_some(p.skin_frames(range(1500)), 0.25, seed=25)
            writes, expected = p.paced(wire, rate), 1500 - lost
        else:                                            # 10 x the rate
            writes, expected, lost = p.paced(p.skin_frames(range(3000)), 10 * rate, per_write=12), 3000, 0
        _, statuses, diagnostics, published = p.run_driver(SkinDriverNode, 'skin', writes)
        last = statuses[-1]
        counted = last.frames_missed + last.checksum_errors + last.decode_errors + last.length_errors
        if (published, counted) != (expected, lost):
            return False                      # a frame published twice, or a loss counted twice or never
        said = [d for d in diagnostics if SKIN_PTY_CASES[kind] in d.message and p.level_of(d) >= p.WARN]
        if not said:
            return False                      # not reported on /diagnostics
        share = f'{100 * counted / (counted + last.frames):.1f} % bad or lost since start; ' if counted else ''
        return (f'{published} frames published; {share}repeated {p.value_of(diagnostics[-1], "repeated_frames")}, '
                f'resets {p.value_of(diagnostics[-1], "sequence_resets")}; /diagnostics '
                f'{("OK", "WARN", "ERROR")[p.level_of(said[0])]} {len(said)} time(s): {said[0].message}')
    return run


#: Skin pty case -> what its /diagnostics message must say (at WARN or ERROR).
SKIN_PTY_CASES = {'one frame replayed 733 times': 'resent with the last sequence number',
                  'a reboot: counter back to 0 after 300 frames': 'jumped back',
                  '25 % of 1500 frames corrupted': '% of frames bad or lost',
                  '10 x the rate (1500 Hz)': 'x the expected'}

PTY_CASES = ('garbage only', '20 % frames with bits 10-15 set', 'only frames with bits 10-15 set',
             'a protocol-1 device', 'truncated frames between whole ones', 'handler raises')


EVAL_EXPRESSIONS = ("str([[0]*99999]*99999)", "'%*d' % (2000000000, 1)", "max([[0]*99999]*99999)", "2**2**30",
                    "__import__('os')", "(1).__class__")


def _eval(expression: str) -> Callable[[], Any]:
    def run() -> Any:
        safe_eval(expression)
        return False                # evaluating any of these is wrong: each hangs, exhausts memory or escapes
    return run


def all_cases() -> list[tuple[str, str, Callable[[], Any] | list[str]]]:
    """``(area, case, callable or CLI argv)`` of every case the report runs."""
    cases: list[tuple[str, str, Any]] = []
    for sensor, params in DRIVER_PARAMETERS:
        text = ', '.join(f'{k}: {v}' for k, v in params.items())
        cases.append(('driver parameters', f'{sensor}_driver {text}', _driver(sensor, params)))
    for sensor, port in PORTS:
        cases.append(('driver ports', f'{sensor}_driver port {port}', _driver(sensor, {'port': port})))
    for name, text in PANEL_FILES.items():
        cases.append(('config files', f'panels.yaml: {name}', _panels_file(text)))
    for damage in ('empty', 'truncated', 'mean', 'coef', 'intercept'):
        what = f'NaN {damage}' if damage not in ('empty', 'truncated') else damage
        cases.append(('model and codebook files', f'bear subtype model: {what}', _bear_model(damage)))
    for damage in ('empty', 'truncated'):
        cases.append(('model and codebook files', f'skin codebook: {damage}', _codebook(damage)))
        cases.append(('model and codebook files', f'patch model: {damage}', _patch_model(damage)))
    for argv in (['record', '-a', '--duration', '0'], ['record', '-a', '--flush-period', '0'],
                 ['play', 'nowhere', '--rate', '0'], ['play', 'no_such_bag'], ['bag', 'info', 'no_such_bag'],
                 ['launch', 'no_such.launch.yaml'], ['bench', 'framing', '--repeats', '0']):
        cases.append(('command line', 'social-touch ' + ' '.join(argv), argv))
    for expression in EVAL_EXPRESSIONS:
        cases.append(('launch $(eval)', f'$(eval {expression})', _eval(expression)))
    for kind in PTY_CASES:
        cases.append(('driver faults (real pty)', f'bear_driver: {kind}', _pty(kind)))
    for kind in SKIN_PTY_CASES:
        cases.append(('driver faults (real pty)', f'skin_driver: {kind}', _skin_pty(kind)))
    for level in (3e38, 1.0001, -0.5):
        cases.append(('recogniser input', f'bear_gestures level {level:g} for 2 s', _bear_level(level)))
    cases += stray_cases()
    cases += input_cases()
    cases += web_cases()
    return cases
