"""``social-touch launch FILE [name:=value ...]``: start a scene's nodes, in this process or in processes of their own.

As ``ros2 launch``: FILE is a path or ``PKG FILE``; arguments are ``name:=value``, and a name the
file does not declare is an error. Every node runs in this process unless ``--processes`` or a
process attribute (``respawn``...) gives it a process of its own (:mod:`.processes`). The graph
joins the DDS domain unless ``--no-network``. In a source checkout, its ``config/`` and
``launch/`` are used. Config files that nodes are given are checked before any node starts
(:mod:`.preflight`). Exit code 1 when a node died, else 0.
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from ..cli.options import clock_rate, non_negative_seconds
from ..errors import ConfigError, LaunchError
from ..node_main import StopSignals
from ..paths import launch_share, prefer_checkout
from ..yamlconf import did_you_mean
from .entities import collect_arguments, evaluate_launch
from .preflight import check_config_files
from .processes import POLL_S, ProcessSupervisor
from .runner import LaunchRunner, rclpy_runtime
from .specs import DeclaredArgument

__all__ = ['add_arguments', 'find_launch_file', 'parse_launch_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The options of ``social-touch launch``."""
    parser.add_argument('words', nargs='+', metavar='FILE | PKG FILE',
                        help='a YAML launch file, or a package and a launch file in its share directory, '
                             "followed by launch arguments 'name:=value'")
    parser.add_argument('-s', '--show-args', action='store_true',
                        help='list the launch arguments (description, default, choices) and exit')
    parser.add_argument('-p', '--print-description', action='store_true',
                        help='print the resolved nodes (names, namespaces, parameters, remaps) without starting them')
    parser.add_argument('--duration', type=non_negative_seconds, metavar='SECONDS',
                        help='stop after this many seconds of ROS time (default: until Ctrl-C / SIGTERM)')
    parser.add_argument('--sim-time', action='store_true', help='run the graph on a simulated clock')
    parser.add_argument('--no-network', action='store_true',
                        help='keep the graph in this process: do not join the DDS domain (other processes and '
                             'machines, social-touch topic echo and record, ROS 2 nodes do not see it)')
    parser.add_argument('--no-bridge', action='store_true', dest='no_network', help=argparse.SUPPRESS)
    parser.add_argument('--strict-params', action='store_true',
                        help='a parameter in the launch file or a parameter file that no node declares (a typo) '
                             'stops the launch; by default it is a warning naming file, line and the nearest '
                             'declared name (ROS 2 itself accepts undeclared overrides silently)')
    parser.add_argument('--processes', action='store_true',
                        help='run every node in a process of its own (connected over DDS), as ros2 launch does; by '
                             'default only nodes with a process attribute (respawn...) do')
    parser.add_argument('--rate', type=clock_rate, metavar='R',
                        help='with --sim-time: simulated seconds per wall-clock second (default: inf, as fast '
                             'as possible)')


def find_launch_file(words: list[str]) -> tuple[Path, list[str]]:
    """``FILE rest...`` or ``PKG FILE rest...`` -> (launch file, rest).

    Raises:
        LaunchError: when neither form names an existing launch file.
    """
    first = words[0]
    if ':=' in first:
        raise LaunchError(f"expected a launch file (or PKG FILE) before the launch arguments; got {first!r}")
    if Path(first).is_file():
        return Path(first), words[1:]
    if len(words) < 2 or ':=' in words[1]:
        raise LaunchError(f"launch file not found: {first} (give a path to a .launch.yaml file, or 'PKG FILE')")
    package, name = words[0], words[1]
    try:
        share = launch_share(package)
    except ConfigError as err:
        raise LaunchError(f'{first} is neither a file nor a package: {err.bare_message}') from err
    direct = share / 'launch' / name
    if direct.is_file():
        return direct, words[2:]
    found = sorted(p for p in share.rglob(Path(name).name) if p.is_file() and str(p).endswith(name))
    if len(found) == 1:
        return found[0], words[2:]
    if len(found) > 1:
        raise LaunchError(f"several files named {name!r} in package '{package}': "
                          f'{", ".join(str(p) for p in found)}; give the path instead')
    available = sorted(p.name for p in (share / 'launch').glob('*.yaml')) if (share / 'launch').is_dir() else []
    raise LaunchError(f"package '{package}' has no launch file {name!r}{did_you_mean(name, available)}; "
                      f'its launch files: {", ".join(available) or "none"} (in {share / "launch"})')


def parse_launch_arguments(words: list[str]) -> dict[str, str]:
    """``['a:=1', 'b:=x y']`` -> ``{'a': '1', 'b': 'x y'}``.

    >>> parse_launch_arguments(['rate:=30', 'robot:=teddy'])
    {'rate': '30', 'robot': 'teddy'}
    """
    out: dict[str, str] = {}
    for word in words:
        name, sep, value = word.partition(':=')
        if not sep or not name:
            raise LaunchError(f"unexpected argument {word!r}: launch arguments are name:=value (options such as "
                              '--duration go before the launch file or after all name:=value arguments)')
        if name in out:
            raise LaunchError(f"launch argument '{name}' is given twice ({out[name]!r} and {value!r}); keep one")
        out[name] = value
    return out


def format_arguments(arguments: list[DeclaredArgument]) -> str:
    """The ``--show-args`` listing, in ``ros2 launch -s`` style."""
    if not arguments:
        return 'No arguments.'
    lines = ["Arguments (pass arguments as '<name>:=<value>'):"]
    for arg in arguments:
        description = arg.description or 'no description given'
        if arg.choices is not None:
            description += f'{"" if description.endswith(".") else "."} Valid choices are: {list(arg.choices)}'
        lines += ['', f"    '{arg.name}':", f'        {description}']
        lines.append(f"        (default: '{arg.default}')" if arg.default is not None else '        (required)')
    return '\n'.join(lines)


def use_checkout_files(command: str) -> None:
    """Inside a source checkout, read its config/ and launch/ rather than the installed copy (tuning
    without reinstalling, :func:`~touch_graph.paths.prefer_checkout`), and say so on stderr."""
    checkout, installed = prefer_checkout()
    if checkout is not None:
        print(f"[{command}] inside the checkout {checkout}: its config/ and launch/ are used, not the installed "
              f'copy in {installed}', file=sys.stderr)


def run(args: argparse.Namespace) -> int:
    """Run ``social-touch launch``; errors are raised as :class:`LaunchError` (``main`` prints them)."""
    use_checkout_files('launch')
    path, rest = find_launch_file(list(args.words))
    arguments = parse_launch_arguments(rest)
    if args.rate is not None and not args.sim_time:
        raise LaunchError('--rate needs --sim-time (it sets how fast simulated time runs)')
    if args.show_args:
        declared, unresolved = collect_arguments(path, arguments, find_package_share=launch_share)
        print(format_arguments(declared))
        for where in unresolved:
            print(f'\n(arguments of the include at {where} are not listed: its file is known only at launch)')
        return 0
    plan = evaluate_launch(path, arguments, find_package_share=launch_share)
    if args.print_description:
        print(plan.describe())
        return 0
    if not plan.nodes:
        print(f'{path}: no nodes to start (check the if/unless conditions and arguments)', file=sys.stderr)
        return 0
    check_config_files(plan.nodes)
    alone = [spec for spec in plan.nodes if args.processes or spec.process is not None]
    together = [spec for spec in plan.nodes if not (args.processes or spec.process is not None)]
    if alone and args.sim_time:
        raise LaunchError(f'{len(alone)} node(s) run in processes of their own (--processes, or a process attribute '
                          'such as respawn), and a simulated clock cannot be shared between processes: drop '
                          '--sim-time, or run every node in this process')
    if alone and args.no_network:
        raise LaunchError('nodes in processes of their own talk over DDS: --no-network cannot go with --processes '
                          'or process attributes (respawn...)')
    return _run(args, together, alone)


def _in_process_runner(args: argparse.Namespace, specs: list, network: bool) -> LaunchRunner:
    """The runner of the nodes that run in this process: on real rclpy when ``touch_graph.compat`` uses it (a
    sourced ROS 2 without SOCIAL_TOUCH_SHIM=1: the node classes are rclpy nodes), else on our runtime."""
    from .. import compat  # lazy: a launch whose nodes all run in processes loads no runtime here
    if not compat.USING_ROS:
        return LaunchRunner(specs, sim_time=args.sim_time, rate=args.rate, network=network,
                            strict_params=args.strict_params)
    if args.sim_time:
        raise LaunchError("--sim-time runs our runtime's simulated clock, and these nodes run on real rclpy (ROS 2 "
                          'is sourced): publish /clock and set use_sim_time:=true instead, or run with '
                          'SOCIAL_TOUCH_SHIM=1')
    if not network:
        raise LaunchError('--no-network: real rclpy always joins the DDS domain (ROS 2 is sourced); set '
                          'ROS_AUTOMATIC_DISCOVERY_RANGE=OFF to keep it on this machine, or run with '
                          'SOCIAL_TOUCH_SHIM=1')
    return LaunchRunner(specs, runtime=rclpy_runtime(), strict_params=args.strict_params)


def _run(args: argparse.Namespace, together: list, alone: list) -> int:
    """Start the in-process nodes, then the node processes; spin and watch until the end; stop everything."""
    supervisor = ProcessSupervisor(alone, strict_params=args.strict_params) if alone else None
    runner = None
    if together:
        runner = _in_process_runner(args, together, network=True if alone else not args.no_network)
    try:
        if runner is not None:
            runner.start()
            names = ', '.join(node.get_fully_qualified_name() for node in runner.nodes)
            print(f'[launch] {len(runner.nodes)} node(s) running in this process: {names}', file=sys.stderr)
        if supervisor is not None:
            supervisor.start()
        if runner is not None:
            runner.spin(args.duration, every_slice=supervisor.poll if supervisor is not None else None)
        else:
            end = None if args.duration is None else time.monotonic() + args.duration
            with StopSignals() as stop:
                while not stop.requested and supervisor.active() and (end is None or time.monotonic() < end):
                    supervisor.poll()
                    stop.event.wait(POLL_S)
            if not supervisor.active():
                print('[launch] every node process has exited', file=sys.stderr)
    finally:
        try:
            if supervisor is not None:
                supervisor.stop()
        finally:
            if runner is not None:
                runner.shutdown()
    print('[launch] all nodes stopped', file=sys.stderr)
    died = (supervisor.died if supervisor is not None else 0) + (len(runner.died) if runner is not None else 0)
    if runner is not None and runner.died:
        print(f'[launch] {len(runner.died)} node(s) of this process died: {"; ".join(runner.died)}', file=sys.stderr)
    return 1 if died else 0
