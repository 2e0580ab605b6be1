"""The package's Foxglove layout: the web view's panels, as Foxglove panels on the same topics.

Built with foxglove-sdk's layout model (``foxglove.layouts``) and shipped as
``touch_view/layouts/social_touch.json``; regenerate it after changing this file with::

    social-touch report foxglove-layout touch_view/layouts/social_touch.json

Panels: the patch and skin maps (Image, from ``foxglove_server``'s image topics), the patch's
class posteriors over time (Plot of ``/patch/posteriors``, sympartner2018 Fig. 7, with the class
order of the shipped model), the bear's symbolic gestures and the skin's commands (State
Transitions), the last haptic command and gesture event (Raw Messages), and the drivers'
``/diagnostics`` (Diagnostics Summary).
"""

from __future__ import annotations

import argparse
import json
import sys

from touch_graph.files import write_text

__all__ = ['POSTERIOR_CLASSES', 'add_arguments', 'build_layout', 'run']

#: The classes of the shipped patch model, in its order (``/patch/posteriors.classes``).
POSTERIOR_CLASSES = ('push', 'slap', 'stroke', 'tickle')


def build_layout() -> dict:
    """The layout as a JSON-ready dict (foxglove-sdk's layout format)."""
    import foxglove.layouts as fl  # lazy: only when a layout is written

    def split(direction: str, *items: tuple[float, object]) -> object:
        return fl.SplitContainer(direction=direction, items=[fl.SplitItem(proportion=p, content=c) for p, c in items])

    def image(topic: str, title: str) -> object:
        return fl.ImagePanel(title=title, config=fl.ImageConfig(image_mode=fl.ImageModeConfig(image_topic=topic)))

    posteriors = fl.PlotPanel(title='patch: class posteriors (sympartner2018 Fig. 7)', config=fl.PlotConfig(
        paths=[fl.PlotSeries(value=f'/patch/posteriors.posteriors[{k}]', id=name)
               for k, name in enumerate(POSTERIOR_CLASSES)],
        min_y_value=0.0, max_y_value=1.0, show_legend=True))
    transitions = fl.StateTransitionsPanel(title='bear gestures, skin commands', config=fl.StateTransitionsConfig(
        paths=[fl.StateTransitionsSeries(value='/touch/symbolic.gesture', label='bear gesture'),
               fl.StateTransitionsSeries(value='/touch/gesture.gesture', label='patch gesture'),
               fl.StateTransitionsSeries(value='/touch/haptic_command.command', label='skin command')]))
    command = fl.RawMessagesPanel(title='last skin command', config=fl.RawMessagesConfig(
        topic_path='/touch/haptic_command'))
    diagnostics = fl.DiagnosticsSummaryPanel(title='drivers', config=fl.DiagnosticsSummaryConfig(
        topic_to_render='/diagnostics'))
    content = split('column',
                    (1.2, split('row', (1, image('/patch/activation_image', 'patch: activation')),
                                (1, image('/skin/pressure_image', 'skin: pressure')), (1.6, posteriors))),
                    (1, split('row', (1.6, transitions), (1, command), (1, diagnostics))))
    return json.loads(fl.Layout(content=content).to_json())




def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('output', nargs='?', help='JSON file to write (default: print it)')


def run(args: argparse.Namespace) -> int:
    text = json.dumps(build_layout(), indent=2) + '\n'
    if args.output:
        write_text(args.output, text)
    else:
        sys.stdout.write(text)
    return 0
