"""``social-touch view``: serve the live web view of the running graph on localhost.

Starts the ``touch_view`` node in its own process: it subscribes to the perception topics of
the graph (the scene of ``social-touch demo`` or ``launch`` in another terminal, or on another
machine once the graph is on the network) and serves a page that shows them live. Open the
address it prints in a browser; Ctrl-C stops it. To view the demo in one process:
``social-touch demo --view``.
"""

from __future__ import annotations

import argparse

from touch_graph.cli.options import number, port, seconds

#: The view's display rate: ViewServer takes (0, 60] snapshots per second.
view_rate_hz = number(low=0, high=60, low_open=True, unit='Hz')

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('--host', default='127.0.0.1',
                        help='address to listen on (default 127.0.0.1, this machine only; 0.0.0.0: every interface)')
    parser.add_argument('--port', type=port, default=8080, help='port to listen on (default 8080; 0: any free port)')
    parser.add_argument('--rate', type=view_rate_hz, default=20.0, metavar='HZ',
                        help='snapshots per second sent to each page, at most (default 20)')
    parser.add_argument('--stale-after', type=seconds, default=1.0, metavar='SECONDS',
                        help='a sensor with no frame for this long is shown as SILENT (default 1.0)')
    parser.add_argument('--allow-origin', action='append', default=[], metavar='ORIGIN',
                        help='a web page of another site allowed to use the view, e.g. https://dashboard.example '
                             '(repeatable); pages of other sites are refused')


def run(args: argparse.Namespace) -> int:
    # lazy: `social-touch view --help` and its argument errors load no node or runtime
    from touch_graph.node_main import run_node

    from .node import TouchViewNode
    ros_args = ['--ros-args', '-p', f'host:={args.host}', '-p', f'port:={args.port}',
                '-p', f'rate_hz:={float(args.rate)!r}', '-p', f'stale_after_s:={float(args.stale_after)!r}']
    if args.allow_origin:
        ros_args += ['-p', f'allowed_origins:={",".join(args.allow_origin)}']
    return run_node(TouchViewNode, ros_args)
