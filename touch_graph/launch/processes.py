"""Nodes in processes of their own: start, watch, restart and stop them as ros2 launch does.

Process names (``<name>-<n>``), output prefixes and life reports follow ros2 launch.
``respawn`` restarts after ``respawn_delay`` at most ``respawn_max_retries`` times (-1: no
limit); a process that dies within :data:`STABLE_S` of starting waits longer each time
(from :data:`FIRST_BACKOFF_S`, doubling, up to :data:`MAX_BACKOFF_S`). Shutdown: SIGINT,
SIGTERM after ``sigterm_timeout``, SIGKILL after ``sigkill_timeout`` more. Each node process runs
:func:`node_process_main` and dies with the launcher (``prctl(PR_SET_PDEATHSIG)``).
"""

from __future__ import annotations

import contextlib
import ctypes
import itertools
import os
import shlex
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from typing import TextIO

from ..errors import SocialTouchError
from ..node_main import StopSignals
from .runner import LaunchRunner, rclpy_runtime
from .specs import NodeSpec, ProcessOptions, spec_from_json, spec_to_json

__all__ = ['FIRST_BACKOFF_S', 'MAX_BACKOFF_S', 'NODE_PROCESS_MAIN', 'STABLE_S', 'NodeProcess', 'ProcessSupervisor',
           'node_process_main']

#: A process that ran at least this long before exiting is restarted after its plain respawn_delay, s.
STABLE_S = 10.0
#: The delay before restarting a process that died within STABLE_S, doubled for each such death in a row, s.
FIRST_BACKOFF_S = 0.5
MAX_BACKOFF_S = 30.0
#: How often the supervisor looks at its processes, s.
POLL_S = 0.1


def _log(level: str, who: str, text: str, stream: TextIO | None = None) -> None:
    (stream or sys.stderr).write(f'[{level}] [{who}]: {text}\n')
    (stream or sys.stderr).flush()


@dataclass
class NodeProcess:
    """One node's process and its history.

    Attributes:
        label: ``<name>-<n>``, as ros2 launch names processes.
        restarts: times it was restarted; quick_deaths: deaths within STABLE_S of starting, in a row.
        exit_codes: every exit code seen (negative: killed by that signal).
    """

    spec: NodeSpec
    label: str
    options: ProcessOptions
    proc: subprocess.Popen | None = None
    started_at: float = 0.0
    restart_at: float | None = None
    restarts: int = 0
    quick_deaths: int = 0
    exit_codes: list[int] = field(default_factory=list)
    reported: bool = False  # its last exit was handled (reported, restart planned)
    _reader: threading.Thread | None = None

    @property
    def running(self) -> bool:
        return self.proc is not None and self.proc.poll() is None

    def command(self, strict_params: bool = False) -> list[str]:
        return [sys.executable, '-c', NODE_PROCESS_MAIN, spec_to_json(self.spec), str(os.getpid()),
                *(['--strict-params'] if strict_params else [])]


class ProcessSupervisor:
    """Starts the node processes of a launch and keeps them as the launch file says (see the module doc).

    Args:
        specs: the nodes to run alone.
        stream: where reports and the processes' prefixed output go (default stderr).
        env: the processes' environment (default this process's).
        strict_params: a parameter no node declares stops that node (``launch --strict-params``).
    """

    def __init__(self, specs: list[NodeSpec], stream: TextIO | None = None,
                 env: dict[str, str] | None = None, strict_params: bool = False) -> None:
        counter = itertools.count(1)
        self.processes = [NodeProcess(spec, f'{spec.name or spec.exec}-{next(counter)}',
                                      spec.process or ProcessOptions()) for spec in specs]
        self.stream = stream
        self.env = env
        self.strict_params = strict_params
        self.stopping = False
        self.died = 0  # exits with a non-zero code while the launch ran
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ starting
    def start(self) -> None:
        for process in self.processes:
            self._spawn(process)

    def _spawn(self, process: NodeProcess) -> None:
        command = process.command(self.strict_params)
        process.proc = subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                                        bufsize=1, start_new_session=True, env=self.env)
        process.started_at = time.monotonic()
        process.restart_at = None
        process.reported = False
        process._reader = threading.Thread(target=self._relay, args=(process, process.proc), daemon=True,
                                           name=f'output-{process.label}')
        process._reader.start()
        _log('INFO', process.label, f'process started with pid [{process.proc.pid}]', self.stream)

    def _relay(self, process: NodeProcess, proc: subprocess.Popen) -> None:
        """Copy the process's output, each line prefixed with its label (ros2 launch's ``output: screen``)."""
        stream = self.stream or sys.stderr
        for line in proc.stdout:
            with self._lock:
                stream.write(f'[{process.label}] {line}' if line.endswith('\n') else f'[{process.label}] {line}\n')
                stream.flush()
        proc.stdout.close()

    # ------------------------------------------------------------------ watching
    def poll(self) -> None:
        """Report processes that exited; restart the ones due (call often, e.g. every POLL_S)."""
        now = time.monotonic()
        for process in self.processes:
            proc = process.proc
            if proc is not None and not process.reported and proc.poll() is not None:
                process.reported = True
                self._exited(process, proc, now)
            if process.restart_at is not None and now >= process.restart_at and not self.stopping:
                process.restarts += 1
                self._spawn(process)

    def _exited(self, process: NodeProcess, proc: subprocess.Popen, now: float) -> None:
        code = proc.returncode
        process.exit_codes.append(code)
        if process._reader is not None:
            process._reader.join(timeout=1.0)  # its last lines before the report
        if self.stopping:
            return
        if code == 0:
            _log('INFO', process.label, f'process has finished cleanly [pid {proc.pid}]', self.stream)
        else:
            self.died += 1
            cmd = shlex.join(proc.args[:3]) + ' ...'
            _log('ERROR', process.label, f"process has died [pid {proc.pid}, exit code {code}, cmd '{cmd}']",
                 self.stream)
        options = process.options
        if not options.respawn:
            return
        if 0 <= options.respawn_max_retries <= process.restarts:
            _log('ERROR', process.label, f'not restarting it again: it was restarted {process.restarts} times '
                                         f'(respawn_max_retries)', self.stream)
            return
        ran = now - process.started_at
        if ran < STABLE_S:
            process.quick_deaths += 1
            delay = max(options.respawn_delay, min(MAX_BACKOFF_S, FIRST_BACKOFF_S * 2 ** (process.quick_deaths - 1)))
            _log('WARN', process.label, f'it died {ran:.1f} s after starting ({process.quick_deaths} time(s) in a '
                                        f'row within {STABLE_S:g} s); restarting in {delay:g} s', self.stream)
        else:
            process.quick_deaths = 0
            delay = options.respawn_delay
            _log('INFO', process.label, f'restarting in {delay:g} s (respawn)', self.stream)
        process.restart_at = now + delay

    def active(self) -> bool:
        """True while some process runs, waits for its restart, or exited and :meth:`poll` has not seen it yet."""
        return any(p.proc is not None and (not p.reported or p.restart_at is not None) for p in self.processes)

    # ------------------------------------------------------------------ stopping
    def stop(self) -> None:
        """SIGINT every process, then SIGTERM and SIGKILL after their timeouts; wait for all of them."""
        self.stopping = True
        running = [p for p in self.processes if p.running]
        for process in running:
            self._signal(process, signal.SIGINT)
        for process in running:
            proc = process.proc
            for timeout, then in ((process.options.sigterm_timeout, signal.SIGTERM),
                                  (process.options.sigkill_timeout, signal.SIGKILL)):
                try:
                    proc.wait(timeout)
                    break
                except subprocess.TimeoutExpired:
                    _log('WARN', process.label, f'still running {timeout:g} s after the last signal; sending '
                                                f'{then.name}', self.stream)
                    self._signal(process, then)
            else:
                proc.wait()
            process.exit_codes.append(proc.returncode)
            if process._reader is not None:
                process._reader.join(timeout=1.0)
            _log('INFO', process.label, f'process stopped [pid {proc.pid}, exit code {proc.returncode}]', self.stream)

    @staticmethod
    def _signal(process: NodeProcess, signum: int) -> None:
        with contextlib.suppress(ProcessLookupError):  # exited in the meantime
            process.proc.send_signal(signum)


#: What the launcher runs with ``python -c`` (no module of ours has a ``__main__`` of its own).
NODE_PROCESS_MAIN = ('import sys; from touch_graph.launch.processes import node_process_main; '
                     'sys.exit(node_process_main())')

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


def node_process_main(argv: list[str] | None = None) -> int:
    """One launched node in a process of its own: ``python -c "$NODE_PROCESS_MAIN" SPEC_JSON PARENT_PID
    [--strict-params]``. Exits 0 after a clean stop, 1 when the node cannot start or a callback raised."""
    argv = sys.argv[1:] if argv is None else argv
    strict = '--strict-params' in argv
    argv = [a for a in argv if a != '--strict-params']
    if len(argv) != 2:
        sys.stderr.write('usage: node_process_main SPEC_JSON PARENT_PID [--strict-params] (the launcher starts it)\n')
        return 2
    die_with_parent(int(argv[1]))
    spec = spec_from_json(argv[0])
    from .. import compat  # lazy: the launcher imports this module without loading the runtime
    if compat.USING_ROS:  # a sourced ROS 2 and no SOCIAL_TOUCH_SHIM: the node is an rclpy node
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
