"""The feeder of ``bench wall-clock``: a process of its own that writes recorded sensor bytes into
pseudo-terminals at the sensors' real rates, on the wall clock.

``python -c FEED_MAIN PLAN`` (:data:`touch_lab.bench.wall_clock.FEED_MAIN`) reads the plan (a pickle: ``seconds`` and
``feeds``, a list of ``(master_fd, period_s, chunks)``; the fds are inherited), prints ``ready``,
waits for a line on stdin, then writes chunk ``i`` of each feed at ``i * period_s`` (looping over
the chunks) for ``seconds`` and prints one JSON line: frames written per feed and the latest
write's lateness (s).
"""

from __future__ import annotations

import heapq
import json
import os
import pickle
import sys
import time


def feed(seconds: float, feeds: list[tuple[int, float, list[bytes]]]) -> dict:
    """Write every feed's chunks at their times for ``seconds``; returns what was written."""
    sent = [0] * len(feeds)
    late = 0.0
    heap = [(0.0, k, 0) for k in range(len(feeds))]
    start = time.monotonic()
    while heap:
        due, k, i = heapq.heappop(heap)
        if due >= seconds:
            continue
        wait = start + due - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        else:
            late = max(late, -wait)
        fd, period, chunks = feeds[k]
        view = memoryview(chunks[i % len(chunks)])
        while view:
            view = view[os.write(fd, view):]
        sent[k] += 1
        heapq.heappush(heap, ((i + 1) * period, k, i + 1))   # not due + period: no drift
    return {'sent': sent, 'max_late_s': late, 'wall_s': time.monotonic() - start}


def main() -> int:
    with open(sys.argv[1], 'rb') as file:
        plan = pickle.load(file)
    print('ready', flush=True)
    sys.stdin.readline()
    print(json.dumps(feed(plan['seconds'], plan['feeds'])), flush=True)
    return 0
