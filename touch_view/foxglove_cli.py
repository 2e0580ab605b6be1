"""``social-touch foxglove``: serve every topic of the running graph to Foxglove over its WebSocket protocol.

Starts the ``foxglove_server`` node in its own process: every topic of the graph goes out with
its ROS 2 message definition (``ros2msg``) and CDR bytes, plus the patch's and skin's maps as
images. In the Foxglove app: Open connection > Foxglove WebSocket > ws://127.0.0.1:8765, then
Layouts > Import the file printed by --layout. In one process with the demo:
``social-touch demo --foxglove``.
"""

from __future__ import annotations

import argparse
from importlib import resources

from touch_graph.cli.options import port, rate_hz

__all__ = ['LAYOUT', 'add_arguments', 'layout_path', 'run']

#: The package's Foxglove layout, relative to the touch_view package.
LAYOUT = ('layouts', 'social_touch.json')


def layout_path() -> str:
    """Where the installed package's Foxglove layout file is."""
    return str(resources.files('touch_view').joinpath(*LAYOUT))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('--host', default='127.0.0.1',
                        help='address to listen on (default 127.0.0.1, this machine only; 0.0.0.0: every interface)')
    parser.add_argument('--port', type=port, default=8765, help='port to listen on (default 8765, Foxglove\'s; 0: any '
                                                               'free port)')
    parser.add_argument('--image-rate', type=rate_hz, default=20.0, metavar='HZ',
                        help='images of the patch and skin maps per second, at most (default 20)')
    parser.add_argument('--allow-origin', action='append', default=[], metavar='ORIGIN',
                        help='a web page allowed to connect besides the Foxglove app (https://app.foxglove.dev) and '
                             'desktop clients, e.g. https://lichtblick.example (repeatable); other sites are refused')
    parser.add_argument('--layout', action='store_true',
                        help='print the path of the Foxglove layout file of the package and exit')


def run(args: argparse.Namespace) -> int:
    if args.layout:
        print(layout_path())
        return 0
    # lazy: `social-touch foxglove --help` and its argument errors load no node or runtime
    from touch_graph.node_main import run_node

    from .foxglove_node import FoxgloveServerNode
    ros_args = ['--ros-args', '-p', f'host:={args.host}', '-p', f'port:={args.port}',
                '-p', f'image_rate_hz:={float(args.image_rate)!r}']
    if args.allow_origin:
        ros_args += ['-p', f'allowed_origins:={",".join(args.allow_origin)}']
    return run_node(FoxgloveServerNode, ros_args)
