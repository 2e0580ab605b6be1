"""``social-touch``: the command runner, and the table of the runtime's own commands.

A command is a module (or ``module:object``) with ``add_arguments(parser)`` and ``run(args) -> int``,
imported only when it runs. Each layer has a table ``name -> Command``; the console script
(``touch_lab.cli.main``) hands this runner every layer's table, so the runtime imports nothing above it.
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys
from typing import Any, NamedTuple

__all__ = ['COMMANDS', 'Command', 'load', 'main']


class Command(NamedTuple):
    """One line of a command table: what runs it (``module`` or ``module:object``) and its one-line help."""

    target: str
    help: str


#: The runtime's commands: the graph and its bags, as the ros2 CLI names them.
COMMANDS: dict[str, Command] = {
    'launch': Command('touch_graph.launch.cli', "start a scene's nodes, in this process or in processes of their own"),
    'topic': Command('touch_graph.cli.topic', 'topics of the running graph: list, echo, hz, info, pub'),
    'node': Command('touch_graph.cli.node', 'nodes of the running graph: list, info'),
    'service': Command('touch_graph.cli.service', 'services of the running graph: list, type, find, call'),
    'param': Command('touch_graph.cli.param',
                     'parameters of running nodes: list, get, set, describe, dump, load, delete'),
    'record': Command('touch_graph.cli.record', 'record topics of the running graph to a rosbag2 (MCAP)'),
    'play': Command('touch_graph.cli.play', 'replay a rosbag2 into the running graph with its recorded timing'),
    'daemon': Command('touch_graph.cli.daemon', 'the graph daemon of this domain: start, stop, status'),
    'bag': Command('touch_graph.cli.bag', 'bag info, bag reindex (recover a bag whose recorder died)'),
    'interface': Command('touch_graph.cli.interface', 'list message types or show one (like ros2 interface)'),
    'export-interfaces': Command('touch_graph.cli.export_interfaces',
                                 'write the social_touch_msgs ament_cmake package for a ROS 2 workspace'),
}

EPILOG = """\
Start with:  social-touch demo          (the demo scene on virtual sensors)
Details:     social-touch COMMAND --help
"""


def load(target: str) -> Any:
    """The module (``module``) or object (``module:object``) a table names, imported now.

    >>> load('touch_graph.cli.main:Command').__name__
    'Command'
    """
    module_name, _, attr = target.partition(':')
    module = importlib.import_module(module_name)
    return getattr(module, attr) if attr else module


def _top_parser(commands: dict[str, Command]) -> argparse.ArgumentParser:
    lines = [f'  {name:<18} {text}' for name, (_, text) in sorted(commands.items())]
    parser = argparse.ArgumentParser(
        prog='social-touch', formatter_class=argparse.RawDescriptionHelpFormatter,
        description='Touch perception for a social robot: a ROS 2-style node graph of sensor drivers and '
                    'gesture recognisers.',
        epilog='commands:\n' + '\n'.join(lines) + '\n\n' + EPILOG)
    parser.add_argument('command', choices=sorted(commands), metavar='COMMAND', help='what to do (see below)')
    return parser


def main(argv: list[str] | None = None, commands: dict[str, Command] | None = None) -> int:
    """Run ``social-touch COMMAND ...`` from ``commands`` (default: the runtime's :data:`COMMANDS`)."""
    commands = COMMANDS if commands is None else commands
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in commands:
        parser = _top_parser(commands)
        if not argv:
            parser.print_help()
            return 2
        parser.parse_args(argv[:1])  # --help, or usage with a did-you-mean and exit 2 on an unknown command
        return 2
    name, rest = argv[0], argv[1:]
    target, text = commands[name]
    module = load(target)
    parser = argparse.ArgumentParser(prog=f'social-touch {name}', description=text[0].upper() + text[1:],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    module.add_arguments(parser)
    args = parser.parse_args(rest)
    # Imported late: the top-level --help above needs nothing of the runtime.
    from ..errors import SocialTouchError
    from ..files import is_disk_full
    try:
        return int(module.run(args) or 0)
    except SocialTouchError as err:
        print(f'social-touch {name}: error: {err}', file=sys.stderr)
        return 1
    except OSError as err:  # a writer without its own DiskFullError: still one clear line
        if not is_disk_full(err):
            raise
        print(f'social-touch {name}: error: {os.strerror(err.errno)} ({errno.errorcode[err.errno]}) writing '
              f'{err.filename or "its output"}; files finished before are complete, the one being written may be '
              'partial: free some space or write to another disk (-o/--output), and run the command again',
              file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130
