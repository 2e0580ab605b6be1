"""Helpers shared by the project's benchmarks (``social-touch bench ...``)."""

from __future__ import annotations

import contextlib
import gc
from collections.abc import Iterator

__all__ = ['gc_paused']


@contextlib.contextmanager
def gc_paused() -> Iterator[None]:
    """Pause the garbage collector while timing: a collection inside one repeat is noise, not
    the cost of the code. The collector is restored as it was, also on an exception.

    >>> with gc_paused():
    ...     gc.isenabled()
    False
    """
    was_enabled = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if was_enabled:
            gc.enable()
