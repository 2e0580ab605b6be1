"""``social-touch node list | info NODE``, as ``ros2 node`` prints them: every node of the DDS domain."""

from __future__ import annotations

import argparse
from typing import Any

from ..daemon.client import graph_source
from ..errors import GraphError
from ..yamlconf import did_you_mean
from .daemon import add_no_daemon

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')
    p = sub.add_parser('list', help='nodes of the running graph')
    p.add_argument('-a', '--all', action='store_true', help='include hidden nodes (names starting with _)')
    p.add_argument('-c', '--count-nodes', action='store_true', help='print only the number of nodes')
    add_no_daemon(p)
    p = sub.add_parser('info', help="a node's publishers and subscriptions")
    p.add_argument('node', help='fully qualified name, e.g. /bear/driver')
    add_no_daemon(p)


def run(args: argparse.Namespace) -> int:
    with graph_source(f'node_{args.action}', args.no_daemon) as source:
        view = source.require_graph()
        return _list(view, args) if args.action == 'list' else _info(view, args)


def _list(view: Any, args: argparse.Namespace) -> int:
    names = sorted({n.name for n in view.visible_nodes(include_hidden=args.all)})
    if args.count_nodes:
        print(len(names))
        return 0
    for name in names:
        print(name)
    return 0


def _info(view: Any, args: argparse.Namespace) -> int:
    found = view.find_nodes(args.node)
    if not found:
        known = sorted({n.name for n in view.nodes})
        raise GraphError(f"unknown node '{args.node}'{did_you_mean(args.node, known)}; nodes: "
                         f'{", ".join(n for n in known if not n.rsplit("/", 1)[-1].startswith("_")) or "none"}')
    if len(found) > 1:
        print(f'There are {len(found)} nodes in the graph with the exact name "{found[0].name}" '
              f'(participants {", ".join(n.participant for n in found)}); showing all.')
    for node in found:
        print(node.name)
        sections = (('Subscribers', _names_and_types((ep.topic, ep.type_name) for ep in node.subscriptions)),
                    ('Publishers', _names_and_types((ep.topic, ep.type_name) for ep in node.publishers)),
                    ('Service Servers', _names_and_types(node.services.items())),
                    ('Service Clients', _names_and_types(node.clients.items())),
                    ('Action Servers', []), ('Action Clients', []))
        for title, lines in sections:
            print(f'  {title}:')
            print(*lines, sep='\n')  # an empty section is an empty line, as ros2 node info prints it
    return 0


def _names_and_types(pairs: Any) -> list[str]:
    """``    name: type1, type2`` lines, sorted by name."""
    types: dict[str, set[str]] = {}
    for name, type_name in pairs:
        types.setdefault(name, set()).add(type_name)
    return [f'    {name}: {", ".join(sorted(t))}' for name, t in sorted(types.items())]
