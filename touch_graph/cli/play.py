"""``social-touch play BAG [--rate R | --fast] [--loop] [--topics T ...] [--start-offset S]``: replay a bag.

The player joins the DDS domain and republishes, with the recorded timing (scaled by
``--rate``), after waiting up to ``--wait`` seconds for the subscribers the graph announces
to match; before exiting it waits until reliable subscribers acknowledged every message.
``--fast`` does not wait between messages (one per ``fast_period``, 0.2 ms by default); a slow subscriber then drops
the oldest messages of its queue, as it would with a fast publisher. Message definitions
recorded in the bag are checked against ours first; a topic whose ``.msg`` changed is
refused with the field that differs.
"""

from __future__ import annotations

import argparse
import sys

from ..node_main import StopSignals
from ..runtime import Parameter
from .options import non_negative_seconds, speed_factor

__all__ = ['add_arguments', 'run']


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('bag', help='bag directory (or a .mcap / .db3 file)')
    speed = parser.add_mutually_exclusive_group()
    speed.add_argument('-r', '--rate', type=speed_factor, default=1.0, help='speed factor, > 0 (default 1.0)')
    speed.add_argument('--fast', action='store_true', help='do not wait between messages')
    parser.add_argument('-l', '--loop', action='store_true', help='play again and again until Ctrl-C')
    parser.add_argument('--topics', nargs='+', help='play only these topics')
    parser.add_argument('--start-offset', type=non_negative_seconds, default=0.0,
                        help='skip the first SECONDS of the bag')
    parser.add_argument('--wait', type=non_negative_seconds, default=2.0,
                        help='seconds to wait for the subscribers of the graph (default 2)')
    parser.add_argument('--no-check', action='store_true',
                        help='play topics even if their recorded definition differs from ours (not advised)')


def run(args: argparse.Namespace) -> int:
    from ..bag.player_node import PlayerNode  # lazy: --help runs without the bag libraries
    from ..dds.tool import GraphTool  # lazy: --help runs without Cyclone DDS

    params = [Parameter('bag', value=str(args.bag)), Parameter('rate', value=float(args.rate)),
              Parameter('fast', value=bool(args.fast)), Parameter('loop', value=bool(args.loop)),
              Parameter('start_offset', value=float(args.start_offset)),
              Parameter('check_definitions', value=not args.no_check), Parameter('autostart', value=False)]
    if args.topics:
        params.append(Parameter('topics', value=list(args.topics)))
    with GraphTool('play') as tool:
        view = tool.graph()
        if not view.remote_participants():
            print(f'social-touch play: {tool.no_graph_message()}; playing anyway', file=sys.stderr)
        player = PlayerNode(context=tool.context, parameter_overrides=params)
        tool.executor.add_node(player)
        wanted = {t: len(view.topics[t].subscriptions) for t in player.player.topics
                  if t in view.topics and view.topics[t].subscriptions}

        def matched() -> bool:  # every subscriber the graph announced is matched by our writer
            return all(player._publishers[t].get_subscription_count() >= n for t, n in wanted.items())
        with StopSignals(tool.executor.wake) as stop:
            if wanted:
                tool.spin_until(matched, args.wait, stop=stop)
            player.start()
            tool.spin_until(lambda: player.done, None, stop=stop)
            acked = tool.flush(list(player._publishers.values()), 5.0)
        print(f'social-touch play: published {player.published} messages'
              + ('' if acked else ', not all acknowledged by reliable subscribers within 5 s')
              + (f', {player.errors} unreadable' if player.errors else ''), file=sys.stderr)
        player.destroy_node()
    return 0
