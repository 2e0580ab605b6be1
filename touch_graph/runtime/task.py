"""``Future``: the outcome of a service call (``rclpy.task.Future``).

Completed once, with a result or an exception, by the thread delivering the response;
``result()`` does not wait (None while pending). Done callbacks run in the completing thread;
one that raises is logged and the others still run.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from typing import Any

__all__ = ['Future']

_log = logging.getLogger('touch_graph.runtime')


class Future:
    """A result that arrives later (``rclpy.task.Future``)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._event = threading.Event()
        self._state = 'pending'  # 'pending' | 'done' | 'cancelled'
        self._result: Any = None
        self._exception: BaseException | None = None
        self._callbacks: list[Callable[[Future], None]] = []

    def __repr__(self) -> str:
        return f'<Future {self._state}>'

    # ------------------------------------------------------------------ state
    def done(self) -> bool:
        """True once a result or an exception is set, or the future is cancelled."""
        return self._state != 'pending'

    def cancelled(self) -> bool:
        return self._state == 'cancelled'

    def result(self) -> Any:
        """The result; raises the exception that was set; None while pending or when cancelled."""
        if self._exception is not None:
            raise self._exception
        return self._result

    def exception(self) -> BaseException | None:
        return self._exception

    def wait(self, timeout_sec: float | None = None) -> bool:
        """Block until done (another thread must complete it); True if done. Not in rclpy."""
        return self._event.wait(timeout_sec)

    # ------------------------------------------------------------------ completion
    def set_result(self, result: Any) -> None:
        self._complete('done', result, None)

    def set_exception(self, exception: BaseException) -> None:
        self._complete('done', None, exception)

    def cancel(self) -> None:
        """Give up on the result: the future is done and cancelled (a late result is ignored)."""
        self._complete('cancelled', None, None)

    def _complete(self, state: str, result: Any, exception: BaseException | None) -> None:
        with self._lock:
            if self._state != 'pending':
                return  # completed already (a second reply from another server, a late one): ignored
            self._state, self._result, self._exception = state, result, exception
            callbacks, self._callbacks = self._callbacks, []
        self._event.set()
        for callback in callbacks:
            self._run(callback)

    def add_done_callback(self, callback: Callable[[Future], None]) -> None:
        """Call ``callback(future)`` when done (at once, in this thread, if it is done already)."""
        with self._lock:
            if self._state == 'pending':
                self._callbacks.append(callback)
                return
        self._run(callback)

    def remove_done_callback(self, callback: Callable[[Future], None]) -> bool:
        with self._lock:
            if callback in self._callbacks:
                self._callbacks.remove(callback)
                return True
        return False

    def _run(self, callback: Callable[[Future], None]) -> None:
        try:
            callback(self)
        except Exception:  # one bad callback must not keep the others from running
            _log.exception('a done callback of %r raised', self)
