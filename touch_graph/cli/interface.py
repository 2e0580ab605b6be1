"""``social-touch interface list | show TYPE``, as ``ros2 interface`` prints them."""

from __future__ import annotations

import argparse

from .. import messages, srv_types


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    sub.add_parser('list', help="this package's message and service types, and the services the runtime uses")
    show = sub.add_parser('show', help='the definition of a type, nested types indented')
    show.add_argument('type', help='e.g. social_touch_msgs/msg/SkinFrame, social_touch_msgs/SkinFrame or SkinFrame, '
                                   'rcl_interfaces/srv/GetParameters')


def run(args: argparse.Namespace) -> int:
    if args.action == 'list':
        print('Messages:')
        for name in messages.interface_names():
            print(f'    {name}')
        print('Services:')
        for name in sorted({*srv_types.service_names(), *srv_types.STANDARD_SERVICES}):
            print(f'    {name}')
        return 0
    if '/srv/' in args.type:
        print(srv_types.service_definition(args.type), end='')
        return 0
    print(messages.message_definition(args.type), end='')
    return 0
