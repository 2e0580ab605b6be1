"""What the machine was doing during a benchmark: its CPU use, the benchmark's own, and everyone else's.

Read from Linux's ``/proc`` (elsewhere the figures are left out): ``/proc/stat`` for the whole
machine (busy, idle and, in a virtual machine, stolen time) and ``/proc/<pid>/stat`` for the
benchmark's processes, so a report can say how much of the machine other work took while the
figures were taken.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterable

__all__ = ['MachineLoad']


def _cpu_times() -> list[int] | None:
    """``/proc/stat``'s first line: user nice system idle iowait irq softirq steal (clock ticks), or None."""
    try:
        with open('/proc/stat', encoding='ascii') as f:
            return [int(v) for v in f.readline().split()[1:9]]
    except (OSError, ValueError):
        return None


def _process_ticks(pid: int) -> int:
    """User + system clock ticks a process has used (0 if it is gone)."""
    try:
        with open(f'/proc/{pid}/stat', encoding='ascii') as f:
            fields = f.read().rsplit(')', 1)[1].split()
        return int(fields[11]) + int(fields[12])
    except (OSError, ValueError, IndexError):
        return 0


class MachineLoad:
    """Measures between :meth:`start` and :meth:`stop` (call ``stop`` while the processes still run)."""

    def __init__(self) -> None:
        self._start: list[int] | None = None
        self._wall = 0.0
        self._ticks: dict[int, int] = {}
        self._load_before = (0.0, 0.0, 0.0)

    def start(self, pids: Iterable[int] = ()) -> None:
        """Start counting; ``pids`` are the benchmark's other processes (this one always counts)."""
        self._load_before = os.getloadavg()
        self._ticks = {pid: _process_ticks(pid) for pid in {os.getpid(), *pids}}
        self._start = _cpu_times()
        self._wall = time.monotonic()

    def stop(self) -> dict:
        """``{'cpus', 'wall_s', 'loadavg_before', 'loadavg_after', 'machine_busy_pct', 'bench_pct',
        'others_pct', 'steal_pct'}``; percentages of all CPUs over the wall time."""
        wall = time.monotonic() - self._wall
        end = _cpu_times()
        ours = sum(_process_ticks(pid) - start for pid, start in self._ticks.items())
        out: dict = {'cpus': os.cpu_count(), 'wall_s': round(wall, 1),
                     'loadavg_before': [round(v, 2) for v in self._load_before],
                     'loadavg_after': [round(v, 2) for v in os.getloadavg()]}
        if self._start is None or end is None:
            return out
        delta = [b - a for a, b in zip(self._start, end, strict=True)]
        total = sum(delta)
        if total <= 0:
            return out
        idle = delta[3] + delta[4]
        busy_pct = 100 * (total - idle) / total
        bench_pct = min(busy_pct, 100 * ours / total)
        out.update(machine_busy_pct=round(busy_pct, 1), bench_pct=round(bench_pct, 1),
                   others_pct=round(max(0.0, busy_pct - bench_pct), 1), steal_pct=round(100 * delta[7] / total, 1))
        return out
