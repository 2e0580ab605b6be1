"""``social-touch service list | type | find | call``, as ``ros2 service`` prints them: every service of the domain.

Services come from DDS discovery (``rq/``/``rr/`` topics); a service with only clients is listed too.
"""

from __future__ import annotations

import argparse
import time

from ..daemon.client import graph_source
from ..errors import ConfigError, GraphError, MessageError
from ..node_main import StopSignals
from ..yamlconf import did_you_mean, safe_load
from .daemon import add_no_daemon
from .options import rate_hz, seconds

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    p = sub.add_parser('list', help='services of the running graph')
    p.add_argument('-t', '--show-types', action='store_true', help='also show each service type')
    p.add_argument('-c', '--count-services', action='store_true', help='print only the number of services')
    p.add_argument('--include-hidden-services', action='store_true', help='include hidden services (a name part '
                                                                          'starting with _)')
    add_no_daemon(p)
    p = sub.add_parser('type', help="a service's type")
    p.add_argument('service_name', help='e.g. /bear/bear_gestures/list_parameters')
    p.add_argument('--include-hidden-services', action='store_true', help='consider hidden services as well')
    add_no_daemon(p)
    p = sub.add_parser('find', help='services of a type')
    p.add_argument('service_type', help='e.g. rcl_interfaces/srv/ListParameters')
    p.add_argument('-c', '--count-services', action='store_true', help='print only the number of services')
    p.add_argument('--include-hidden-services', action='store_true', help='consider hidden services as well')
    add_no_daemon(p)
    p = sub.add_parser('call', help='call a service and print the response')
    p.add_argument('service_name', help="e.g. '/robot/set_mode'")
    p.add_argument('service_type', help="e.g. 'std_srvs/srv/SetBool' (or std_srvs/SetBool)")
    p.add_argument('values', nargs='?', default='{}',
                   help="the request's fields in YAML, e.g. '{data: true}' (default: all fields at their defaults)")
    p.add_argument('-r', '--rate', type=rate_hz, metavar='N',
                   help='repeat the call N times a second (Ctrl-C stops)')
    p.add_argument('--timeout', type=seconds, default=5.0, metavar='S',
                   help='wait at most S seconds for the service to appear, and again for each response (default 5)')


def run(args: argparse.Namespace) -> int:
    if args.action == 'call':
        return _call(args)
    with graph_source(f'service_{args.action}', args.no_daemon) as source:
        view = source.require_graph()
        services = view.visible_services(args.include_hidden_services)
        if args.action == 'list':
            if args.count_services:
                print(len(services))
                return 0
            for name, info in services.items():
                print(f'{name} [{", ".join(sorted(info.types))}]' if args.show_types else name)
            return 0
        if args.action == 'type':
            info = services.get(args.service_name)
            if info is None:
                raise GraphError(f"unknown service '{args.service_name}'{did_you_mean(args.service_name, services)}"
                                 '; social-touch service list shows them')
            for type_name in sorted(info.types):
                print(type_name)
            return 0
        wanted = _normalized_type(args.service_type)
        found = [name for name, info in services.items() if wanted in info.types]
        for line in [len(found)] if args.count_services else found:
            print(line)
        return 0


def _normalized_type(name: str) -> str:
    from ..srv_types import normalize_service_name  # lazy: the daemon answers list and type without the messages
    return normalize_service_name(name)


def _call(args: argparse.Namespace) -> int:
    # lazy: only call joins the domain and builds messages (list and type are the daemon's)
    from .. import messages
    from ..dds.tool import GraphTool  # lazy: as above
    from ..srv_types import get_service  # lazy: as above
    srv_type = get_service(args.service_type)
    try:
        values = safe_load(args.values, 'the request values')
    except ConfigError as err:
        raise GraphError(f'{err}; write them as "{{field: value}}"') from err
    try:
        request = messages.from_dict(srv_type.Request.__msgtype__, values if values is not None else {})
    except MessageError as err:
        raise GraphError(f'Failed to populate field: {err}') from err
    with GraphTool('service_call') as tool, StopSignals(tool.executor.wake) as stop:
        tool.require_graph()
        while True:
            print(f'requester: making request: {request!r}\n')
            started = time.monotonic()
            response = tool.call(srv_type, args.service_name, request, args.timeout)
            print(f'response:\n{response!r}\n', flush=True)
            if args.rate is None or stop.requested:
                return 0
            period = 1.0 / args.rate
            stop.event.wait(max(0.0, started + period - time.monotonic()))
            if stop.requested:
                return 0
