"""``social-touch bench node-memory``: what each node process holds, as a user launches it.

Two figures per node, medians of ``repeats`` runs: **launched** (each scene of :data:`SCENES` started
with ``social-touch launch FILE --processes`` in a DDS domain of its own; ``VmRSS`` of every node
process after :data:`SETTLE_S` s) and **imported** (a bare interpreter importing the node's module,
beside ``python -c 'import numpy'``; heavy packages loaded, :data:`HEAVY`, are listed). Linux only.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import random
import signal
import statistics
import subprocess
import sys
import time
from importlib.metadata import entry_points
from pathlib import Path

from touch_graph.cli.options import add_output, positive_int
from touch_graph.files import write_text

__all__ = ['HEAVY', 'SCENES', 'SETTLE_S', 'add_arguments', 'bench_node_memory', 'import_rss_mb', 'launched_rss_mb',
           'render', 'run']

ROOT = Path(__file__).resolve().parents[2]
REPORT = ROOT / 'docs' / 'node-memory.md'
#: The shipped single-sensor scenes, launched with their default arguments.
SCENES = ('launch/skin.launch.yaml', 'launch/patch.launch.yaml', 'launch/bear.launch.yaml')
#: Seconds after the launch at which the processes' RSS is read.
SETTLE_S = 10.0
#: The goal each node process is held to, MB.
GOAL_MB = 100.0
#: Packages a node process should load only where it needs them (reported per node module).
HEAVY = ('sklearn', 'scipy', 'matplotlib', 'touch_lab', 'touch_sim', 'mcap', 'rosbags.rosbag2', 'cyclonedds',
         'foxglove')

_IMPORT_PROBE = '''
import importlib, sys
if sys.argv[1]:
    importlib.import_module(sys.argv[1])
rss = next(line.split()[1] for line in open('/proc/self/status') if line.startswith('VmRSS:'))
loaded = [h for h in sys.argv[2].split(',') if h in sys.modules]
print(int(rss), ','.join(loaded))
'''


def _rss_kb(pid: int) -> int | None:
    """VmRSS of process ``pid`` in kB (None when it has gone)."""
    try:
        with open(f'/proc/{pid}/status') as status:
            for line in status:
                if line.startswith('VmRSS:'):
                    return int(line.split()[1])
    except (FileNotFoundError, ProcessLookupError):
        return None
    return None


def _children(pid: int) -> list[int]:
    """Direct children of ``pid`` (every thread's ``children`` list)."""
    out: list[int] = []
    for task in Path(f'/proc/{pid}/task').iterdir():
        try:
            out += [int(c) for c in (task / 'children').read_text().split()]
        except FileNotFoundError:
            continue
    return out


def _node_label(pid: int) -> tuple[str, str] | None:
    """``namespace/name`` and executable of a launcher's node process, from the spec JSON on its command line."""
    try:
        argv = Path(f'/proc/{pid}/cmdline').read_bytes().split(b'\0')
    except FileNotFoundError:
        return None
    for arg in argv:
        if arg.startswith(b'{'):
            spec = json.loads(arg)
            name = spec.get('name') or spec.get('exec')
            namespace = (spec.get('namespace') or '').strip('/')
            return (f'{namespace}/{name}' if namespace else name), spec['exec']
    return None


def _launch_command() -> list[str]:
    script = Path(sys.executable).with_name('social-touch')
    return [str(script)] if script.is_file() else [sys.executable, '-m', 'touch_lab.cli.main']


def launched_rss_mb(scene: str, settle_s: float = SETTLE_S) -> dict[tuple[str, str], float]:
    """One launch of ``scene`` with ``--processes``: (node label, executable) -> RSS (MB) ``settle_s`` after
    the start.

    Raises:
        RuntimeError: when the launch ends before ``settle_s`` (a node that cannot start).
    """
    env = dict(os.environ, ROS_DOMAIN_ID=str(random.randint(1, 99)), PYTHONUNBUFFERED='1')
    env.pop('SOCIAL_TOUCH_SHIM', None)
    proc = subprocess.Popen([*_launch_command(), 'launch', str(ROOT / scene), '--processes'], cwd=ROOT, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True)
    try:
        deadline = time.monotonic() + settle_s
        while time.monotonic() < deadline:
            if proc.poll() is not None:
                raise RuntimeError(f'{scene}: the launch ended early (exit {proc.returncode}):\n'
                                   f'{proc.stdout.read()[-2000:]}')
            time.sleep(0.1)
        out = {}
        for child in _children(proc.pid):
            node, rss = _node_label(child), _rss_kb(child)
            if node is not None and rss is not None:
                out[node] = rss / 1024
        return out
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.communicate(timeout=20)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.communicate()


def import_rss_mb(module: str) -> tuple[float, list[str]]:
    """RSS (MB) of a fresh interpreter after ``import module`` ('' imports nothing), and the :data:`HEAVY`
    packages it loaded."""
    out = subprocess.run([sys.executable, '-c', _IMPORT_PROBE, module, ','.join(HEAVY)], capture_output=True,
                         text=True, check=True).stdout.split()
    return int(out[0]) / 1024, (out[1].split(',') if len(out) > 1 else [])


def _node_modules() -> dict[str, str]:
    """Executable name -> the module of its node class (the ``social_touch.nodes`` entry points)."""
    return {ep.name: ep.value.partition(':')[0] for ep in entry_points(group='social_touch.nodes')}


def bench_node_memory(repeats: int = 3, settle_s: float = SETTLE_S) -> dict:
    """Medians over ``repeats`` runs of each node's RSS (MB) launched (``--processes``) and imported."""
    launched: dict[str, dict[str, list[float]]] = {}
    executables: set[str] = set()
    for _ in range(repeats):
        for scene in SCENES:
            for (label, exe), mb in launched_rss_mb(scene, settle_s).items():
                launched.setdefault(scene, {}).setdefault(label, []).append(mb)
                executables.add(exe)
    modules = _node_modules()
    baseline = [import_rss_mb('numpy')[0] for _ in range(repeats)]
    imported = {}
    for exe in sorted(executables):
        runs = [import_rss_mb(modules[exe]) for _ in range(repeats)]
        imported[exe] = {'module': modules[exe], 'rss_mb': round(statistics.median(r[0] for r in runs), 1),
                         'heavy': runs[-1][1]}
    return {
        'repeats': repeats, 'settle_s': settle_s, 'goal_mb': GOAL_MB,
        'launched': {scene: {label: round(statistics.median(v), 1) for label, v in sorted(nodes.items())}
                     for scene, nodes in launched.items()},
        'imported': imported,
        'import numpy (MB)': round(statistics.median(baseline), 1),
    }


def render(figures: dict) -> str:
    lines = [
        '# Node processes: memory', '',
        'Generated by `social-touch report node-memory` (touch_lab/bench/node_memory.py); the same figures '
        'print with `social-touch bench node-memory`. Resident set size (VmRSS), MB, median of '
        f'{figures["repeats"]} runs on this machine. The goal (issue 27): every node process <= '
        f'{figures["goal_mb"]:.0f} MB.', '',
        f'## Launched: `social-touch launch FILE --processes`, {figures["settle_s"]:.0f} s after the start', '',
        'Each shipped scene with its default arguments (simulated people, synthetic), on the wall clock, in a '
        'DDS domain of its own.', '',
        '| launch file | node process | RSS (MB) | <= goal |', '|---|---|---:|---|',
    ]
    for scene, nodes in figures['launched'].items():
        for label, mb in nodes.items():
            lines.append(f'| {scene} | {label} | {mb:.1f} | {"yes" if mb <= figures["goal_mb"] else "NO"} |')
    lines += [
        '', '## Imported: a bare interpreter after `import MODULE`', '',
        f'What each node\'s code costs before the node starts; `python -c "import numpy"` holds '
        f'{figures["import numpy (MB)"]:.1f} MB. "Heavy" lists the packages of this list it loaded: '
        f'{", ".join(HEAVY)}.', '',
        '| executable | module | RSS (MB) | heavy packages loaded |', '|---|---|---:|---|',
    ]
    for exe, row in figures['imported'].items():
        lines.append(f'| {exe} | `{row["module"]}` | {row["rss_mb"]:.1f} | {", ".join(row["heavy"]) or "none"} |')
    machine = figures.get('machine', {})
    if machine:
        lines += ['', f'Python {machine.get("python")} on {machine.get("processor")}.']
    return '\n'.join(lines) + '\n'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--repeats', type=positive_int, default=3, help='runs to take the median of (default 3)')
    add_output(parser, f'report to write (default {REPORT})', default=str(REPORT))


def run(args: argparse.Namespace) -> int:
    figures = bench_node_memory(repeats=args.repeats)
    figures['machine'] = {'python': platform.python_version(), 'processor': platform.machine()}
    write_text(Path(args.output), render(figures))
    print(f'wrote {args.output}')
    return 0
