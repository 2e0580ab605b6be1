"""``social-touch bench cli``: how long ``social-touch --help`` and the graph queries take, beside ``python -c pass``.

Each is run ``repeats`` times as a user runs it, in a fresh interpreter (the console script
next to this Python when there is one, else ``python -m touch_lab.cli.main``); the medians
of the wall-clock times in seconds, and their ratio. The graph queries run in a DDS domain of
their own with nothing in it (LOCALHOST discovery): ``topic list`` as the first call (no graph
daemon yet: it starts one and asks it), the call right after it, and later
calls once the daemon has settled; ``node list`` through the daemon; ``topic list --no-daemon``
beside them. The daemon is stopped before each repeat and at the end.
"""

from __future__ import annotations

import os
import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

from touch_graph.daemon import client
from touch_graph.daemon.address import daemon_address
from touch_lab.robustness.cases_stray import hold_test_domain

__all__ = ['bench_cli', 'bench_graph_queries', 'help_command', 'social_touch_command']


def social_touch_command() -> list[str]:
    """The argv of ``social-touch`` as installed beside this interpreter."""
    script = Path(sys.executable).with_name('social-touch')
    if script.is_file():
        return [str(script)]
    found = shutil.which('social-touch')
    return [found] if found else [sys.executable, '-m', 'touch_lab.cli.main']


def help_command() -> list[str]:
    """The argv of ``social-touch --help`` as installed beside this interpreter."""
    return [*social_touch_command(), '--help']


def _median_s(argv: list[str], repeats: int, env: dict[str, str] | None = None, check: bool = True) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(argv, check=check, capture_output=True, env=env)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_graph_queries(repeats: int, settle_s: float = 3.0) -> dict:
    """Medians (s) of the graph queries on an empty domain of their own, with and without the graph daemon."""
    command = social_touch_command()
    names = ('topic list, first call', 'topic list, second call', 'topic list, daemon settled',
             'node list, daemon settled', 'topic list --no-daemon')
    argvs = (['topic', 'list'], ['topic', 'list'], ['topic', 'list'], ['node', 'list'],
             ['topic', 'list', '--no-daemon'])
    times: dict[str, list[float]] = {name: [] for name in names}
    with hold_test_domain() as domain:
        env = {k: v for k, v in os.environ.items()
               if k not in ('SOCIAL_TOUCH_NETWORK', 'ROS_STATIC_PEERS', 'CYCLONEDDS_URI', 'ROS_LOCALHOST_ONLY')}
        env.update(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', SOCIAL_TOUCH_DAEMON='1')
        address = daemon_address(env)
        try:
            for _ in range(repeats):
                client.stop(address)
                for name, argv in zip(names, argvs, strict=True):
                    if name == 'topic list, daemon settled':
                        time.sleep(settle_s)
                    # nobody in the domain: the queries exit 1 with "no ROS 2 graph is running", as ros2cli's do
                    times[name].append(_median_s([*command, *argv], 1, env, check=False))
        finally:
            client.stop(address)
    medians = {f'{name} (s)': round(statistics.median(t), 4) for name, t in times.items()}
    medians['domain'] = 'empty, a domain of its own, LOCALHOST discovery'
    return medians


def bench_cli(repeats: int = 7) -> dict:
    """Medians (s) of ``python -c pass`` and ``social-touch --help``, interleaved run by run; then the graph
    queries (:func:`bench_graph_queries`)."""
    baseline = [sys.executable, '-c', 'pass']
    command = help_command()
    pass_s, help_s = [], []
    for _ in range(repeats):
        pass_s.append(_median_s(baseline, 1))
        help_s.append(_median_s(command, 1))
    python_s, cli_s = statistics.median(pass_s), statistics.median(help_s)
    return {'repeats': repeats, 'python -c pass (s)': round(python_s, 4),
            'social-touch --help (s)': round(cli_s, 4), 'ratio': round(cli_s / python_s, 2),
            'command': ' '.join(Path(command[0]).name if i == 0 else a for i, a in enumerate(command)),
            'graph queries': bench_graph_queries(repeats)}
