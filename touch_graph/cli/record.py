"""``social-touch record [-o BAG] (TOPIC ... | -a) [--duration S]``: record the running graph to a rosbag2 (MCAP).

The recorder joins the DDS domain and subscribes (raw CDR, with a QoS every publisher
matches) to the topics it is told, or to every published topic, also later ones: a
``social-touch launch`` in another process or on another machine, or any ROS 2 node.
Each message's log time is when the recorder received it (its wall clock, as ``ros2 bag
record`` without ``--use-sim-time``), its publish time the sample's source timestamp (the
publishing graph's ROS time: simulated time in a simulated scene of ours), as rosbag2
writes them; so the bag's duration is the recording's, latched samples included. Ctrl-C or
SIGTERM closes the bag; the bag is flushed once a second, so if the recorder is killed
instead, ``social-touch bag reindex BAG`` recovers all but the last second. Progress
(messages and bytes per topic) goes to stderr.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from typing import Any

from ..errors import BagError, GraphError, SocialTouchError
from ..node_main import StopSignals
from .options import seconds

__all__ = ['add_arguments', 'format_size', 'run']


def format_size(n: float) -> str:
    """Bytes as ``ros2 bag info`` shows them.

    >>> format_size(512), format_size(1536), format_size(3 * 1024 ** 2)
    ('512 B', '1.5 KiB', '3.0 MiB')
    """
    for unit in ('B', 'KiB', 'MiB', 'GiB'):
        if n < 1024 or unit == 'GiB':
            return f'{n:.0f} {unit}' if unit == 'B' else f'{n:.1f} {unit}'
        n /= 1024
    return f'{n:.1f} GiB'  # pragma: no cover


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('topics', nargs='*', help='topics to record')
    parser.add_argument('-a', '--all', action='store_true', help='record every published topic, also later ones')
    parser.add_argument('-o', '--output', help='bag directory to create (default rosbag2_<date>)')
    parser.add_argument('--duration', type=seconds, metavar='SECONDS',
                        help='stop after SECONDS (wall time, > 0)')
    parser.add_argument('--flush-period', type=seconds, default=1.0, metavar='SECONDS',
                        help='seconds between flushes to disk (default 1; what a kill -9 can lose)')
    parser.add_argument('--quiet', action='store_true', help='no progress lines on stderr')


def run(args: argparse.Namespace) -> int:
    # lazy: --help and argument errors run without Cyclone DDS, rosbags or the runtime
    from ..bag.recorder import BagRecorder
    from ..bag.recorder_node import default_bag_name  # lazy: as above
    from ..dds.tool import GraphTool  # lazy: as above

    if bool(args.topics) == bool(args.all):
        raise GraphError('name the topics to record, or pass -a/--all for every topic (not both)')
    if args.duration is not None and not args.duration > 0:
        raise ValueError(f'--duration must be > 0 s, got {args.duration}')
    output = args.output or default_bag_name()
    with GraphTool('record') as tool:
        if not tool.graph().remote_participants():
            print(f'social-touch record: {tool.no_graph_message()}; waiting for one', file=sys.stderr)
        bag = BagRecorder(output, flush_period_s=args.flush_period).open()
        try:
            recorder = _TopicRecorder(tool, bag, args.topics or None, quiet=args.quiet)
            with StopSignals(tool.executor.wake) as stop:
                recorder.update()
                tool.spin_until(lambda: bag.full is not None, args.duration, stop=stop, every=recorder.tick,
                                every_s=0.2)
                # What arrived before the stop is still in the executor's inbox: record it too.
                for _ in range(20):
                    tool.executor.spin_once(0)
        finally:
            if bag.full is None:
                bag.close()
            else:  # said once by the writer; close() would only say it again
                with contextlib.suppress(BagError):
                    bag.close()
        if bag.full is not None:
            return 1
        total = sum(bag.sizes.values())
        print(f'social-touch record: wrote {bag.message_count} messages ({format_size(total)}) to {bag.path}'
              + ''.join(f'\n  {t}: {n}' for t, n in sorted(bag.counts.items())), file=sys.stderr)
        missing = [t for t in (args.topics or []) if t not in bag.counts]
        if missing:
            print(f'social-touch record: never saw {", ".join(missing)}', file=sys.stderr)
    return 0


class _TopicRecorder:
    """Subscribes to the wanted topics as they appear in the graph and writes their samples to the bag."""

    def __init__(self, tool: Any, bag: Any, topics: list[str] | None, quiet: bool = False) -> None:
        self.tool = tool
        self.quiet = quiet
        self.next_progress = time.monotonic() + 1.0
        self.bag = bag
        self.topics = topics
        self.subscriptions: dict[str, Any] = {}
        self.started = time.monotonic()
        self.warned: set[str] = set()

    def update(self) -> None:
        from ..messages import get_message  # lazy: as in run()
        view = self.tool.graph()
        for name, info in view.published_topics().items():
            if name in self.subscriptions or (self.topics is not None and name not in self.topics):
                continue
            if len(info.types) > 1:
                self._warn_once(name, f"'{name}' has several types ({info.type_name}); not recorded")
                continue
            type_name = next(iter(info.types))
            try:
                msg_type = get_message(type_name)
            except SocialTouchError as err:
                self._warn_once(name, f"'{name}': {err}; not recorded")
                continue
            self.bag.add_topic(name, type_name, [ep.qos for ep in info.publishers])
            self.subscriptions[name] = self.tool.subscribe(msg_type, name, self._writer(name, type_name), 1000,
                                                           raw=True)

    def _warn_once(self, topic: str, text: str) -> None:
        if topic not in self.warned:
            self.warned.add(topic)
            print(f'social-touch record: {text}', file=sys.stderr)

    def _writer(self, topic: str, type_name: str) -> Any:
        bag = self.bag

        def write(data: bytes, message_info: dict) -> None:
            try:
                bag.write(topic, type_name, message_info['received_timestamp'], data,
                          publish_ns=message_info['source_timestamp'])
            except BagError as err:
                if bag.full is None:
                    raise
                self._warn_once('', f'error: {err}')  # the disk is full: once, then the recording ends
        return write

    def tick(self) -> None:
        """Every 0.2 s: pick up new topics; once a second: a progress line."""
        self.update()
        if not self.quiet and time.monotonic() >= self.next_progress:
            self.next_progress += 1.0
            self.progress()

    def progress(self) -> None:
        elapsed = time.monotonic() - self.started
        parts = ', '.join(f'{t}: {n} ({format_size(self.bag.sizes[t])})' for t, n in sorted(self.bag.counts.items()))
        print(f'[{elapsed:6.1f} s] {self.bag.message_count} messages  {parts or "waiting for topics"}',
              file=sys.stderr, flush=True)
