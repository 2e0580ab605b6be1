"""Each shipped node's process imports what its node uses and nothing else (issue 27, light nodes).

Importing a node's module (its ``social_touch.nodes`` entry point, the one ``launch --processes``
and the console script import) in a fresh interpreter must not load a package the node does not
use. What every node may load, and why:

- numpy, PyYAML, and rosbags' type system (``rosbags.typesys``, ``rosbags.serde``): the runtime's
  messages are built from the ``.msg`` definitions through rosbags' type store
  (touch_graph.messages), and parameters and config files are YAML.

What no node loads unless it is listed for that node below:

- ``sklearn``, ``scipy``: fitting is the lab's (touch_lab); the nodes evaluate fitted models with
  numpy (test/test_model_evaluation.py holds them equal to scikit-learn's).
- ``matplotlib``, ``touch_lab``: figures, evaluation and training.
- ``touch_sim``: simulated sensors are opened through the serial URL handlers at run time, only
  when a driver's port is a simulated one (checked below on its own).
- ``mcap``, ``rosbags.rosbag2``: bag files; only the recorder and the player read or write them.
- ``cyclonedds``: the DDS transport; the runtime loads it when a node joins a domain (not on
  import), and a node in one process with the others never needs it.
- ``serial`` (pyserial): only the drivers open serial ports.
- ``foxglove``: the Foxglove SDK's server; only foxglove_server runs one.
"""

from __future__ import annotations

import subprocess
import sys
from importlib.metadata import entry_points

import pytest

#: Packages a node must not load unless :data:`ALLOWED` lists them for it.
WATCHED = ('sklearn', 'scipy', 'matplotlib', 'touch_lab', 'touch_sim', 'mcap', 'rosbags.rosbag2', 'cyclonedds',
           'serial', 'foxglove')
#: Executable -> the watched packages it needs (reasons in the module doc).
ALLOWED = {
    'bear_driver': {'serial'},
    'patch_driver': {'serial'},
    'skin_driver': {'serial'},
    'recorder': {'mcap', 'rosbags.rosbag2'},
    'player': {'mcap', 'rosbags.rosbag2'},
    'foxglove_server': {'foxglove'},
}
#: What a simulated port (a driver's process in the demo scenes) must not add: the simulator runs in
#: the driver's process, so it evaluates with numpy too.
NOT_IN_SIMULATION = ('sklearn', 'scipy', 'matplotlib', 'touch_lab')

NODES = {ep.name: ep.value.partition(':')[0] for ep in entry_points(group='social_touch.nodes')}
SIMULATION = sorted({ep.value.partition(':')[0] for ep in entry_points(group='social_touch.scene_generators')}
                    | {f'{ep.value}.protocol_{ep.name}'
                       for ep in entry_points(group='social_touch.serial_url_handlers')})

_PROBE = 'import importlib, sys; importlib.import_module(sys.argv[1]); print(" ".join(sorted(sys.modules)))'


def loaded(module: str, watched: tuple[str, ...]) -> set[str]:
    """The ``watched`` packages (or subpackages) a fresh interpreter has loaded after ``import module``."""
    out = subprocess.run([sys.executable, '-c', _PROBE, module], capture_output=True, text=True, check=True)
    modules = set(out.stdout.split())
    return {w for w in watched if w in modules}


def test_every_node_is_covered():
    assert {'haptic_commands', 'patch_gestures', 'bear_gestures', 'skin_driver', 'recorder'} <= set(NODES)
    assert set(ALLOWED) <= set(NODES)


@pytest.mark.parametrize('executable', sorted(NODES))
def test_node_module_loads_only_what_the_node_uses(executable):
    extra = loaded(NODES[executable], WATCHED) - ALLOWED.get(executable, set())
    assert not extra, f'{executable} ({NODES[executable]}) loads {sorted(extra)} on import'


@pytest.mark.parametrize('module', SIMULATION)
def test_simulated_sensor_evaluates_with_numpy(module):
    assert not loaded(module, NOT_IN_SIMULATION), f'{module} runs in a driver process'
