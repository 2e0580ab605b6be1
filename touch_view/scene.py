"""Run a launch file's graph in a background thread, for the view's tests, screenshot and benchmark.

A scene is a launch file (its nodes on virtual devices or real ports); :class:`BackgroundScene`
starts its nodes in this process on a simulated clock running ``rate`` times real time and
spins them in a thread, so the caller (a browser, a client) can watch it live::

    with BackgroundScene('launch/demo.launch.yaml', {'view': 'true', 'view_port': '0'}, rate=2.0) as scene:
        url = scene.node('touch_view').url
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from touch_graph.errors import LaunchError
from touch_graph.launch import LaunchRunner, evaluate_launch

__all__ = ['BackgroundScene']


class BackgroundScene:
    """The nodes of a launch file, spinning in a thread on a simulated clock.

    Args:
        launch_file: the ROS 2 YAML launch file.
        arguments: its launch arguments (``name -> value``).
        rate: simulated seconds per wall second.
        duration_s: simulated seconds to run at most (None: until :meth:`stop`).
    """

    def __init__(self, launch_file: str | Path, arguments: dict[str, str] | None = None, *, rate: float = 1.0,
                 duration_s: float | None = None) -> None:
        plan = evaluate_launch(Path(launch_file), dict(arguments or {}))
        self.runner = LaunchRunner(plan.nodes, sim_time=True, rate=rate)
        self.duration_s = duration_s
        self._thread: threading.Thread | None = None
        self.error: BaseException | None = None

    def start(self) -> BackgroundScene:
        """Start the nodes (errors raise here, in the caller's thread), then spin them in a thread."""
        self.runner.start()
        self._thread = threading.Thread(target=self._spin, name='scene', daemon=True)
        self._thread.start()
        return self

    def _spin(self) -> None:
        try:
            self.runner.spin(self.duration_s, handle_signals=False)
        except BaseException as err:  # handed to the caller by stop()
            self.error = err

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def node(self, name: str) -> Any:
        """The started node called ``name``."""
        for node in self.runner.nodes:
            if node.get_name() == name:
                return node
        raise LaunchError(f"the scene has no node '{name}'; it has: "
                          f'{", ".join(n.get_name() for n in self.runner.nodes)}')

    def call_in_graph(self, fn: Any, *args: Any) -> None:
        """Run ``fn(*args)`` in the graph's thread (e.g. destroy a driver to make its sensor go silent)."""
        self.runner.executor.call_soon_threadsafe(fn, *args)

    def join(self, timeout_s: float | None = None) -> None:
        """Wait for the scene's duration to pass."""
        if self._thread is not None:
            self._thread.join(timeout_s)

    def stop(self) -> None:
        """Stop spinning, destroy the nodes; re-raises an error the spinning thread met. Safe twice."""
        self.runner.request_stop()
        if self._thread is not None:
            self._thread.join(timeout=30.0)
            self._thread = None
        self.runner.shutdown()
        if self.error is not None:
            error, self.error = self.error, None
            raise error

    def __enter__(self) -> BackgroundScene:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.stop()
