"""``social-touch demo``: the demo scene on virtual sensors, printing what the robot perceives.

Runs ``launch/demo.launch.yaml`` of the package: the three sensors' virtual devices (driven
by scripted scenes of simulated people: all data is synthetic), their drivers, the
recognisers and ``touch_monitor``, which prints one line per perceived event. The graph
runs on a simulated clock, ``--rate`` times real time, and stops by itself after
``--duration`` simulated seconds. While it runs, other terminals can watch it
(``social-touch topic echo /touch/symbolic``) or record it (``social-touch record -a -o demo``);
``--view`` serves the live web view of the scene, ``--foxglove`` every topic to Foxglove.
Run inside a source checkout, it reads the checkout's config/ and launch/ (as ``social-touch
launch`` does), so an edited threshold counts without reinstalling.
"""

from __future__ import annotations

import argparse
import math
import sys

from touch_graph.cli.options import clock_rate, port, seconds
from touch_graph.errors import LaunchError
from touch_graph.launch import LaunchRunner, evaluate_launch
from touch_graph.launch.cli import parse_launch_arguments, use_checkout_files
from touch_graph.launch.preflight import check_config_files
from touch_graph.paths import share_file


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('--duration', type=seconds, default=45.0, metavar='SECONDS',
                        help='simulated seconds to run (default 45: the whole scene)')
    speed = parser.add_mutually_exclusive_group()
    speed.add_argument('--rate', type=clock_rate, default=1.5, metavar='R',
                       help='how many times faster than real time (default 1.5)')
    speed.add_argument('--fast', action='store_true', help='as fast as the machine can (deterministic)')
    parser.add_argument('--view', action='store_true',
                        help='serve the live web view of the scene (social-touch view); its address is logged')
    parser.add_argument('--view-port', type=port, default=8080, metavar='PORT',
                        help='port of the web view (default 8080; 0: any free port)')
    parser.add_argument('--foxglove', action='store_true',
                        help='serve every topic over the Foxglove WebSocket protocol (social-touch foxglove)')
    parser.add_argument('--foxglove-port', type=port, default=8765, metavar='PORT',
                        help='port of the Foxglove server (default 8765; 0: any free port)')
    parser.add_argument('arguments', nargs='*', metavar='name:=value',
                        help='launch arguments of demo.launch.yaml (see social-touch launch --show-args)')


def run(args: argparse.Namespace) -> int:
    if not args.duration > 0:
        raise LaunchError(f'--duration must be > 0 seconds, got {args.duration}')
    rate = math.inf if args.fast else args.rate
    if not rate > 0:
        raise LaunchError(f'--rate must be > 0, got {args.rate}')
    use_checkout_files('demo')     # tuning a checkout's config/ counts in the demo as in launch
    arguments = parse_launch_arguments(args.arguments)
    if args.view:
        arguments.update(view='true', view_port=str(args.view_port))
    if args.foxglove:
        arguments.update(foxglove='true', foxglove_port=str(args.foxglove_port))
    plan = evaluate_launch(share_file('launch', 'demo.launch.yaml'), arguments)
    check_config_files(plan.nodes)  # gestures:=./mine.yaml: a missing or broken file stops here, named
    print(f'social_touch demo: {len(plan.nodes)} nodes, {args.duration:g} s of a simulated scene '
          f'({"as fast as possible" if args.fast else f"{rate:g}x real time"}); all sensor data is synthetic.',
          file=sys.stderr)
    runner = LaunchRunner(plan.nodes, sim_time=True, rate=rate, network=True)
    try:
        runner.start()
        runner.spin(args.duration)
    finally:
        runner.shutdown()
    print('social_touch demo: scene over, all nodes stopped.', file=sys.stderr)
    return 0
