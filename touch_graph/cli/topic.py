"""``social-touch topic list | echo | hz | info | pub``, as the ros2 CLI prints them, over DDS.

``echo``, ``hz`` and ``record`` subscribe with a QoS every publisher matches, as ``ros2 topic
echo`` chooses it; ``hz`` measures in the publishing graph's ROS time (source timestamps), or
in arrival wall time with ``--wall-time``.

Imports inside functions: ``list`` and ``info`` are answered by the graph daemon, so this module
loads the message classes, PyYAML and the DDS tool only in the verbs that use them (as does
``social-touch topic --help``).
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections import deque
from typing import Any

from ..daemon.client import graph_source
from ..dds.graph import format_gid
from ..errors import ConfigError, GraphError, MessageError
from ..node_main import StopSignals
from .daemon import add_no_daemon
from .options import non_negative_seconds, positive_int, rate_hz, seconds

__all__ = ['HzMonitor', 'abbreviate_arrays', 'add_arguments', 'run', 'select_field']


# --------------------------------------------------------------------------- pure helpers
class HzMonitor:
    """Rate statistics over the last ``window`` intervals between message times (ns), as ``ros2 topic hz``.

    >>> hz = HzMonitor(window=10)
    >>> for t in range(0, 500_000_001, 100_000_000):
    ...     hz.add(t)
    >>> rate, lo, hi, std, n = hz.stats()
    >>> round(rate, 3), lo, hi, std, n
    (10.0, 0.1, 0.1, 0.0, 5)
    """

    def __init__(self, window: int = 10_000) -> None:
        if window < 1:
            raise ValueError(f'window must be >= 1 message, got {window}')
        self.intervals: deque[int] = deque(maxlen=window)
        self.last_ns: int | None = None
        self.resets = 0

    def add(self, t_ns: int) -> None:
        if self.last_ns is not None and t_ns < self.last_ns:
            self.intervals.clear()  # time went back (a replay looped, a sim restarted): start over
            self.resets += 1
        elif self.last_ns is not None:
            self.intervals.append(t_ns - self.last_ns)
        self.last_ns = t_ns

    def stats(self) -> tuple[float, float, float, float, int] | None:
        """``(rate Hz, min s, max s, std dev s, window)``; None before two messages."""
        n = len(self.intervals)
        if n == 0:
            return None
        mean = sum(self.intervals) / n
        std = math.sqrt(sum((x - mean) ** 2 for x in self.intervals) / n)
        rate = 1e9 / mean if mean > 0 else 0.0  # equal stamps: no meaningful rate
        return rate, min(self.intervals) / 1e9, max(self.intervals) / 1e9, std / 1e9, n


def _array_note(type_str: str, value: Any) -> str:
    base, _, rest = type_str.partition('[')
    size = rest.rstrip(']')
    if size and not size.startswith('<='):
        return f'<array type: {base}[{size}]>'
    if size:
        return f'<sequence type: {base}[{size[2:]}], length: {len(value)}>'
    return f'<sequence type: {base}, length: {len(value)}>'


def abbreviate_arrays(msg: Any) -> dict[str, Any]:
    """``to_dict`` with every array field replaced by a note (``echo --no-arr``).

    >>> from touch_graph import messages
    >>> Header = messages.get_message('std_msgs/msg/Header')
    >>> abbreviate_arrays(messages.get_message('DriverStatus')())['header'] == messages.to_dict(Header())
    True
    """
    from .. import messages  # lazy: see the module doc
    out = {}
    for name, type_str in messages.msg_field_types(type(msg)).items():
        value = getattr(msg, name)
        if type_str.endswith(']'):
            out[name] = _array_note(type_str, value)
        elif isinstance(value, messages.Message):
            out[name] = abbreviate_arrays(value)
        else:
            out[name] = value
    return out


def check_field_path(type_name: str, path: str) -> None:
    """Raise GraphError unless ``a.b`` names a field (nested through messages) of ``type_name``."""
    from .. import messages  # lazy: see the module doc
    from ..yamlconf import did_you_mean  # lazy: see the module doc
    cls = messages.get_message(type_name)
    parts = path.split('.')
    for i, part in enumerate(parts):
        fields = messages.msg_field_types(cls)
        if part not in fields:
            raise GraphError(f"{cls.__msgtype__} has no field '{part}'{did_you_mean(part, list(fields))} "
                             f"(in --field {path}); its fields: {', '.join(fields)}")
        type_str = fields[part]
        if i < len(parts) - 1:
            if '/' not in type_str or type_str.endswith(']'):
                raise GraphError(f"--field {path}: '{part}' is {type_str}, it has no fields")
            cls = messages.get_message(type_str)


def select_field(data: Any, path: str) -> Any:
    """The value at dotted ``path`` in a ``to_dict`` tree."""
    for part in path.split('.'):
        data = data[part]
    return data


def to_yaml(data: Any) -> str:
    import yaml  # lazy: see the module doc
    return yaml.safe_dump(data, sort_keys=False, default_flow_style=False, width=sys.maxsize, allow_unicode=True)


# --------------------------------------------------------------------------- arguments
def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    p = sub.add_parser('list', help='topics of the running graph')
    p.add_argument('-t', '--show-types', action='store_true', help='print each topic with its type')
    p.add_argument('-c', '--count-topics', action='store_true', help='print only the number of topics')
    p.add_argument('--include-hidden-topics', action='store_true', help='also topics with a token starting with _')
    add_no_daemon(p)
    p = sub.add_parser('echo', help='print the messages of a topic')
    p.add_argument('topic')
    p.add_argument('type', nargs='?', help='message type, to wait for a topic that is not published yet')
    p.add_argument('--once', action='store_true', help='print one message and exit')
    p.add_argument('-n', '--count', type=positive_int, help='print N messages and exit')
    p.add_argument('--no-arr', action='store_true', help='print array fields as their type and length')
    p.add_argument('--field', help='print only this field, e.g. header.stamp')
    p.add_argument('--timeout', type=seconds, metavar='S', help='exit with code 1 after S seconds without a message')
    p = sub.add_parser('hz', help='print the rate of a topic')
    p.add_argument('topic')
    p.add_argument('-w', '--window', type=positive_int, default=10_000, help='messages to compute over (default 10000)')
    p.add_argument('--wall-time', action='store_true', help="rate in arrival wall time, not the graph's ROS time")
    p.add_argument('--duration', type=seconds, help='exit after SECONDS')
    p = sub.add_parser('info', help='type and endpoints of a topic')
    p.add_argument('topic')
    p.add_argument('-v', '--verbose', action='store_true',
                   help='list each publisher and subscription: node, GID, QoS, and queue drops where known')
    add_no_daemon(p)
    p = sub.add_parser('pub', help='publish a message given as YAML')
    p.add_argument('topic')
    p.add_argument('type', help='e.g. std_msgs/msg/String or social_touch_msgs/msg/HapticCommand')
    p.add_argument('values', nargs='?', default='{}', help="YAML, e.g. \"{data: hello}\" (default: all defaults)")
    rate = p.add_mutually_exclusive_group()
    rate.add_argument('-r', '--rate', type=rate_hz, default=1.0, help='messages per second (default 1)')
    rate.add_argument('-1', '--once', action='store_true', help='publish one message and exit')
    p.add_argument('-t', '--times', type=positive_int, help='publish N messages and exit')
    p.add_argument('-w', '--wait', type=non_negative_seconds, default=2.0,
                   help='seconds to wait for the subscribers of the graph before the first message (default 2)')


def run(args: argparse.Namespace) -> int:
    if args.action in _GRAPH_QUERIES:
        with graph_source(f'topic_{args.action}', args.no_daemon) as source:
            return _GRAPH_QUERIES[args.action](source, args)
    from ..dds.tool import GraphTool  # lazy: see the module doc
    with GraphTool(f'topic_{args.action}') as tool:
        return {'echo': _echo, 'hz': _hz, 'pub': _pub}[args.action](tool, args)


# --------------------------------------------------------------------------- actions
def _list(tool: Any, args: argparse.Namespace) -> int:
    topics = tool.require_graph().visible_topics(args.include_hidden_topics)
    if args.count_topics:
        print(len(topics))
        return 0
    for name, info in sorted(topics.items()):
        print(f'{name} [{info.type_name}]' if args.show_types else name)
    return 0


def _info(tool: Any, args: argparse.Namespace) -> int:
    from ..dds.qos import describe_qos  # lazy: see the module doc
    info = tool.require_topic(args.topic)
    print(f'Type: {info.type_name}')
    for title, kind, endpoints in (('Publisher', 'PUBLISHER', info.publishers),
                                   ('Subscription', 'SUBSCRIPTION', info.subscriptions)):
        print(f'{chr(10) if args.verbose else ""}{title} count: {len(endpoints)}')
        if not args.verbose:
            continue
        for ep in sorted(endpoints, key=lambda e: (e.node, e.gid)):
            namespace, _, name = ep.node.rpartition('/')
            print(f'\nNode name: {name}\nNode namespace: {namespace or "/"}\nTopic type: {ep.type_name}')
            print(f'Topic type hash: {ep.type_hash or "INVALID"}\nEndpoint type: {kind}\nGID: {format_gid(ep.gid)}')
            print('QoS profile:\n' + '\n'.join(describe_qos(ep.qos)))
            if ep.stats:
                print(f"Queue: {ep.stats.get('received', 0)} received, {ep.stats.get('dropped', 0)} dropped "
                      f"(queue full), {ep.stats.get('undecodable', 0)} undecodable")
    return 0


#: The actions that only read the graph (answered by the graph daemon unless --no-daemon).
_GRAPH_QUERIES = {'list': _list, 'info': _info}


def _echo(tool: Any, args: argparse.Namespace) -> int:
    from .. import messages  # lazy: see the module doc
    limit = 1 if args.once else args.count
    type_name = messages.normalize_type_name(args.type) if args.type else None
    if type_name is None:
        type_name = next(iter(tool.require_topic(args.topic).types))
    elif not tool.graph().remote_participants():  # with a type, wait for the publishers as ros2 topic echo does
        print(f"social-touch topic echo: {tool.no_graph_message()}; waiting for publishers of '{args.topic}'",
              file=sys.stderr)
    else:
        tool.require_topic(args.topic, type_name)
    if args.field:
        check_field_path(type_name, args.field)
    printed = [0]
    last = [time.monotonic()]
    closed = [False]  # stdout went away (| head): stop quietly

    def show(msg: Any) -> None:
        if (limit is not None and printed[0] >= limit) or closed[0]:
            return
        data = abbreviate_arrays(msg) if args.no_arr else messages.to_dict(msg)
        if args.field:
            data = select_field(data, args.field)
        try:
            sys.stdout.write(to_yaml(data) + '---\n')
            sys.stdout.flush()
        except BrokenPipeError:
            closed[0] = True
        printed[0] += 1
        last[0] = time.monotonic()

    sub = tool.subscribe(messages.get_message(type_name), args.topic, show, 100)
    reported = [0, time.monotonic()]       # drops reported, when

    def report_drops(final: bool = False) -> None:
        # A paused echo (Ctrl-Z, a full pipe) loses messages in its queue: say so on stderr, at most once a second.
        dropped = getattr(sub, 'dropped', 0)
        if dropped > reported[0] and (final or time.monotonic() - reported[1] >= 1.0):
            print(f"social-touch topic echo: {dropped - reported[0]} messages on '{args.topic}' dropped "
                  f'({dropped} in all): the echo fell behind and its queue was full', file=sys.stderr)
            reported[:] = [dropped, time.monotonic()]

    with StopSignals(tool.executor.wake) as stop:
        while not stop.requested and not closed[0] and (limit is None or printed[0] < limit):
            if args.timeout is not None and time.monotonic() - last[0] > args.timeout:
                print(f"social-touch topic echo: no message on '{args.topic}' for {args.timeout} s", file=sys.stderr)
                return 1
            tool.executor.spin_once(0.1)
            report_drops()
    report_drops(final=True)
    return 0


def _hz(tool: Any, args: argparse.Namespace) -> int:
    from ..messages import get_message  # lazy: see the module doc
    info = tool.require_topic(args.topic)
    monitor = HzMonitor(args.window)
    seen = [0, 0]  # messages, messages at the last print

    def on_sample(_data: bytes, message_info: dict) -> None:
        monitor.add(message_info['received_timestamp' if args.wall_time else 'source_timestamp'])
        seen[0] += 1

    def report() -> None:
        stats = monitor.stats()
        if stats is None or seen[0] == seen[1]:
            return
        seen[1] = seen[0]
        rate, lo, hi, std, n = stats
        print(f'average rate: {rate:.3f}\n\tmin: {lo:.3f}s max: {hi:.3f}s std dev: {std:.5f}s window: {n}', flush=True)

    tool.subscribe(get_message(next(iter(info.types))), args.topic, on_sample, 1000, raw=True)
    with StopSignals(tool.executor.wake) as stop:
        tool.spin_until(lambda: False, args.duration, stop=stop, every=report)
    report()
    return 0


def _pub(tool: Any, args: argparse.Namespace) -> int:
    from .. import messages  # lazy: see the module doc
    from ..yamlconf import safe_load  # lazy: see the module doc
    type_name = messages.normalize_type_name(args.type)
    try:
        values = safe_load(args.values, 'the message values')
    except ConfigError as err:
        raise MessageError(f'cannot parse {err}') from err
    msg = messages.from_dict(type_name, values if values is not None else {})
    times = 1 if args.once else args.times
    view = tool.graph()
    if not view.remote_participants():
        if times is not None:
            raise GraphError(tool.no_graph_message())
        print(f'social-touch topic pub: {tool.no_graph_message()}; publishing anyway', file=sys.stderr)
    pub = tool.node.create_publisher(messages.get_message(type_name), args.topic, 10)
    seen = view.topics.get(args.topic)
    if seen is not None and seen.subscriptions:  # wait for the subscribers the graph announced to match
        tool.spin_until(lambda: pub.get_subscription_count() >= len(seen.subscriptions), args.wait)
    sent = [0]

    def tick() -> None:
        pub.publish(msg)
        sent[0] += 1
        print(f'publishing #{sent[0]}: {messages.to_dict(msg)}', flush=True)
    tick()
    with StopSignals(tool.executor.wake) as stop:
        if times is None or times > 1:
            timer = tool.node.create_timer(1.0 / args.rate, tick)
            tool.spin_until(lambda: times is not None and sent[0] >= times, None, stop=stop)
            timer.cancel()
    tool.flush([pub])
    return 0
