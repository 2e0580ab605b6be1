"""``social-touch bag info BAG | reindex BAG``: what a bag holds; rebuild one whose recorder died."""

from __future__ import annotations

import argparse
import time

from .options import add_output
from .record import format_size

__all__ = ['add_arguments', 'format_stamp', 'run']



def format_stamp(ns: int) -> str:
    """A ROS time as ``ros2 bag info`` prints it (local time, then seconds since the epoch)."""
    sec, nsec = divmod(ns, 1_000_000_000)
    return f'{time.strftime("%b %d %Y %H:%M:%S", time.localtime(sec))}.{nsec:09d} ({sec}.{nsec:09d})'


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    sub.add_parser('info', help='files, duration, topics and message counts').add_argument('bag')
    reindex = sub.add_parser('reindex', help='rebuild metadata.yaml and the MCAP summary after a crash')
    reindex.add_argument('bag')
    add_output(reindex, 'write the rebuilt bag to this new directory (e.g. on another disk when the bag\'s is '
                        'full) instead of repairing it in place')


def run(args: argparse.Namespace) -> int:
    if args.action == 'reindex':
        from ..bag.reindex import reindex  # lazy: --help runs without rosbags and the message classes
        report = reindex(args.bag, args.output)
        what = f'repaired {", ".join(report.repaired)}' if report.repaired else 'the MCAP files were complete'
        print(f'reindexed {report.bag}: {what}; {report.message_count} messages'
              + (f', {report.bytes_dropped} torn bytes cut off' if report.bytes_dropped else ''))
        for topic, count in sorted(report.topics.items()):
            print(f'  {topic}: {count}')
        return 0
    from ..bag.player import bag_info  # lazy: as reindex above
    info = bag_info(args.bag)
    lines = [('Files', '\n'.join(info['files'])), ('Bag size', format_size(info['size'])),
             ('Storage id', info['storage']), ('Duration', f'{info["duration_ns"] / 1e9:.9f}s')]
    if info['messages']:
        lines += [('Start', format_stamp(info['start_ns'])), ('End', format_stamp(info['end_ns']))]
    lines.append(('Messages', str(info['messages'])))
    topics = [f'Topic: {t["name"]} | Type: {t["type"]} | Count: {t["count"]} | Serialization Format: {t["format"]}'
              for t in info['topics']]
    lines.append(('Topic information', '\n'.join(topics)))
    for key, value in lines:
        first, *rest = value.split('\n') if value else ['']
        print(f'{key + ":":<19}{first}')
        for line in rest:
            print(' ' * 19 + line)
    return 0
