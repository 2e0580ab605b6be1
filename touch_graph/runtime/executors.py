"""Executors: run the callbacks of subscriptions and timers, one at a time, in one thread.

Each ``spin_once`` runs the inbox (work handed over by other threads), then one due
timer, or else one ready subscription (round robin), or else waits on the context's
time source until the next timer or until another thread brings work. A callback that
raises ends the spin call with its exception, as in rclpy (``rclpy.spin``, ``spin_once``
and every executor's ``spin*`` re-raise it): a node that must survive bad input catches
its own errors (:class:`~touch_graph.node_health.NodeHealth`). The exception is counted on
its node and the context, and :attr:`Executor.last_failure` says whose callback it was (the
launcher reports that node as dead). With a fast simulated clock, time only moves while
there is nothing to do, so a scene gives the same result on every run.
"""

from __future__ import annotations

import heapq
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..errors import GraphError
from .clock import SimTimeSource
from .context import Context, ExternalShutdownException, get_default_context

if TYPE_CHECKING:  # annotations only: nodes and their endpoints import nothing of the executor
    from .endpoints import Subscription, Timer
    from .node import Node

__all__ = ['Executor', 'MultiThreadedExecutor', 'SingleThreadedExecutor']

_get_ident = threading.get_ident
_monotonic = time.monotonic


class Executor:
    """Runs the callbacks of the nodes added to it (rclpy.executors.Executor)."""

    def __init__(self, *, context: Context | None = None) -> None:
        self.context = context or get_default_context()
        self._nodes: list[Node] = []
        self._ready: deque[Subscription] = deque()
        self._timers: list[tuple[int, int, int, Timer]] = []
        self._inbox: deque[tuple[Callable[..., Any], tuple]] = deque()
        self._wake: Any = threading.Event()
        self._dds_waker: Any = None  # replaces _wake on a networked context (touch_graph.dds.waker)
        self._thread_id: int | None = None
        self._spinning_in: int | None = None  # the thread inside a spin method now, if any
        self._spin_lock = threading.RLock()
        self._shutdown = False
        self.callbacks_run = 0
        #: ``(node or None, what)`` of the last callback that raised out of a spin call (not in rclpy).
        self.last_failure: tuple[Node | None, str] | None = None

    # ------------------------------------------------------------------ nodes
    def add_node(self, node: Node) -> bool:
        if node in self._nodes:
            return False
        if node.executor is not None and node.executor is not self:
            node.executor.remove_node(node)
        if node.context is not self.context:
            raise GraphError(f'node {node.get_fully_qualified_name()} belongs to another context')
        self._nodes.append(node)
        node.executor = self
        for entity in node._waitables():
            entity._executor = self
            if entity._queue and not entity._ready:
                entity._ready = True
                self._ready.append(entity)
            if entity._dds is not None:
                self._attach_reader(entity._dds)
        for timer in node.timers:
            timer._executor = self
            self._schedule(timer)
        for guard in node.guards:
            guard._schedule_pending()
        self.wake()
        return True

    def _attach_reader(self, reader: Any) -> None:
        """Take from ``reader`` (the DDS reader of one of our subscriptions) in this executor's thread."""
        waker = self._network_waker()
        if waker is None:
            return
        if reader.waker is not None and reader.waker is not waker:
            reader.waker.detach(reader)
        reader.waker = waker
        waker.attach(reader)
        waker.set()

    def _network_waker(self) -> Any:
        """The DDS wait this executor sleeps on, made on first need on a networked context (else None)."""
        transport = self.context.transport
        if self._dds_waker is not None and self._dds_waker.owner is not transport:
            self._dds_waker = None  # the context left the network (and maybe joined again)
            self._wake = threading.Event()
            self._wake.set()
        if self._dds_waker is None:
            if transport is None:
                return None
            waker = self._dds_waker = transport.make_waker()
            if self._wake.is_set():
                waker.set()
            self._wake = waker
            for node in self._nodes:
                for entity in node._waitables():
                    if entity._dds is not None and entity._dds.waker is None:
                        entity._dds.waker = waker
                        waker.attach(entity._dds)
        return self._dds_waker

    def remove_node(self, node: Node) -> None:
        if node not in self._nodes:
            return
        self._nodes.remove(node)
        node.executor = None
        for entity in node._waitables():
            entity._executor = None
            entity._ready = False
            reader = entity._dds
            if reader is not None and reader.waker is not None and reader.waker is self._dds_waker:
                reader.waker.detach(reader)
                reader.waker = None
        self._ready = deque(s for s in self._ready if s.node is not node)
        for timer in node.timers:
            timer._executor = None
            timer._generation += 1

    def get_nodes(self) -> list[Node]:
        return list(self._nodes)

    # ------------------------------------------------------------------ threads
    def call_soon_threadsafe(self, fn: Callable[..., Any], *args: Any) -> None:
        """Run ``fn(*args)`` in the spinning thread (safe from any thread)."""
        self._inbox.append((fn, args))
        self._wake.set()

    def wake(self) -> None:
        self._wake.set()

    def _schedule(self, timer: Timer) -> None:
        if not timer.is_canceled():
            heapq.heappush(self._timers, (timer._deadline_ns, timer._order, timer._generation, timer))

    # ------------------------------------------------------------------ spinning
    # Every public spin method holds the spin lock and records its thread, so a blocking
    # service call knows whether some thread spins this executor (it then waits), none does
    # (it spins it itself) or its own thread does (waiting would never end).
    def _begin(self) -> int | None:
        self._spin_lock.acquire()
        outer, self._spinning_in = self._spinning_in, threading.get_ident()
        return outer

    def _end(self, outer: int | None) -> None:
        self._spinning_in = outer
        self._spin_lock.release()

    def spin_once(self, timeout_sec: float | None = None) -> None:
        """Run at most one callback, waiting up to ``timeout_sec`` for one (None: forever)."""
        # _begin and _end inlined: a node spinning once per message pays them per message
        lock = self._spin_lock
        lock.acquire()
        outer, self._spinning_in = self._spinning_in, _get_ident()
        try:
            self._run_one(None if timeout_sec is None else max(0.0, timeout_sec), until_ns=None)
        finally:
            self._spinning_in = outer
            lock.release()

    def spin(self) -> None:
        """Run callbacks until the context shuts down (or :meth:`shutdown`)."""
        outer = self._begin()
        try:
            while self.context.ok() and not self._shutdown:
                self._run_one(0.5, until_ns=None)
        finally:
            self._end(outer)

    def spin_for(self, seconds: float) -> None:
        """Run callbacks for ``seconds`` of ROS time (simulated or real), then return."""
        end = self.context.now_ns() + int(seconds * 1e9)
        self.spin_until_time(end)

    def spin_until_time(self, end_ns: int) -> None:
        outer = self._begin()
        try:
            while self.context.ok() and not self._shutdown and self.context.now_ns() < end_ns:
                self._run_one(None, until_ns=end_ns)
            # Work due exactly at the end still runs, so a scene of N periods sees N frames.
            while self.context.ok() and not self._shutdown and self._run_ready_work():
                pass
        finally:
            self._end(outer)

    def spin_until(self, predicate: Callable[[], bool], timeout_sec: float | None = None) -> bool:
        """Spin until ``predicate()`` is true (returns True) or ``timeout_sec`` of ROS time pass."""
        end = None if timeout_sec is None else self.context.now_ns() + int(timeout_sec * 1e9)
        outer = self._begin()
        try:
            while self.context.ok() and not self._shutdown:
                if predicate():
                    return True
                if end is not None and self.context.now_ns() >= end:
                    return predicate()
                self._run_one(None if end is not None else 0.5, until_ns=end)
        finally:
            self._end(outer)
        return predicate()

    def spin_until_future_complete(self, future: Any, timeout_sec: float | None = None) -> None:
        """Spin until ``future`` is done or ``timeout_sec`` seconds of wall time pass (rclpy's semantics)."""
        deadline = None if timeout_sec is None else time.monotonic() + max(0.0, timeout_sec)
        outer = self._begin()
        try:
            while self.context.ok() and not self._shutdown and not future.done():
                left = 0.1 if deadline is None else deadline - time.monotonic()
                if left <= 0:
                    return
                self._run_one(min(left, 0.1), until_ns=None)
        finally:
            self._end(outer)

    def spinning_thread(self) -> int | None:
        """The ident of the thread spinning this executor now (None: nobody)."""
        return self._spinning_in

    def shutdown(self, timeout_sec: float | None = None) -> bool:
        self._shutdown = True
        self.wake()
        for node in list(self._nodes):
            self.remove_node(node)
        return True

    def _run_ready_work(self) -> bool:
        """Run one piece of work that is due now; False when there is none."""
        self._thread_id = _get_ident()
        inbox = self._inbox
        while inbox:
            fn, args = inbox.popleft()
            self._guarded(fn, args, None, 'cross-thread call')
        waker = self._dds_waker
        if waker is not None and (waker._pending or _monotonic() - waker._last_poll >= waker.poll_s):
            waker.take()  # (tested here, not in take(): this runs on every turn)
        timers = self._timers
        if timers:
            now = self.context.now_ns()
            while timers and timers[0][0] <= now:
                _, _, generation, timer = heapq.heappop(timers)
                if generation != timer._generation or timer.is_canceled() or timer._executor is not self:
                    continue
                timer._advance(now)
                self._schedule(timer)
                timer.calls += 1
                self._guarded(timer.callback, (), timer.node, 'timer')
                return True
        if self._ready:
            sub = self._ready.popleft()
            queue = sub._queue
            if not queue or sub._executor is not self:
                sub._ready = False
                return True
            item = queue.popleft()
            if queue:
                self._ready.append(sub)
            else:
                sub._ready = False
            self.callbacks_run += 1
            try:  # _guarded inlined: this is every subscription's path
                sub._handler(*item) if sub._packs else sub._handler(item)
            except (KeyboardInterrupt, SystemExit, ExternalShutdownException):
                raise
            except Exception as err:
                self._failed(err, sub.node, sub._what)
                raise
            return True
        return False

    def _run_one(self, timeout_sec: float | None, until_ns: int | None) -> None:
        if not self.context._ok:
            raise ExternalShutdownException('the context was shut down')
        if (self._dds_waker.owner if self._dds_waker is not None else None) is not self.context.transport:
            self._network_waker()
        self._wake.clear()
        if self._run_ready_work():
            return
        deadline = None
        while self._timers:
            head_deadline, _, generation, timer = self._timers[0]
            if generation == timer._generation and not timer.is_canceled() and timer._executor is self:
                deadline = head_deadline
                break
            heapq.heappop(self._timers)  # stale entry
        if until_ns is not None:
            deadline = until_ns if deadline is None else min(deadline, until_ns)
        if timeout_sec == 0:
            return
        if deadline is None:
            source = self.context.time_source
            if isinstance(source, SimTimeSource) and math.isinf(source.rate):
                # Nothing scheduled in a fast simulation: only another thread can bring work.
                self._wake.wait(timeout_sec if timeout_sec is not None else 0.5)
            else:  # no deadline to convert to wall time: what every time source's wait_until would do
                self._wake.wait(timeout_sec)
        else:
            self.context.time_source.wait_until(deadline, self._wake, timeout_sec)
        # Run what woke us (a sample, a due timer) in this call, as rclpy's spin_once does,
        # rather than returning to the caller's loop for another round first.
        if self.context._ok:  # (ok() inlined: every message's path)
            self._run_ready_work()

    def _guarded(self, fn: Callable[..., Any], args: tuple, node: Node | None, what: str) -> None:
        self.callbacks_run += 1
        try:
            fn(*args)
        except (KeyboardInterrupt, SystemExit, ExternalShutdownException):
            raise
        except Exception as err:
            self._failed(err, node, what)
            raise

    def _failed(self, err: Exception, node: Node | None, what: str) -> None:
        """Count a callback's exception and say whose it was, before it ends the spin call (rclpy's rule)."""
        self.context.callback_errors += 1
        self.last_failure = (node, what)
        if node is not None:
            node.callback_errors += 1
            where = f'the {what} callback of node {node.get_fully_qualified_name()}'
        else:
            where = f'a {what} in executor {type(self).__name__}'
        err.add_note(f'raised by {where}; as in rclpy, it ends the spin (a node catches the errors it can survive)')


class SingleThreadedExecutor(Executor):
    """All callbacks in the thread that spins (the default)."""


class MultiThreadedExecutor(Executor):
    """Accepted for compatibility; runs callbacks in one thread so simulated runs stay deterministic."""

    def __init__(self, num_threads: int | None = None, *, context: Context | None = None) -> None:
        super().__init__(context=context)
