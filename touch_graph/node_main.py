"""``run_node(NodeClass)``: what every node module's ``main()`` calls (``ros2 run social_touch bear_driver``).

::

    def main(args=None):
        return run_node(BearDriver, args)

Initialises the context with ``args`` (``--ros-args ...``), which joins the DDS domain, makes the
node and spins until Ctrl-C or SIGTERM, then shuts down; under real rclpy it does the same with rclpy.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from typing import Any

from .errors import SocialTouchError

__all__ = ['StopSignals', 'run_node']


class StopSignals:
    """Turn SIGINT/SIGTERM into a request to stop (a flag), so loops finish their work and clean up.

    A second signal raises KeyboardInterrupt, for a process that does not stop. Only the
    main thread can install handlers; elsewhere this does nothing but hold the flag.

    Args:
        wake: called from the handler, e.g. an executor's ``wake``, so a waiting loop notices.
    """

    def __init__(self, wake: Callable[[], None] | None = None) -> None:
        self.event = threading.Event()
        self.signal: int | None = None
        self._wake = wake
        self._old: dict[int, Any] = {}

    @property
    def requested(self) -> bool:
        return self.event.is_set()

    def _handle(self, signum: int, _frame: Any) -> None:
        if self.event.is_set():
            raise KeyboardInterrupt  # the second Ctrl-C: stop now
        self.signal = signum
        self.event.set()
        if self._wake is not None:
            self._wake()

    def wake_with(self, wake: Callable[[], None]) -> None:
        """Call ``wake`` on the next signal (and now, if one came already), e.g. once an executor exists."""
        self._wake = wake
        if self.event.is_set():
            wake()

    def __enter__(self) -> StopSignals:
        if threading.current_thread() is threading.main_thread():
            for sig in (signal.SIGINT, signal.SIGTERM):
                self._old[sig] = signal.signal(sig, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        for sig, old in self._old.items():
            signal.signal(sig, old)
        self._old.clear()


def run_node(node_class: type, args: list[str] | None = None) -> int:
    """Run one node in this process until Ctrl-C/SIGTERM; 0 on a clean stop, 1 when it cannot start."""
    from .compat import USING_ROS  # lazy: the CLI imports StopSignals without loading rclpy or the runtime
    if USING_ROS:  # pragma: no cover - exercised on a ROS 2 machine
        return _run_rclpy(node_class, args)
    from .runtime import SingleThreadedExecutor, get_default_context  # ours only where rclpy is not used
    from .runtime.override_check import check_overrides

    argv = list(sys.argv[1:] if args is None else args)
    context = get_default_context()
    prog = getattr(node_class, '__name__', 'node')
    # Handlers before the node exists: a Ctrl-C while it starts is a clean stop, not a traceback.
    with StopSignals() as stop:
        try:
            context.init(argv)
            node = node_class()
            check_overrides([node], node.get_logger())  # a misspelt -p or params-file name: warn, file and line
        except SocialTouchError as err:
            sys.stderr.write(f'{prog}: error: {err}\n')
            context.try_shutdown()
            return 1
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)
        stop.wake_with(executor.wake)
        try:
            while context.ok() and not stop.requested:
                executor.spin_once(0.5)
        except KeyboardInterrupt:
            pass
        finally:
            node.destroy_node()
            executor.shutdown()
            context.try_shutdown()
    return 0


def _run_rclpy(node_class: type, args: list[str] | None) -> int:  # pragma: no cover - needs ROS 2
    import rclpy  # only on a ROS 2 machine
    from rclpy.executors import ExternalShutdownException
    rclpy.init(args=args)
    node = None
    try:
        node = node_class()
        rclpy.spin(node)
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
