"""The ``social-touch`` console script: every layer's commands in one table.

The top layer is the one that may name every other, so the script lives here: the runtime's
table (:data:`touch_graph.cli.main.COMMANDS`) plus the simulation's, the view's and the lab's
commands below, run by the runtime's runner. A line is ``name -> (module or module:object,
one-line help)``; nothing is imported until its command runs.
"""

from __future__ import annotations

from touch_graph.cli.main import COMMANDS as RUNTIME_COMMANDS
from touch_graph.cli.main import Command
from touch_graph.cli.main import main as run_command

__all__ = ['COMMANDS', 'main']

#: Every ``social-touch`` command: the runtime's, then the view's, the simulation's and the lab's.
COMMANDS: dict[str, Command] = {
    **RUNTIME_COMMANDS,
    'view': Command('touch_view.cli', 'serve the live web view of the running graph on localhost'),
    'foxglove': Command('touch_view.foxglove_cli',
                        'serve every topic of the running graph to Foxglove over its WebSocket protocol'),
    'demo': Command('touch_sim.demo', 'the demo scene on virtual sensors, printing what the robot perceives'),
    'eval': Command('touch_lab.cli.targets:EVAL', 'evaluate recognisers on simulated people or recorded data'),
    'train': Command('touch_lab.cli.targets:TRAIN', 'train a recogniser from recordings or simulated people'),
    'codebook': Command('touch_lab.cli.targets:CODEBOOK',
                        'record, inspect and edit haptic-command codebooks of the skin (record, info, add, remove, '
                        'merge)'),
    'report': Command('touch_lab.cli.targets:REPORT',
                      'regenerate the evaluation reports in docs/ (bear, patch, skin) from measurements'),
    'bench': Command('touch_lab.cli.bench', 'measure speed: runtime, drivers, the whole stack at sensor rates, '
                                            'recognisers, the CLI'),
    'lines': Command('touch_lab.lines',
                     'lines of Python per layer (runtime, simulation, lab, tests) and the runtime share of the tree'),
    'collect': Command('touch_lab.collect.cli', 'record labelled sessions of one sensor to rosbag2 (guided protocol; '
                                                '--simulate N: simulated people)'),
    'model': Command('touch_lab.model_cli',
                     'show (info) or add evaluation figures to (card) the model card of a model or codebook file'),
    'adapt': Command('touch_lab.adapt', 'adapt a deployed model to one person from a few labelled examples (session '
                                        'bags of a short collect)'),
}


def main(argv: list[str] | None = None) -> int:
    """``social-touch COMMAND ...`` with every command of the project."""
    return run_command(argv, COMMANDS)


if __name__ == '__main__':
    import sys
    sys.exit(main())
