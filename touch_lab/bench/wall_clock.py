"""``social-touch bench wall-clock``: what the touch graph costs as a user launches it, on the wall clock.

Each configuration is started as a user starts it, ``social-touch launch FILE`` (all nodes in one
process) or ``... --processes`` (one process per node), on the wall clock, in a DDS domain of its
own, from the shipped launch files (:func:`prepared_launch`: the monitors off, every driver's
``read_on_arrival`` set to the mode measured). The sensors' ports are pseudo-terminals
(``os.openpty``); another process (:mod:`~touch_lab.bench.wall_clock_feed`) writes into them the
bytes the virtual devices of touch_sim send for the demo's people scenes (synthetic; recorded
first, :func:`~touch_lab.bench.replay.record_scene`), at the sensors' real rates (bear 3.4 Hz,
patch 20 Hz, skin 150 Hz). Once every driver has reported on /diagnostics the feed starts; after
:data:`WARMUP_S` the CPU time (user + system, ``/proc/PID/stat``) of the launch process and all
its descendants is read over ``seconds`` wall seconds: the share of one core, also split into the
processes' main threads (the executors: decoding, calibrating, recognising) and their other threads
(the drivers' port readers, DDS). Then the drivers'
last /diagnostics must count every frame written as published (``frames``), none missed.

Configurations: ``sensors`` (bear, patch and skin with their recognisers, launch/bear, patch and
skin.launch.yaml in one process) and ``patches N`` (launch/skin_patches.launch.yaml, N skin
patches with their recognisers, one process or ``--processes``), each in both reading modes:
``arrival`` (the drivers read when bytes arrive, the default) and ``polled`` (a timer at twice the
sensor rate, ``read_on_arrival:=false``). Figures are medians of ``repeats`` runs, with the load
average of the machine beside them: on a shared machine wall-clock CPU figures are noisy.
``social-touch report wall-clock`` runs it and writes docs/wall-clock.md with the curve.
"""

from __future__ import annotations

import contextlib
import json
import os
import pickle
import platform
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import yaml

from touch_graph.cli.options import add_output, positive_int, seconds
from touch_graph.files import write_text
from touch_graph.messages import get_message
from touch_graph.paths import share_file
from touch_graph.runtime import Context, Node, SingleThreadedExecutor

from .replay import PtyPort, Recording, record_scene

__all__ = ['GOAL_PATCH_PERCENT', 'GOAL_SENSORS_PERCENT', 'WARMUP_S', 'bench_wall_clock', 'measure', 'prepared_launch',
           'tree_cpu_s', 'tree_thread_cpu_s']

#: Issue 27's goals: the three sensors with their recognisers in one process, and each extra patch.
GOAL_SENSORS_PERCENT = 3.0
GOAL_PATCH_PERCENT = 1.0
#: s of feeding before the CPU window opens (the first frames warm caches and DDS matches).
WARMUP_S = 2.0
#: s the drivers get after the last byte to publish it and report it on /diagnostics.
DRAIN_S = 4.0
#: s a launch may take until every driver has reported (a loaded machine starting 17 processes).
START_TIMEOUT_S = 180.0
SENSORS = ('bear', 'patch', 'skin')
#: What the feeder process runs (``python -c FEED_MAIN PLAN``): no module of ours has a ``__main__``.
FEED_MAIN = 'import sys; from touch_lab.bench.wall_clock_feed import main; sys.exit(main())'
_TICK = os.sysconf('SC_CLK_TCK')


def tree_cpu_s(pid: int) -> float:
    """User + system CPU seconds of process ``pid`` and its living descendants (``/proc``)."""
    return sum(tree_thread_cpu_s(pid))


def tree_thread_cpu_s(pid: int) -> tuple[float, float]:
    """User + system CPU seconds of process ``pid`` and its living descendants, split into their main threads
    (where the executors spin) and all their other threads (port readers, DDS; ended ones included)."""
    main = other = 0.0
    todo = [pid]
    while todo:
        current = todo.pop()
        try:
            total = _stat_cpu_s(Path(f'/proc/{current}/stat'))
            own = _stat_cpu_s(Path(f'/proc/{current}/task/{current}/stat'))
            main += own
            other += total - own
            for task in Path(f'/proc/{current}/task').iterdir():
                todo += [int(c) for c in (task / 'children').read_text().split()]
        except (FileNotFoundError, ProcessLookupError, IndexError):
            continue
    return main, other


def _stat_cpu_s(path: Path) -> float:
    """utime + stime of a ``/proc/.../stat`` file, s."""
    fields = path.read_text().rsplit(')', 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / _TICK


def _with_driver_param(entries: list, name: str, value: Any) -> list:
    """``entries`` of a launch file with ``{name: value}`` added to every driver node (``exec: *_driver``)."""
    for entry in entries:
        node = entry.get('node') if isinstance(entry, dict) else None
        if isinstance(node, dict) and str(node.get('exec', '')).endswith('_driver'):
            node.setdefault('param', []).append({'name': name, 'value': value})
        group = entry.get('group') if isinstance(entry, dict) else None
        if isinstance(group, dict):
            _with_driver_param(group.get('children', []), name, value)
    return entries


def prepared_launch(folder: Path, shipped: str, read_on_arrival: bool) -> Path:
    """The shipped launch file ``launch/<shipped>`` written into ``folder`` with every driver's
    ``read_on_arrival`` set (the file is otherwise the same; its paths use ``find-pkg-share``)."""
    tree = yaml.safe_load(Path(share_file('launch', shipped)).read_text())
    _with_driver_param(tree['launch'], 'read_on_arrival', read_on_arrival)
    path = folder / shipped
    path.write_text(yaml.safe_dump(tree, sort_keys=False))
    return path


def _sensors_launch(folder: Path, ports: dict[str, str], read_on_arrival: bool) -> Path:
    """One file including the three sensors' shipped launch files, monitors off, on ``ports``."""
    includes = [{'include': {'file': str(prepared_launch(folder, f'{sensor}.launch.yaml', read_on_arrival)),
                             'arg': [{'name': 'monitor', 'value': 'false'},
                                     {'name': f'{sensor}_port', 'value': ports[sensor]}]}} for sensor in SENSORS]
    path = folder / 'sensors.launch.yaml'
    path.write_text(yaml.safe_dump({'launch': includes}, sort_keys=False))
    return path


def _launch_command() -> list[str]:
    script = Path(sys.executable).with_name('social-touch')
    return [str(script)] if script.is_file() else [sys.executable, '-m', 'touch_lab.cli.main']


class _Diagnostics:
    """The latest /diagnostics status of each driver, in this process (a DDS participant of its own)."""

    def __init__(self) -> None:
        self.context = Context('wall', network=True)
        self.context.init()
        self.node = Node('wall_clock_bench', context=self.context)
        self.latest: dict[str, dict[str, str]] = {}
        self.node.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                                      self._on_diagnostics, 100)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)

    def _on_diagnostics(self, msg: Any) -> None:
        for status in msg.status:
            if status.name.startswith('social_touch: ') and status.name.endswith('_driver'):
                self.latest[status.name.removeprefix('social_touch: ')] = {kv.key: kv.value for kv in status.values}

    def spin_until(self, predicate: Any, timeout_s: float) -> bool:
        return self.executor.spin_until(predicate, timeout_sec=timeout_s)

    def close(self) -> None:
        self.context.shutdown()


def measure(config: str, n: int, seconds: float, read_on_arrival: bool, processes: bool,
            recordings: dict[str, Recording]) -> dict[str, Any]:
    """One run of a configuration (module doc): CPU share of one core and frames written/published per driver."""
    sensors = list(SENSORS) if config == 'sensors' else ['skin'] * n
    drivers = ([f'/{s}/{s}_driver' for s in SENSORS] if config == 'sensors'
               else [f'/skin{k}/skin_driver' for k in range(n)])
    ports = [PtyPort() for _ in sensors]
    domain = random.randint(1, 99)
    os.environ['ROS_DOMAIN_ID'] = str(domain)      # this process's listener joins the launch's domain
    launch = feeder = listener = None
    with tempfile.TemporaryDirectory(prefix='wall-clock-') as tmp:
        folder = Path(tmp)
        try:
            if config == 'sensors':
                path = _sensors_launch(folder, {s: p.path for s, p in zip(sensors, ports, strict=True)},
                                       read_on_arrival)
                args = []
            else:
                path = prepared_launch(folder, 'skin_patches.launch.yaml', read_on_arrival)
                args = [f'patches:={n}', *(f'port{k}:={p.path}' for k, p in enumerate(ports))]
            plan = folder / 'plan.pickle'
            feed_s = WARMUP_S + seconds + 0.5
            with plan.open('wb') as file:
                pickle.dump({'seconds': feed_s, 'feeds': [(p.master, recordings[s].period, recordings[s].chunks)
                                                          for s, p in zip(sensors, ports, strict=True)]}, file)
            feeder = subprocess.Popen([sys.executable, '-c', FEED_MAIN, str(plan)],
                                      pass_fds=[p.master for p in ports], stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE, text=True)
            if feeder.stdout.readline().strip() != 'ready':
                raise RuntimeError('the feeder did not start')
            env = dict(os.environ, PYTHONUNBUFFERED='1')
            env.pop('SOCIAL_TOUCH_SHIM', None)
            log = (folder / 'launch.log').open('w')     # a file, not a pipe: a full pipe would stall the launch
            launch = subprocess.Popen([*_launch_command(), 'launch', str(path), *args,
                                       *(['--processes'] if processes else [])], env=env, stdout=log,
                                      stderr=subprocess.STDOUT, start_new_session=True)
            listener = _Diagnostics()
            if not listener.spin_until(lambda: set(drivers) <= set(listener.latest) or launch.poll() is not None,
                                       START_TIMEOUT_S) or launch.poll() is not None:
                raise RuntimeError(f'{config} {n}: not every driver reported in {START_TIMEOUT_S:g} s: '
                                   f'{sorted(listener.latest)}\n{(folder / "launch.log").read_text()[-2000:]}')
            listener.executor.spin_for(0.5)
            feeder.stdin.write('go\n')
            feeder.stdin.flush()
            listener.executor.spin_for(WARMUP_S)
            load_before = os.getloadavg()[0]
            threads0, wall0 = tree_thread_cpu_s(launch.pid), time.monotonic()
            listener.executor.spin_for(seconds)
            threads1, wall1 = tree_thread_cpu_s(launch.pid), time.monotonic()
            load_after = os.getloadavg()[0]
            fed = json.loads(feeder.stdout.readline())
            sent = dict.fromkeys(drivers, 0)
            for name, count in zip(drivers, fed['sent'], strict=True):
                sent[name] += count

            def published() -> dict[str, int]:
                return {name: int(listener.latest.get(name, {}).get('frames', -1)) for name in drivers}

            listener.spin_until(lambda: published() == sent, DRAIN_S)
            got = published()
            missed = {name: int(listener.latest[name].get('frames_missed', 0)) for name in drivers}
            return {'percent_of_core': 100.0 * (sum(threads1) - sum(threads0)) / (wall1 - wall0),
                    'wall_s': wall1 - wall0,
                    'main_threads_percent': 100.0 * (threads1[0] - threads0[0]) / (wall1 - wall0),
                    'other_threads_percent': 100.0 * (threads1[1] - threads0[1]) / (wall1 - wall0),
                    'frames_sent': sum(sent.values()), 'frames_published': sum(got.values()),
                    'frames_missed': sum(missed.values()), 'all_published': got == sent,
                    'feeder_max_late_s': fed['max_late_s'], 'load_average_1min': (load_before + load_after) / 2}
        finally:
            if listener is not None:
                listener.close()
            if launch is not None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(launch.pid, signal.SIGINT)
                try:
                    launch.wait(timeout=30)
                except subprocess.TimeoutExpired:
                    os.killpg(launch.pid, signal.SIGKILL)
                    launch.wait()
            if feeder is not None:
                feeder.kill()
                feeder.communicate()
            for port in ports:
                port.close()


def _median_run(runs: list[dict[str, Any]]) -> dict[str, Any]:
    return {'percent_of_core': round(statistics.median(r['percent_of_core'] for r in runs), 2),
            'runs_percent': [round(r['percent_of_core'], 2) for r in runs],
            'main_threads_percent': round(statistics.median(r['main_threads_percent'] for r in runs), 2),
            'other_threads_percent': round(statistics.median(r['other_threads_percent'] for r in runs), 2),
            'frames_sent': runs[-1]['frames_sent'], 'frames_published': runs[-1]['frames_published'],
            'no_frame_missed': all(r['all_published'] and r['frames_missed'] == 0 for r in runs),
            'load_average_1min': round(statistics.median(r['load_average_1min'] for r in runs), 2)}


def bench_wall_clock(repeats: int = 3, seconds: float = 8.0, patches: tuple[int, ...] = (1, 2, 4, 8),
                     process_patches: tuple[int, ...] = (1, 2, 4, 8), modes: tuple[str, ...] = ('arrival', 'polled'),
                     progress: Any = None) -> dict:
    """Medians over ``repeats`` runs of every configuration (module doc); ``progress(text)`` hears of each run."""
    if repeats < 1 or not seconds > 0:
        raise ValueError(f'repeats >= 1 and seconds > 0 are required; got {repeats}, {seconds}')
    recordings = {sensor: record_scene(sensor, WARMUP_S + seconds + 1.0) for sensor in SENSORS}
    plan = [('sensors', 1, mode, False) for mode in modes]
    plan += [('patches', n, mode, False) for mode in modes for n in patches]
    plan += [('patches', n, 'arrival', True) for n in process_patches]
    out: dict[str, Any] = {'repeats': repeats, 'seconds': seconds, 'synthetic_data': True,
                           'cpu_count': os.cpu_count(), 'sensors': {}, 'patches': {}, 'patches_processes': {}}
    for config, n, mode, processes in plan:
        runs = []
        for _ in range(repeats):
            runs.append(measure(config, n, seconds, mode == 'arrival', processes, recordings))
            if progress is not None:
                progress(f'{config} n={n} {mode} processes={processes}: {runs[-1]["percent_of_core"]:.2f} % '
                         f'(load {runs[-1]["load_average_1min"]:.2f})')
        entry = _median_run(runs)
        if config == 'sensors':
            out['sensors'][mode] = entry
        elif processes:
            out['patches_processes'].setdefault(mode, {})[n] = entry
        else:
            out['patches'].setdefault(mode, {})[n] = entry
    for key in ('patches', 'patches_processes'):
        for curve in out[key].values():
            counts = sorted(curve)
            if len(counts) >= 2:
                first, last = curve[counts[0]], curve[counts[-1]]
                curve['per_extra_patch'] = round((last['percent_of_core'] - first['percent_of_core'])
                                                 / (counts[-1] - counts[0]), 2)
    out['goals'] = {'sensors_percent': GOAL_SENSORS_PERCENT, 'per_extra_patch_percent': GOAL_PATCH_PERCENT}
    return out


# ---------------------------------------------------------------------- report: social-touch report wall-clock
REPORT = Path(__file__).resolve().parents[2] / 'docs' / 'wall-clock.md'


def _curve_png(figures: dict, path: Path) -> Path:
    """CPU (% of one core) against the number of patches, one line per configuration."""
    from touch_lab.figures.png import drawing, note_synthetic, save_png  # matplotlib: loaded only to draw the report
    with drawing(6.0, 3.6) as fig:
        axes = fig.add_subplot()
        for key, label in (('patches', 'one process'), ('patches_processes', 'processes of their own')):
            for mode, curve in figures[key].items():
                counts = sorted(n for n in curve if isinstance(n, int))
                axes.plot(counts, [curve[n]['percent_of_core'] for n in counts], marker='o',
                          label=f'{label}, {mode}')
        axes.set_xlabel('skin patches (driver + recogniser each)')
        axes.set_ylabel('CPU, % of one core (median)')
        axes.set_title('launch/skin_patches.launch.yaml on the wall clock')
        axes.grid(True, alpha=0.3)
        axes.legend(fontsize=7)
        note_synthetic(fig, "demo people scene's bytes (touch_sim) replayed at 150 Hz per patch")
        return save_png(fig, path)


def _threads(row: dict) -> str:
    """``main / other`` threads' % of one core of a row ('-' for figures measured before the split)."""
    if 'main_threads_percent' not in row:
        return '-'
    return f'{row["main_threads_percent"]:.2f} / {row["other_threads_percent"]:.2f}'


def render(figures: dict, png_name: str) -> str:
    goals = figures['goals']
    lines = [
        '# Wall-clock cost of the touch graph', '',
        'Generated by `social-touch report wall-clock` (touch_lab/bench/wall_clock.py); the same figures print '
        'with `social-touch bench wall-clock`. Each configuration is launched as a user launches it, '
        '`social-touch launch FILE` (one process) or `--processes`, on the wall clock, its sensors\' ports '
        'pseudo-terminals fed from another process at the real rates (bear 3.4 Hz, patch 20 Hz, skin 150 Hz) with '
        'the bytes the virtual devices send for the demo\'s people scenes (SYNTHETIC). CPU is user + system time of '
        f'the launch process and its children over {figures["seconds"]:g} wall seconds after {WARMUP_S:g} s of '
        f'feeding, as % of one core, median of {figures["repeats"]} runs. "arrival": the drivers read when bytes '
        'arrive (the default); "polled": a timer at twice the sensor rate (`read_on_arrival:=false`, the way before). '
        '"main / other threads": the same CPU split into the processes\' main threads (the executors: decoding, '
        'calibrating, recognising) and their other threads (the drivers\' port readers, DDS).',
        '',
        f'**Noise.** This machine has {figures["cpu_count"]} cores shared with other work; the 1-minute load '
        'average during each configuration is printed beside it. With a load average above the core count the '
        'figures carry the scheduler\'s noise (runs are listed); compare ratios within one run of the report.', '',
        f'## Three sensors with their recognisers, one process (goal <= {goals["sensors_percent"]:g} %)', '',
        '| reading | % of one core | main / other threads | runs | frames sent | published | none missed | '
        'load average |',
        '|---|---:|---:|---|---:|---:|---|---:|',
    ]
    for mode, row in figures['sensors'].items():
        lines.append(f'| {mode} | {row["percent_of_core"]:.2f} | {_threads(row)} | {row["runs_percent"]} | '
                     f'{row["frames_sent"]} | '
                     f'{row["frames_published"]} | {"yes" if row["no_frame_missed"] else "NO"} | '
                     f'{row["load_average_1min"]:.2f} |')
    lines += ['', f'## N skin patches: launch/skin_patches.launch.yaml (goal <= {goals["per_extra_patch_percent"]:g} '
              '% per extra patch)', '', f'![CPU against N patches]({png_name})', '',
              '| processes | reading | patches | % of one core | main / other threads | runs | frames sent | '
              'published | none missed | load average |', '|---|---|---:|---:|---:|---|---:|---:|---|---:|']
    for key, label in (('patches', 'one'), ('patches_processes', 'one per node')):
        for mode, curve in figures[key].items():
            for n in sorted(k for k in curve if isinstance(k, int)):
                row = curve[n]
                lines.append(f'| {label} | {mode} | {n} | {row["percent_of_core"]:.2f} | {_threads(row)} | '
                             f'{row["runs_percent"]} | '
                             f'{row["frames_sent"]} | {row["frames_published"]} | '
                             f'{"yes" if row["no_frame_missed"] else "NO"} | {row["load_average_1min"]:.2f} |')
    lines += ['', 'Per extra patch (the slope from the fewest to the most patches measured), % of one core:', '']
    for key, label in (('patches', 'one process'), ('patches_processes', 'processes of their own')):
        for mode, curve in figures[key].items():
            if 'per_extra_patch' in curve:
                lines.append(f'- {label}, {mode}: {curve["per_extra_patch"]:.2f}')
    machine = figures.get('machine', {})
    if machine:
        lines += ['', f'Python {machine.get("python")} on {machine.get("processor")}.']
    return '\n'.join(lines) + '\n'


def _counts(text: str) -> tuple[int, ...]:
    return tuple(int(n) for n in text.split(',') if n)


def add_arguments(parser: Any) -> None:
    parser.add_argument('--repeats', type=positive_int, default=3, help='runs to take the median of (default 3)')
    parser.add_argument('--seconds', type=seconds, default=8.0, help='wall seconds each CPU window lasts (default 8)')
    parser.add_argument('--patches', type=_counts, default=(1, 2, 4, 8),
                        help='patch counts in one process, comma-separated (default 1,2,4,8)')
    parser.add_argument('--process-patches', type=_counts, default=(1, 2, 4, 8),
                        help='patch counts with --processes (default 1,2,4,8; empty: none)')
    add_output(parser, f'report to write (default {REPORT})', default=str(REPORT))


def run(args: Any) -> int:
    figures = bench_wall_clock(repeats=args.repeats, seconds=args.seconds, patches=args.patches,
                               process_patches=args.process_patches,
                               progress=lambda text: print(text, file=sys.stderr, flush=True))
    figures['machine'] = {'python': platform.python_version(), 'processor': platform.machine()}
    output = Path(args.output)
    png = _curve_png(figures, output.with_suffix('.png'))
    write_text(output, render(figures, png.name))
    print(f'wrote {output} and {png}')
    return 0
