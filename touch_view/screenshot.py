"""Take the README's screenshot of the touch view: the demo scene (synthetic) seen in headless Chromium.

::

    social-touch report view-screenshot docs/touch-view.png

runs ``launch/demo.launch.yaml`` with the view in this process on a simulated clock (``--rate``
times real time), opens the page in headless Chromium (:mod:`touch_view.browser`) and saves a
screenshot once the scene has reached ``--at`` simulated seconds.
"""

from __future__ import annotations

import argparse
import contextlib
import io
import sys
import time

from touch_graph.cli.options import non_negative_seconds, positive_float
from touch_graph.paths import share_file

from .browser import headless_chromium
from .scene import BackgroundScene

__all__ = ['add_arguments', 'run', 'take_screenshot']


def take_screenshot(path: str, *, at_s: float = 17.0, rate: float = 2.0, size: tuple[int, int] = (1400, 1050)) -> None:
    """Save a PNG of the page once the demo scene has run ``at_s`` simulated seconds."""
    with contextlib.redirect_stdout(io.StringIO()):   # touch_monitor's lines; the page is the point here
        scene = BackgroundScene(share_file('launch', 'demo.launch.yaml'), {'view': 'true', 'view_port': '0'},
                                rate=rate).start()
    try:
        with headless_chromium(*size) as browser:
            browser.get(scene.node('touch_view').url)
            end = time.monotonic() + at_s / rate + 30.0
            while time.monotonic() < end:
                shown = browser.execute_script("const t = document.getElementById('graph-time').innerText;"
                                               "return parseFloat(t.replace('graph time', '')) || 0;")
                if shown >= at_s:
                    break
                time.sleep(0.1)
            else:
                raise TimeoutError(f'the page did not reach {at_s} s of the scene')
            browser.save_screenshot(path)
    finally:
        scene.stop()




def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('output', help='PNG file to write, e.g. docs/touch-view.png')
    parser.add_argument('--at', type=non_negative_seconds, default=17.0, metavar='SECONDS',
                        help='scene time of the screenshot')
    parser.add_argument('--rate', type=positive_float, default=2.0, help='simulated seconds per wall second')


def run(args: argparse.Namespace) -> int:
    take_screenshot(args.output, at_s=args.at, rate=args.rate)
    print(f'wrote {args.output}', file=sys.stderr)
    return 0
