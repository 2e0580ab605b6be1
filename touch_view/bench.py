"""``social-touch bench view``: the extra CPU the web view costs the graph, with five pages connected.

The demo scene (``launch/demo.launch.yaml``, SYNTHETIC data) runs ``scene_s`` simulated seconds at
``rate`` times real time, without the view and with the view and ``clients`` pages (separate
processes reading the event stream) connected, ``repeats`` times each, interleaved, after one
unmeasured run of each. The figure is the ratio of the medians of the graph process's CPU seconds
per scene.
"""

from __future__ import annotations

import contextlib
import io
import resource
import statistics
import subprocess
import sys
import textwrap
import time

from touch_graph.launch import LaunchRunner, evaluate_launch
from touch_graph.paths import share_file

__all__ = ['bench_view']

#: A page: reads /events and counts the state frames, until it is killed.
_PAGE = textwrap.dedent('''
    import socket, sys
    sock = socket.create_connection(('127.0.0.1', int(sys.argv[1])))
    sock.sendall(b'GET /events HTTP/1.1\\r\\nHost: 127.0.0.1\\r\\n\\r\\n')
    while sock.recv(1 << 16):
        pass
''')


def _cpu_s() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _run_once(with_view: bool, clients: int, rate: float, scene_s: float) -> dict:
    arguments = {'view': 'true', 'view_port': '0'} if with_view else {}
    plan = evaluate_launch(share_file('launch', 'demo.launch.yaml'), arguments)
    runner = LaunchRunner(plan.nodes, sim_time=True, rate=rate)
    pages: list[subprocess.Popen] = []
    out: dict = {}
    # touch_monitor prints what it perceives; keep that out of the benchmark's output (it runs in both modes).
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            runner.start()
            out = _measure(runner, with_view, clients, scene_s, pages)
        finally:
            for page in pages:
                page.kill()
                page.wait()
            runner.shutdown()
    return out


def _measure(runner: LaunchRunner, with_view: bool, clients: int, scene_s: float, pages: list) -> dict:
    if with_view:
        view = next(n for n in runner.nodes if n.get_name() == 'touch_view')
        pages.extend(subprocess.Popen([sys.executable, '-c', _PAGE, str(view.server.port)]) for _ in range(clients))
        deadline = time.monotonic() + 10.0
        while len(view.server.clients) < clients and time.monotonic() < deadline:
            time.sleep(0.01)  # every page connected before the measurement starts
    cpu0, wall0 = _cpu_s(), time.monotonic()
    runner.spin(scene_s, handle_signals=False)
    out = {'cpu_s': _cpu_s() - cpu0, 'wall_s': time.monotonic() - wall0}
    if with_view:
        stats = view.server.clients.stats()
        out.update(pages=stats['connected'], frames_built=view.server.frames_built,
                   dropped=stats['dropped_total'], sent=sum(c['sent'] for c in stats['clients']))
    return out


def bench_view(repeats: int = 5, clients: int = 5, rate: float = 2.0, scene_s: float = 12.0) -> dict:
    """Median CPU of the demo graph without and with the view and ``clients`` pages, and their ratio."""
    runs: dict[str, list[dict]] = {'without_view': [], 'with_view': []}
    for with_view in (False, True):  # warm up: imports, the scene generators' caches, the model files
        _run_once(with_view, clients, rate, scene_s)
    for _ in range(repeats):
        runs['without_view'].append(_run_once(False, 0, rate, scene_s))
        runs['with_view'].append(_run_once(True, clients, rate, scene_s))
    base = statistics.median(r['cpu_s'] for r in runs['without_view'])
    view = statistics.median(r['cpu_s'] for r in runs['with_view'])
    last = runs['with_view'][-1]
    return {
        'scene': f'launch/demo.launch.yaml, {scene_s:g} simulated s at {rate:g}x real time (synthetic data)',
        'repeats': repeats, 'pages': clients,
        'cpu_s_without_view': round(base, 3), 'cpu_s_with_view': round(view, 3),
        'cpu_fraction_without_view': round(base / (scene_s / rate), 3),
        'extra_cpu': round(view / base - 1.0, 3) if base > 0 else None,
        'goal_extra_cpu_at_most': 0.2,
        'snapshots_per_s': round(last['frames_built'] / last['wall_s'], 1),
        'frames_sent_per_page': round(last['sent'] / max(1, last['pages']), 1), 'frames_dropped': last['dropped'],
        'cpu_s_runs': {mode: [round(r['cpu_s'], 3) for r in rs] for mode, rs in runs.items()},
    }
