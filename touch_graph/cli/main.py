"""``social-touch``: launch scenes, inspect the graph, record and replay, train, evaluate, benchmark.

Every subcommand is a module (or an object) with ``add_arguments(parser)`` and ``run(args) -> int``
(and optionally ``HELP``, its one-line help), registered by the package that owns it in the
``social_touch.commands`` entry point group (setup.py): the runtime's graph commands, the
simulation's ``demo``, the lab's ``eval``, ``train``, ``bench``, ``report``, ... Only the
module of the chosen subcommand is imported, so ``social-touch topic list`` does not pay for
scikit-learn, and the runtime imports nothing of the simulation or the lab.
"""

from __future__ import annotations

import argparse
import importlib
import re
import sys
from importlib.metadata import entry_points
from typing import Any

from ..errors import SocialTouchError

__all__ = ['COMMANDS', 'COMMAND_GROUP', 'command_help', 'installed_commands', 'main']

#: The entry point group of ``social-touch`` subcommands: ``name = module`` or ``name = module:object``.
COMMAND_GROUP = 'social_touch.commands'


def installed_commands() -> dict[str, tuple[str, str]]:
    """``name -> (module, help)`` of every installed subcommand; help is '' (read from the module when shown)."""
    return {ep.name: (ep.value, '') for ep in entry_points(group=COMMAND_GROUP)}


#: name -> (module, one-line help or '' for the module's own).
COMMANDS: dict[str, tuple[str, str]] = installed_commands()

EPILOG = """\
Start with:  social-touch demo          (the demo scene on virtual sensors)
Details:     social-touch COMMAND --help
"""


def load_command(value: str) -> Any:
    """The command an entry point value names: ``module`` or ``module:object``."""
    module_name, _, attr = value.partition(':')
    module = importlib.import_module(module_name)
    return getattr(module, attr) if attr else module


def command_help(module: Any) -> str:
    """A command module's one-line help: its ``HELP``, else the first line of its docstring
    (what follows a leading ````usage````: , or the line with its code spans unwrapped).

    >>> from types import ModuleType
    >>> command_help(ModuleType('x', '``social-touch x a | b``: do x.\\n\\nMore.'))
    'do x.'
    >>> command_help(ModuleType('y', '``social-touch y``, as ros2 y does.'))
    'social-touch y, as ros2 y does.'
    """
    text = getattr(module, 'HELP', None) or (module.__doc__ or '').strip().split('\n')[0]
    usage = re.match(r'``[^`]*``: (.+)', text)
    return usage.group(1) if usage else re.sub(r'``([^`]*)``', r'\1', text)


def _top_parser() -> argparse.ArgumentParser:
    lines = []
    for name, (module_name, text) in sorted(COMMANDS.items()):
        lines.append(f'  {name:<18} {text or command_help(load_command(module_name))}')
    parser = argparse.ArgumentParser(
        prog='social-touch', formatter_class=argparse.RawDescriptionHelpFormatter,
        description='Touch perception for a social robot: a ROS 2-style node graph of sensor drivers and '
                    'gesture recognisers.',
        epilog='commands:\n' + '\n'.join(lines) + '\n\n' + EPILOG)
    parser.add_argument('command', choices=sorted(COMMANDS), metavar='COMMAND', help='what to do (see below)')
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not COMMANDS:
        print('social-touch: no commands are installed (the social_touch.commands entry points are missing); '
              "install the package: pip install -e . (or pip install .)", file=sys.stderr)
        return 2
    if not argv or argv[0] not in COMMANDS:
        parser = _top_parser()
        if not argv:
            parser.print_help()
            return 2
        parser.parse_args(argv[:1])  # prints usage, a did-you-mean and exits 2 on an unknown command
        return 2
    name, rest = argv[0], argv[1:]
    module_name, text = COMMANDS[name]
    module = load_command(module_name)
    text = text or command_help(module)
    parser = argparse.ArgumentParser(prog=f'social-touch {name}', description=text[0].upper() + text[1:],
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    module.add_arguments(parser)
    args = parser.parse_args(rest)
    try:
        return int(module.run(args) or 0)
    except SocialTouchError as err:
        print(f'social-touch {name}: error: {err}', file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        return 130


if __name__ == '__main__':
    sys.exit(main())
