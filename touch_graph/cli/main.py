"""``social-touch``: launch scenes, inspect the graph, record and replay, train, evaluate, benchmark.

Each subcommand lives in its own module with ``add_arguments(parser)`` and ``run(args) -> int``;
only the module of the chosen subcommand is imported, so ``social-touch topic list`` does not
pay for scikit-learn.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import SocialTouchError

# name -> (module, one-line help). The module defines add_arguments(parser) and run(args).
COMMANDS: dict[str, tuple[str, str]] = {
    'demo': ('touch_sim.demo', 'the demo scene on virtual sensors, printing what the robot perceives'),
    'launch': ('touch_graph.launch.cli', 'start a scene: a ROS 2 YAML launch file, in this process'),
    'topic': ('touch_graph.cli.topic', 'topics of the running graph: list, echo, hz, info, pub'),
    'node': ('touch_graph.cli.node', 'nodes of the running graph: list, info'),
    'record': ('touch_graph.cli.record', 'record topics of the running graph to a rosbag2 (MCAP)'),
    'play': ('touch_graph.cli.play', 'replay a rosbag2 into the running graph with its recorded timing'),
    'bag': ('touch_graph.cli.bag', 'bag info, bag reindex (recover a bag whose recorder died)'),
    'eval': ('touch_lab.cli.evaluate', 'evaluate recognisers on simulated people or recorded data'),
    'train': ('touch_lab.cli.train', 'train a recogniser (patch gestures) from recordings or simulated people'),
    'codebook': ('touch_lab.cli.codebook', 'record a haptic-command codebook from the skin (live or simulated)'),
    'interface': ('touch_graph.cli.interface', 'list message types or show one (like ros2 interface)'),
    'export-interfaces': ('touch_graph.cli.export_interfaces',
                          'write the social_touch_msgs ament_cmake package for a ROS 2 workspace'),
    'bench': ('touch_lab.cli.bench', 'measure speed: runtime, drivers, recognisers'),
}

EPILOG = """\
Start with:  social-touch demo          (the demo scene on virtual sensors)
Details:     social-touch COMMAND --help
"""


def _top_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='social-touch', formatter_class=argparse.RawDescriptionHelpFormatter,
        description='Touch perception for a social robot: a ROS 2-style node graph of sensor drivers and '
                    'gesture recognisers.',
        epilog='commands:\n' + '\n'.join(f'  {name:<18} {text}' for name, (_, text) in COMMANDS.items())
        + '\n\n' + EPILOG)
    parser.add_argument('command', choices=sorted(COMMANDS), metavar='COMMAND', help='what to do (see below)')
    return parser


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or argv[0] not in COMMANDS:
        parser = _top_parser()
        if not argv:
            parser.print_help()
            return 2
        parser.parse_args(argv[:1])  # prints usage, a did-you-mean and exits 2 on an unknown command
        return 2
    name, rest = argv[0], argv[1:]
    module_name, text = COMMANDS[name]
    module = importlib.import_module(module_name)
    parser = argparse.ArgumentParser(prog=f'social-touch {name}', description=text[0].upper() + text[1:] + '.',
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
