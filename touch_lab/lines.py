"""``social-touch lines [--json]``: lines of Python per layer and the runtime's share of the tree.

The layers are the runtime (what a robot runs: ``touch_graph``, ``touch_driver``,
``touch_gestures`` and the interface package ``social_touch_msgs``), the simulation
(``touch_sim``), the lab (``touch_lab``) and the views (``touch_view``: the web view and the
Foxglove server); the tests (``test/`` of a source checkout) are counted beside them. A line is a physical line of a
``.py`` file (what ``wc -l`` counts); ``code`` leaves out blank lines and lines that hold only
a comment. docs/DEVELOPING.md quotes this command's output.
"""

from __future__ import annotations

import argparse
import importlib
import json
from pathlib import Path

__all__ = ['LAYERS', 'add_arguments', 'count_lines', 'line_counts', 'run']


#: layer -> its top-level packages.
LAYERS: dict[str, tuple[str, ...]] = {
    'runtime': ('touch_graph', 'touch_driver', 'touch_gestures', 'social_touch_msgs'),
    'simulation': ('touch_sim',),
    'lab': ('touch_lab',),
    'view': ('touch_view',),
}


def count_lines(directory: Path) -> dict[str, int]:
    """``{'files', 'lines', 'code'}`` over every ``.py`` file under ``directory``."""
    files = lines = code = 0
    for path in sorted(directory.rglob('*.py')):
        files += 1
        for line in path.read_text(encoding='utf-8').splitlines():
            lines += 1
            stripped = line.strip()
            code += bool(stripped) and not stripped.startswith('#')
    return {'files': files, 'lines': lines, 'code': code}


def _add(total: dict[str, int], part: dict[str, int]) -> dict[str, int]:
    return {k: total.get(k, 0) + v for k, v in part.items()}


def line_counts() -> dict:
    """Counts per package and layer, the tests', and the runtime's share of all the layers."""
    packages: dict[str, dict[str, int]] = {}
    layers: dict[str, dict[str, int]] = {}
    root = None
    for layer, names in LAYERS.items():
        layers[layer] = {'files': 0, 'lines': 0, 'code': 0}
        for name in names:
            directory = Path(importlib.import_module(name).__file__).parent
            root = directory.parent
            packages[name] = count_lines(directory)
            layers[layer] = _add(layers[layer], packages[name])
    tree = {'files': 0, 'lines': 0, 'code': 0}
    for counts in layers.values():
        tree = _add(tree, counts)
    tests = root / 'test' if root is not None else None
    out: dict = {'packages': packages, 'layers': layers, 'tree': tree,
                 'runtime_share_lines': layers['runtime']['lines'] / tree['lines'] if tree['lines'] else 0.0,
                 'runtime_share_code': layers['runtime']['code'] / tree['code'] if tree['code'] else 0.0}
    if tests is not None and tests.is_dir():
        out['tests'] = count_lines(tests)
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument('--json', action='store_true', help='print one JSON object')


def run(args: argparse.Namespace) -> int:
    counts = line_counts()
    if args.json:
        print(json.dumps(counts, indent=2))
        return 0
    print(f'{"":19s} {"files":>6s} {"lines":>7s} {"code":>7s}')
    for layer, names in LAYERS.items():
        c = counts['layers'][layer]
        print(f'{layer:19s} {c["files"]:6d} {c["lines"]:7d} {c["code"]:7d}')
        for name in names:
            p = counts['packages'][name]
            print(f'  {name:17s} {p["files"]:6d} {p["lines"]:7d} {p["code"]:7d}')
    t = counts['tree']
    print(f'{"tree (all layers)":19s} {t["files"]:6d} {t["lines"]:7d} {t["code"]:7d}')
    if 'tests' in counts:
        c = counts['tests']
        print(f'{"tests":19s} {c["files"]:6d} {c["lines"]:7d} {c["code"]:7d}')
    print(f'runtime share of the tree: {100 * counts["runtime_share_lines"]:.1f} % of lines, '
          f'{100 * counts["runtime_share_code"]:.1f} % of code lines')
    return 0
