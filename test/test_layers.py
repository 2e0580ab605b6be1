"""Three layers, arrows one way: lab -> simulation -> runtime, never back.

The runtime (``touch_graph``, ``touch_driver``, ``touch_gestures``: what a robot runs) imports
nothing of the simulation (``touch_sim``) or the lab (``touch_lab``), and the simulation nothing of
the lab. Checked twice: by importing every node module and every runtime module in a fresh
interpreter and looking at ``sys.modules``, and by reading every import statement (function-level
ones too, which a fresh import would not run). matplotlib (the reports' figures) is the lab's
alone: only ``touch_lab.figures`` imports it.
"""

from __future__ import annotations

import ast
import json
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
RUNTIME = ('touch_graph', 'touch_driver', 'touch_gestures')
LAYER_OF = {'touch_graph': 'runtime', 'touch_driver': 'runtime', 'touch_gestures': 'runtime', 'touch_sim': 'simulation',
            'touch_lab': 'lab'}
#: layer -> the layers it may import.
ALLOWED = {'runtime': {'runtime'}, 'simulation': {'runtime', 'simulation'}, 'lab': {'runtime', 'simulation', 'lab'}}

FRESH_IMPORT = '''
import importlib, json, pkgutil, sys
from importlib.metadata import entry_points
import serial
nodes = sorted({ep.value.split(':')[0] for ep in entry_points(group='social_touch.nodes')})
for name in nodes:
    importlib.import_module(name)
after_nodes = sorted(m for m in sys.modules if m.split('.')[0] in ('touch_sim', 'touch_lab', 'matplotlib'))
runtime = []
for top in ('touch_graph', 'touch_driver', 'touch_gestures'):
    package = importlib.import_module(top)
    runtime.append(top)
    for info in pkgutil.walk_packages(package.__path__, top + '.'):
        importlib.import_module(info.name)
        runtime.append(info.name)
after_all = sorted(m for m in sys.modules if m.split('.')[0] in ('touch_sim', 'touch_lab', 'matplotlib'))
print(json.dumps({'nodes': nodes, 'runtime': runtime, 'after_nodes': after_nodes, 'after_all': after_all,
                  'handlers': [p for p in serial.protocol_handler_packages if p.startswith('touch')]}))
'''


def test_importing_every_node_and_runtime_module_loads_nothing_of_the_simulation_or_the_lab():
    proc = subprocess.run([sys.executable, '-c', FRESH_IMPORT], capture_output=True, text=True, cwd=ROOT,
                          timeout=120)
    assert proc.returncode == 0, proc.stderr
    seen = json.loads(proc.stdout)
    if not seen['nodes']:
        pytest.skip('the package is not installed (pip install .): node entry points come from its metadata')
    assert {'touch_driver.bear.node', 'touch_gestures.skin.node', 'touch_graph.bag.recorder_node'} <= set(seen['nodes'])
    assert len(seen['runtime']) > 80                    # every module of the three packages was imported
    assert seen['after_nodes'] == [] and seen['after_all'] == []
    assert seen['handlers'] == []                       # no eager URL handler registration either


def _imports(path: Path) -> list[tuple[int, str]]:
    """(line, module) of every import in ``path``, at any depth, plus importlib.import_module('...') literals."""
    out = []
    for node in ast.walk(ast.parse(path.read_text(encoding='utf-8'))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, alias.name) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            out.append((node.lineno, node.module))
        elif (isinstance(node, ast.Call) and getattr(node.func, 'attr', None) == 'import_module' and node.args
              and isinstance(node.args[0], ast.Constant) and isinstance(node.args[0].value, str)):
            out.append((node.lineno, node.args[0].value))
    return out


def test_no_import_statement_points_back_up_the_layers():
    wrong = []
    for top, layer in LAYER_OF.items():
        for path in sorted((ROOT / top).rglob('*.py')):
            for line, module in _imports(path):
                target = LAYER_OF.get(module.split('.')[0])
                if target is not None and target not in ALLOWED[layer]:
                    wrong.append(f'{path.relative_to(ROOT)}:{line}: {layer} imports {module} ({target})')
    assert wrong == []


def test_the_layer_check_sees_a_function_level_import(tmp_path):
    path = tmp_path / 'x.py'
    path.write_text('def f():\n    from touch_sim.harness import Harness\n'
                    '    importlib.import_module("touch_lab.lines")\n')
    assert [m for _, m in _imports(path)] == ['touch_sim.harness', 'touch_lab.lines']


def test_only_the_lab_figures_import_matplotlib():
    wrong = [f'{path.relative_to(ROOT)}:{line}' for top in (*LAYER_OF, 'touch_view', 'social_touch_msgs')
             for path in sorted((ROOT / top).rglob('*.py')) if path.parent != ROOT / 'touch_lab' / 'figures'
             for line, module in _imports(path) if module.split('.')[0] == 'matplotlib']
    assert wrong == [], f'matplotlib imported outside touch_lab/figures: {wrong}'
