"""``social-touch collect SENSOR --person NAME --out BAG``: a guided session with a real person on the running graph.

Records the sensor driver's topics to one session bag (:class:`~.session_bag.SessionWriter`) and walks
the protocol's shuffled trials, prompting in the terminal and on :data:`PROMPT_TOPIC` (latched). Keys,
each followed by Enter: Enter (start / end the trial), ``r`` (redo the last), ``d`` (drop the last,
not asked again), ``q`` or end of input or Ctrl-C (end; every kept trial and frame is in the bag).
A trial's start and end are the ``header.stamp`` of the sensor's newest frame when the key arrives.
A label is written when the next trial starts, so only the last trial can be redone or dropped.
"""

from __future__ import annotations

import os
import queue
import select
import shutil
import sys
import threading
import time
from collections import deque
from collections.abc import Callable
from pathlib import Path
from typing import Any

from touch_graph import messages
from touch_graph.dds.qos import adapted_profile
from touch_graph.dds.tool import GraphTool
from touch_graph.messages import get_message
from touch_graph.node_main import StopSignals
from touch_graph.runtime.qos import DurabilityPolicy, QoSProfile

from .protocol import Protocol, Trial
from .session_bag import FRAME_TOPIC, SENSOR_TOPICS, SessionWriter

__all__ = ['PROMPT_TOPIC', 'LiveSessionError', 'TerminalLines', 'live_session']

#: Where the current prompt is published (latched), for the live view.
PROMPT_TOPIC = '/touch/collect_prompt'
_NS = 1_000_000_000
_KEYS = 'Enter = start, r = redo the last trial, d = drop the last trial, q = end the session'


class LiveSessionError(RuntimeError):
    """The session cannot start: no graph, no publisher of the sensor's topics, no frames."""


class TerminalLines:
    """The operator's lines from standard input, read from its file descriptor (a ``read_line``).

    Unlike ``input()``, a reader blocked here gives up within ``poll_s`` once ``stop`` is set, so no
    thread is left holding stdin's lock when the process exits (CPython aborts on that).
    """

    def __init__(self, stop: threading.Event, fd: int | None = None, poll_s: float = 0.2) -> None:
        self.stop = stop
        self.fd = sys.stdin.fileno() if fd is None else fd
        self.poll_s = poll_s
        self._buffer = b''

    def __call__(self, _prompt: str) -> str:
        while b'\n' not in self._buffer:
            if self.stop.is_set():
                raise EOFError
            ready, _, _ = select.select([self.fd], [], [], self.poll_s)
            if ready:
                chunk = os.read(self.fd, 4096)
                if not chunk:
                    if self._buffer:   # a last line without its newline
                        line, self._buffer = self._buffer, b''
                        return line.decode(errors='replace')
                    raise EOFError
                self._buffer += chunk
        line, self._buffer = self._buffer.split(b'\n', 1)
        return line.decode(errors='replace')


def _key_reader(read_line: Callable[[str], str], keys: queue.Queue) -> threading.Thread:
    """A daemon thread putting the operator's lines (stripped, lower case) on ``keys``; None at end of input."""
    def loop() -> None:
        while True:
            try:
                line = read_line('')
            except (EOFError, OSError, ValueError):   # end of input, or stdin closed under us
                keys.put(None)
                return
            keys.put(line.strip().lower())
    thread = threading.Thread(target=loop, name='collect-keys', daemon=True)
    thread.start()
    return thread


class _Recorder:
    """Subscribes to the sensor's topics as they appear and writes them raw; keeps the graph's ROS time."""

    def __init__(self, tool: Any, writer: SessionWriter, sensor: str) -> None:
        self.tool = tool
        self.writer = writer
        self.sensor = sensor
        self.subscriptions: dict[str, Any] = {}
        self.frames = 0
        self.clock_ns: int | None = None   # header.stamp of the newest frame
        self.stopped = False

    def update(self) -> None:
        for topic, info in self.tool.graph().published_topics().items():
            if topic in self.subscriptions or topic not in SENSOR_TOPICS[self.sensor]:
                continue
            type_name = SENSOR_TOPICS[self.sensor][topic]
            offered = [ep.qos for ep in info.publishers]
            self.subscriptions[topic] = self.tool.node.create_subscription(
                get_message(type_name), topic, self._writer(topic), adapted_profile(offered, depth=1000), raw=True)

    def _writer(self, topic: str) -> Callable[[bytes, dict], None]:
        is_frame = topic == FRAME_TOPIC[self.sensor]
        type_name = SENSOR_TOPICS[self.sensor][topic]

        def write(data: bytes, info: dict) -> None:
            if self.stopped:   # the bag is closed: the session is over
                return
            stamp = int(info['source_timestamp'])
            if is_frame:
                header = messages.deserialize(data, type_name).header.stamp
                stamp = int(header.sec) * _NS + int(header.nanosec)
                self.clock_ns = stamp if self.clock_ns is None else max(self.clock_ns, stamp)
                self.frames += 1
            self.writer.write_raw(topic, data, stamp)
        return write


def live_session(sensor: str, protocol: Protocol, person: str, out: str | Path, *,
                 read_line: Callable[[str], str] | None = None, say: Callable[[str], None] = print,
                 wait_s: float = 5.0, synthetic: bool = False) -> dict[str, int]:
    """Run one live session of ``person`` and write it to the bag ``out`` (module doc).

    Args:
        sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
        protocol: the trials to prompt, shuffled by its seed.
        person: the person's name, written into every label.
        out: the bag directory to create (must not exist).
        read_line: returns the operator's next line (default :class:`TerminalLines`: standard input; tests pass
            a script); EOFError ends the session.
        say: where prompts and progress go.
        wait_s: how long to wait for the sensor's publisher and its first frame, wall s.
        synthetic: mark the bag synthetic (the running scene plays a virtual device).

    Returns: ``{'kept': labels written, 'trials': trials of the protocol, 'frames': frames recorded}``.

    Raises:
        LiveSessionError: no publisher of the sensor's frames, or no frame, within ``wait_s``.
    """
    frame_topic = FRAME_TOPIC[sensor]
    with GraphTool(f'collect_{sensor}', discovery_timeout_s=min(wait_s, 2.0)) as tool:
        if not tool.wait_until(lambda v: frame_topic in v.published_topics(), wait_s):
            domain = tool.context.transport.domain_id
            raise LiveSessionError(
                f'nobody publishes {frame_topic} in DDS domain {domain} (waited {wait_s:g} s):'
                f' is the scene running? start it in another terminal with `social-touch launch launch/'
                f'{sensor}.launch.yaml` (or {sensor}_driver.launch.yaml {sensor}_port:=/dev/ttyACM0 on the robot),'
                ' with the same ROS_DOMAIN_ID')
        string = get_message('std_msgs/msg/String')
        prompts = tool.node.create_publisher(string, PROMPT_TOPIC,
                                             QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        with SessionWriter(out, sensor, synthetic=synthetic) as writer:
            recorder = _Recorder(tool, writer, sensor)
            recorder.update()
            with StopSignals(tool.executor.wake) as stop:
                if not tool.spin_until(lambda: recorder.clock_ns is not None, wait_s, stop=stop,
                                       every=recorder.update, every_s=0.2):
                    writer.close()
                    shutil.rmtree(writer.path, ignore_errors=True)   # an empty bag would only mislead
                    raise LiveSessionError(f'{frame_topic} has a publisher but sent no frame in {wait_s:g} s; '
                                           'is the sensor plugged in? see `social-touch topic hz ' + frame_topic + '`')
                session = _Walk(tool, writer, recorder, protocol, person, stop, say,
                                lambda text: prompts.publish(string(data=text)))
                finished = threading.Event()
                try:
                    session.run(read_line or TerminalLines(finished))
                finally:
                    finished.set()   # the terminal reader lets go of stdin
                # What arrived before the end is still in the executor's inbox: record it too.
                for _ in range(20):
                    tool.executor.spin_once(0)
                recorder.stopped = True
            prompts.publish(string(data=''))
            tool.spin_until(lambda: False, 0.2)   # let the view see that the session ended
    return {'kept': writer.labels, 'trials': session.total, 'frames': recorder.frames}


class _Walk:
    """The operator's walk through the trials (module doc: keys, when labels are written)."""

    def __init__(self, tool: Any, writer: SessionWriter, recorder: _Recorder, protocol: Protocol, person: str,
                 stop: Any, say: Callable[[str], None], show: Callable[[str], None]) -> None:
        self.tool, self.writer, self.recorder = tool, writer, recorder
        self.person, self.stop, self.say, self.show = person, stop, say, show
        self.todo: deque[Trial] = deque(protocol.trials())
        self.total = len(self.todo)
        self.pending: tuple[Trial, int, int] | None = None   # the last trial: kept, label not yet written
        self.keys: queue.Queue = queue.Queue()

    def _key(self) -> str | None:
        """The operator's next line, spinning the graph meanwhile; None for end of input or Ctrl-C."""
        next_update = time.monotonic() + 0.5
        while not self.stop.requested:
            try:
                return self.keys.get_nowait()
            except queue.Empty:
                pass
            self.tool.executor.spin_once(0.05)
            if time.monotonic() >= next_update:   # a topic that appears late (the patch's panels)
                self.recorder.update()
                next_update += 0.5
        return None

    def _commit(self) -> None:
        if self.pending is not None:
            trial, start, end = self.pending
            self.writer.label(self.person, trial.gesture, trial.variant, start, end, end)
            self.pending = None

    def _end_after(self, start_ns: int, timeout_s: float = 3.0) -> int | None:
        """The graph's ROS time once a frame newer than ``start_ns`` came (None if none within the timeout)."""
        self.tool.spin_until(lambda: (self.recorder.clock_ns or 0) > start_ns, timeout_s, stop=self.stop)
        clock = self.recorder.clock_ns or 0
        return clock if clock > start_ns else None

    def run(self, read_line: Callable[[str], str]) -> None:
        _key_reader(read_line, self.keys)
        self.say(f'{self.total} trials for {self.person}; keys: {_KEYS}')
        while self.todo:
            trial = self.todo[0]
            number = self.writer.labels + (self.pending is not None) + 1
            prompt = f'trial {number}/{self.total}: {trial.prompt}: press Enter, perform it, press Enter when done'
            self.show(prompt)
            self.say(prompt)
            key = self._key()
            if key is None or key == 'q':
                break
            if key in ('r', 'd'):
                self._take_back(key)
                continue
            if key:
                self.say(f'unknown key {key!r}; {_KEYS}')
                continue
            start = self.recorder.clock_ns
            self.show(f'trial {number}/{self.total}: {trial.prompt}: now! press Enter when done')
            key = self._key()
            if key is None or key == 'q':
                self.say(f'trial {number} ({trial.prompt}) not kept: the session ended during it')
                break
            end = self._end_after(start)
            if end is None:
                self.say(f'no {FRAME_TOPIC[self.writer.sensor]} frame came during trial {number}; not kept, '
                         'asked again')
                continue
            self._commit()
            self.pending = (self.todo.popleft(), start, end)
            self.say(f'trial {number} kept: {trial.prompt}, {(end - start) / _NS:.2f} s')
        self._commit()
        self.say(f'session ended: {self.writer.labels} trials kept of {self.total}; '
                 f'{self.recorder.frames} frames in {self.writer.path}')

    def _take_back(self, key: str) -> None:
        if self.pending is None:
            self.say('nothing to ' + ('redo' if key == 'r' else 'drop') + ': only the last kept trial can be')
            return
        trial = self.pending[0]
        self.pending = None
        if key == 'r':
            self.todo.appendleft(trial)
            self.say(f'redo: {trial.prompt} is asked again; its label is replaced')
        else:
            self.total -= 1
            self.say(f'dropped: {trial.prompt} (its label removed; it is not asked again)')
