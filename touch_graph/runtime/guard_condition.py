"""``node.create_guard_condition(callback)``: another thread wakes the executor to run ``callback`` there.

Triggers before the executor takes the condition are one call (a flag, not a counter), and a
trigger before the node joins an executor runs once it does, as in rclpy.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from .node import Node

__all__ = ['GuardCondition']


class GuardCondition:
    """rclpy.guard_condition.GuardCondition, made by :meth:`Node.create_guard_condition`."""

    def __init__(self, node: Node, callback: Callable[[], Any] | None) -> None:
        self.node = node
        self.callback = callback
        self._triggered = False
        self._destroyed = False
        self._lock = threading.Lock()

    def trigger(self) -> None:
        """Ask the node's executor to run the callback (safe from any thread)."""
        with self._lock:
            if self._triggered or self._destroyed:
                return
            self._triggered = True
        executor = self.node.executor
        if executor is not None:
            executor.call_soon_threadsafe(self._take)

    def _schedule_pending(self) -> None:
        """Called by an executor the node joins: run a trigger that came before it."""
        if self._triggered and not self._destroyed and self.node.executor is not None:
            self.node.executor.call_soon_threadsafe(self._take)

    def _take(self) -> None:
        with self._lock:
            if not self._triggered or self._destroyed:
                return
            self._triggered = False
        if self.callback is not None:
            self.callback()        # in the executor's thread (its inbox)

    def destroy(self) -> None:
        self._destroyed = True
