"""``social-touch bench cli``: how long ``social-touch --help`` takes, beside ``python -c pass``.

Each is run ``repeats`` times as a user runs it, in a fresh interpreter (the console script
next to this Python when there is one, else ``python -m touch_lab.cli.main``); the medians
of the wall-clock times in seconds, and their ratio.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import time
from pathlib import Path

__all__ = ['bench_cli', 'help_command']


def help_command() -> list[str]:
    """The argv of ``social-touch --help`` as installed beside this interpreter."""
    script = Path(sys.executable).with_name('social-touch')
    if script.is_file():
        return [str(script), '--help']
    found = shutil.which('social-touch')
    return [found, '--help'] if found else [sys.executable, '-m', 'touch_lab.cli.main', '--help']


def _median_s(argv: list[str], repeats: int) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        subprocess.run(argv, check=True, capture_output=True)
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def bench_cli(repeats: int = 7) -> dict:
    """Medians (s) of ``python -c pass`` and ``social-touch --help``, interleaved run by run."""
    baseline = [sys.executable, '-c', 'pass']
    command = help_command()
    pass_s, help_s = [], []
    for _ in range(repeats):
        pass_s.append(_median_s(baseline, 1))
        help_s.append(_median_s(command, 1))
    python_s, cli_s = statistics.median(pass_s), statistics.median(help_s)
    return {'repeats': repeats, 'python -c pass (s)': round(python_s, 4),
            'social-touch --help (s)': round(cli_s, 4), 'ratio': round(cli_s / python_s, 2),
            'command': ' '.join(Path(command[0]).name if i == 0 else a for i, a in enumerate(command))}
