"""Helper for tests of the compiled extensions: no reference or memory block leaks over many calls."""

from __future__ import annotations

import gc
import sys
from collections.abc import Callable, Sequence


def assert_no_leak(run: Callable[[int], None], watched: Sequence[object], warm: int = 100, times: int = 2000,
                   blocks: int = 100) -> None:
    """``run(n)`` makes n rounds of calls (successes and failures); after ``warm`` rounds (caches, interned names,
    the first exceptions' types), ``times`` more leave every ``watched`` object's reference count as it was and
    fewer than ``blocks`` new memory blocks (one leaked array, message or codebook per round would be thousands)."""
    run(warm)
    gc.collect()
    before = [sys.getrefcount(obj) for obj in watched]
    start = sys.getallocatedblocks()
    run(times)
    gc.collect()
    assert [sys.getrefcount(obj) for obj in watched] == before
    assert sys.getallocatedblocks() - start < blocks
