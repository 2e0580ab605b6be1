"""``social-touch daemon start | stop | status``: this domain's graph daemon (:mod:`touch_graph.daemon`)."""

from __future__ import annotations

import argparse

from ..daemon import client
from ..daemon.address import is_older
from .options import non_negative_int, seconds

__all__ = ['add_arguments', 'add_no_daemon', 'run']


def add_no_daemon(parser: argparse.ArgumentParser) -> None:
    """``--no-daemon`` on a graph command (ros2cli's spelling)."""
    parser.add_argument('--no-daemon', action='store_true',
                        help='do not ask the graph daemon: join the domain and wait for discovery in this command')


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    sub.add_parser('start', help="start this domain's daemon if it is not running")
    sub.add_parser('stop', help="stop this domain's daemon")
    sub.add_parser('status', help="whether this domain's daemon runs, and for what")
    p = sub.add_parser('serve', help='be the daemon, in this terminal (the graph commands start it in the background)')
    p.add_argument('--ros-domain-id', type=non_negative_int, required=True, metavar='N',
                   help='the domain: must match ROS_DOMAIN_ID (given to be seen in the process list)')
    p.add_argument('--idle-timeout', type=seconds, metavar='S',
                   help='exit after S seconds without a question (default two hours)')


def run(args: argparse.Namespace) -> int:
    if args.action == 'serve':
        from ..daemon.server import IDLE_TIMEOUT_S, serve  # lazy: the list verbs import this module, not the server
        return serve(args.ros_domain_id, args.idle_timeout or IDLE_TIMEOUT_S)
    address = client.daemon_address()
    where = f'domain {address.domain_id}, discovery range {address.discovery_range}'
    if args.action == 'stop':
        print(f'The daemon has been stopped ({where})' if client.stop(address)
              else f'There is no daemon running ({where})')
        return 0
    try:
        status = client.request('status', address)
    except client.DaemonUnavailable:
        status = None
    current = status is not None and status.get('version') == client.code_version()
    if args.action == 'status':
        if status is None:
            print(f'The daemon is not running ({where})')
            return 1
        print(f"The daemon is running ({where}): pid {status['pid']}, up {status['up_s']:.0f} s, "
              f"{status['requests']} requests, {status['participants']} other participants, "
              f"socket {status['socket']}" + ('' if current else '; it runs another installation of social-touch '
                                              '(an older one is replaced at the next graph command)'))
        return 0
    if status is not None and not current and is_older(status.get('version', ''), client.code_version()):
        client.stop(address)  # an older installation's daemon: replaced by ours
        status = None
    if status is not None:
        print(f'The daemon is already running ({where})')
        return 0
    client.spawn(address)
    if client.wait_running(address) is None:
        print(f'social-touch daemon: error: the daemon did not start ({where}); run social-touch daemon serve '
              f'--ros-domain-id {address.domain_id} in a terminal to see why')
        return 1
    print(f'The daemon has been started ({where})')
    return 0
