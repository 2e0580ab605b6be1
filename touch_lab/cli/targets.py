"""Commands whose targets bring their own arguments: ``eval``, ``train``, ``codebook``, ``report``.

Each command has a table of its targets, ``name -> (module or module:OBJECT, one-line help)``:
the target has ``add_arguments(parser)`` and ``run(args) -> int``. A new evaluation is one line
in a table here. ``social-touch eval --help`` lists the table without importing a target;
``social-touch eval bear --help`` imports the bear's alone, to show its options.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from touch_graph.cli.main import Command, load

__all__ = ['CODEBOOK', 'CODEBOOK_TARGETS', 'EVAL', 'EVAL_TARGETS', 'REPORT', 'REPORT_TARGETS', 'TRAIN',
           'TRAIN_TARGETS', 'Target', 'TargetCommand']

EVAL_TARGETS: dict[str, Command] = {
    'bear': Command('touch_lab.bear.cli', 'evaluate the Sensate Bear recognisers on simulated people (synthetic)'),
    'patch': Command('touch_lab.patch.cli:EVAL',
                     'evaluate the patch gesture recogniser leave-one-subject-out (Fig. 6 of sympartner2018)'),
    'skin': Command('touch_lab.skin.cli',
                    'evaluate the skin recognisers on real traces through the virtual skin, leave-one-subject-out'),
    'skin-sessions': Command('touch_lab.skin.session_eval', 'how the skin nodes do on simulated sessions of people '
                                                            '(SYNTHETIC): right, wrong, missed, false commands'),
    'skin-collisions': Command('touch_lab.skin.collision_eval', 'collisions, presses and traced gestures on simulated '
                                                                'contacts (SYNTHETIC): confusion and latency'),
    'skin-ending': Command('touch_lab.skin.ending_cli', 'why multi-stroke samples are cut into other than one '
                                                        'gesture, per class; the end-of-gesture rules compared'),
    'skin-transfer': Command('touch_lab.skin.acceptance_transfer', 'the calibrated acceptance score across '
                             'vocabularies: weights fit on one trace file, measured on another'),
    'bear-models': Command('touch_lab.bear.transfer', 'candidate bear subtype models (input columns x training '
                                                      'populations) across families of simulated people (SYNTHETIC)'),
    'adapt': Command('touch_lab.adapt_measure', 'accuracy for a new person after adapting to 0, 1, 3, 5 examples per '
                                                'class (simulated people, SYNTHETIC)'),
}

TRAIN_TARGETS: dict[str, Command] = {
    'bear': Command('touch_lab.bear.train',
                    'train the Sensate Bear subtype model on simulated people (synthetic) and write it as .npz'),
    'bear-candidates': Command('touch_lab.bear.candidates', 'count how often each bear gesture CANDIDATE is '
                               'confirmed on simulated people (synthetic): config/bear_candidates.yaml'),
    'patch': Command('touch_lab.patch.cli:TRAIN',
                     'train the patch gesture model (Gaussian mixtures) from a CSV, bags or simulated people'),
    'skin': Command('touch_lab.skin.train_cli',
                    'build (or --extend) a skin codebook from labelled session bags (social-touch collect skin)'),
}

CODEBOOK_TARGETS: dict[str, Command] = {
    'record': Command('touch_lab.skin.record_cli',
                      'record m repetitions of each gesture from the skin (live, or --simulate) into a codebook'),
    'info': Command('touch_lab.skin.codebook_cli:INFO',
                    'print a skin codebook: recogniser, gestures, templates, thresholds and its model card'),
    'add': Command('touch_lab.skin.codebook_cli:ADD',
                   'add the labelled touches of skin session bags to a codebook (a new file)'),
    'remove': Command('touch_lab.skin.codebook_cli:REMOVE', 'remove gestures from a codebook (a new file)'),
    'merge': Command('touch_lab.skin.codebook_cli:MERGE', 'merge two codebooks of the same recogniser (a new file)'),
    'forecast': Command('touch_lab.skin.forecast:FORECAST', 'which gestures of a codebook the skin will confuse on '
                        'new people, before deploying it (leave-one-person-out inside it)'),
    'calibrate': Command('touch_lab.skin.codebook_cli:CALIBRATE', 'set a codebook\'s rejection for a wrong-command '
                         'rate, leave-one-person-out inside it (a new file)'),
}

REPORT_TARGETS: dict[str, Command] = {
    'bear': Command('touch_lab.bear.report', 'regenerate docs/bear-evaluation.md and docs/bear-rates.md (simulated '
                                             'people; about 15 minutes)'),
    'patch': Command('touch_lab.patch.report', 'regenerate docs/patch-evaluation.md (simulated people; about 10 '
                                               'minutes)'),
    'skin': Command('touch_lab.skin.report', 'regenerate docs/skin-evaluation.md from real traces through the '
                                             'virtual skin (about 15 minutes)'),
    'skin-multistroke': Command('touch_lab.skin.multistroke_report', 'regenerate docs/skin-multistroke.md: '
                                'multi-stroke vocabularies, early decisions, collisions, cost'),
    'skin-rejection': Command('touch_lab.skin.rejection_report', 'regenerate docs/skin-rejection.md: the calibrated '
                              'rejection on both development files and across them'),
    'robustness': Command('touch_lab.robustness.report', 'regenerate docs/robustness.md (bad input, faults, floods, '
                                                         'unplug, kill -9; about 3 minutes)'),
    'compiled-code': Command('touch_lab.bench.compiled_code', "regenerate docs/compiled-code.md (each compiled "
                             "twin's saving at the real rates; about 5 minutes)"),
    'node-memory': Command('touch_lab.bench.node_memory', 'regenerate docs/node-memory.md: RSS of the sensor '
                           "scenes' node processes (launch --processes; about 3 minutes)"),
    'wall-clock': Command('touch_lab.bench.wall_clock', 'regenerate docs/wall-clock.md: CPU of the sensors and of '
                          'N skin patches as launched on the wall clock (about 15 minutes)'),
    'view-screenshot': Command('touch_view.screenshot', "the README's screenshot of the touch view on the demo "
                                                        "scene (synthetic), in headless Chromium"),
    'foxglove-layout': Command('touch_view.foxglove_layout', "write the package's Foxglove layout "
                               "(touch_view/layouts/social_touch.json) from this module"),
}


@dataclass(frozen=True)
class Target:
    """A target that is not a module of its own (e.g. ``train patch`` and ``eval patch`` share one)."""

    add_arguments: Callable[[argparse.ArgumentParser], None]
    run: Callable[[argparse.Namespace], int]
    __doc__: str = ''


def _description(target: Any) -> str:
    """The first paragraph of a target's docstring ('' without one)."""
    return (getattr(target, '__doc__', None) or '').strip().split('\n\n')[0]


class _TargetParser(argparse.ArgumentParser):
    """A target's parser that imports the target and adds its options only when it is the one parsed."""

    def __init__(self, *args: Any, target: str, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self._target = target
        self._filled = False

    def parse_known_args(self, args=None, namespace=None):
        if not self._filled:
            self._filled = True
            target = load(self._target)
            self.description = _description(target) or self.description
            target.add_arguments(self)
        return super().parse_known_args(args, namespace)


@dataclass(frozen=True)
class TargetCommand:
    """A ``social-touch`` command whose targets are the lines of ``table``."""

    table: dict[str, Command]

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """One subparser per target, with the table's help; the chosen target adds its own options."""
        sub = parser.add_subparsers(dest='target', required=True, metavar='TARGET', parser_class=_TargetParser)
        for name, command in sorted(self.table.items()):
            sub.add_parser(name, help=command.help, description=command.help, target=command.target)

    def run(self, args: argparse.Namespace) -> int:
        """Run the chosen target."""
        return int(load(self.table[args.target].target).run(args) or 0)


EVAL = TargetCommand(EVAL_TARGETS)
TRAIN = TargetCommand(TRAIN_TARGETS)
CODEBOOK = TargetCommand(CODEBOOK_TARGETS)
REPORT = TargetCommand(REPORT_TARGETS)
