"""One launched node in a process of its own: ``python -c "$NODE_PROCESS_MAIN" SPEC_JSON PARENT_PID [--strict-params]``.

Exits 0 after a clean stop, 1 when the node cannot start or a callback raised; dies with
the launcher (``prctl(PR_SET_PDEATHSIG)``).
"""

from __future__ import annotations

import ctypes
import os
import signal
import sys

from ..errors import SocialTouchError

__all__ = ['NODE_PROCESS_MAIN', 'main']

#: What the launcher runs with ``python -c`` (no module of ours has a ``__main__`` of its own).
NODE_PROCESS_MAIN = 'import sys; from touch_graph.launch.node_process import main; sys.exit(main())'

_PR_SET_PDEATHSIG = 1


def die_with_parent(parent_pid: int) -> None:
    """Ask Linux for SIGTERM when the parent dies; exit now if it already has (the race before the call)."""
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        libc.prctl(_PR_SET_PDEATHSIG, signal.SIGTERM, 0, 0, 0)
    except (OSError, AttributeError):  # not Linux: the launcher's shutdown still stops it
        pass
    if os.getppid() != parent_pid:
        sys.exit(1)


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    strict = '--strict-params' in argv
    argv = [a for a in argv if a != '--strict-params']
    if len(argv) != 2:
        sys.stderr.write('usage: node_process SPEC_JSON PARENT_PID [--strict-params] (the launcher starts it)\n')
        return 2
    die_with_parent(int(argv[1]))
    from ..node_main import StopSignals
    from .runner import LaunchRunner
    from .specs import spec_from_json
    spec = spec_from_json(argv[0])
    from .. import compat
    if compat.USING_ROS:  # a sourced ROS 2 and no SOCIAL_TOUCH_SHIM: the node is an rclpy node
        from .runner import rclpy_runtime
        runner = LaunchRunner([spec], runtime=rclpy_runtime(), strict_params=strict)
    else:
        runner = LaunchRunner([spec], network=True, strict_params=strict)
    # Handlers from the first line on: the launcher may stop us while the node is still starting
    # (a SIGINT then must still end in a clean shutdown and exit code 0, not a KeyboardInterrupt).
    with StopSignals(wake=runner.request_stop):
        try:
            runner.start()
        except SocialTouchError as err:
            sys.stderr.write(f'error: {err}\n')
            return 1
        try:
            runner.spin(handle_signals=False)  # returns at once when a stop came during start()
        except KeyboardInterrupt:  # a second signal: stop now
            pass
        finally:
            runner.shutdown()
    return 1 if runner.died else 0  # a callback raised: the node died, as under rclpy

