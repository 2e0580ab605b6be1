"""The project's files import each other without circles.

Every ``import`` and ``from ... import`` in each file of the project's packages, at any depth
(module level and inside functions), is resolved to the project's file it names; the files and
those edges form a graph, and a circle is a strongly connected component of more than one file.
A failure names each circle's files.

Imports under ``if TYPE_CHECKING:`` are left out: they name types for annotations and the type
checker, never run, and so never make one module wait for another.

Run as a script, it also counts the project imports made inside functions and classes, per package.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
PACKAGES = ("touch_driver", "touch_gestures", "touch_graph", "touch_lab", "touch_sim", "touch_view",
            "social_touch_msgs")


def module_files() -> dict[str, Path]:
    """Map each dotted module name of the project to its file."""
    files = {}
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            parts = list(path.relative_to(ROOT).with_suffix("").parts)
            if parts[-1] == "__init__":
                parts.pop()
            files[".".join(parts)] = path
    return files


def _resolve(name: str, modules: dict[str, Path]) -> str | None:
    """The longest prefix of ``name`` that is a project module, or None."""
    while name:
        if name in modules:
            return name
        name = name.rpartition(".")[0]
    return None


def _is_type_checking_block(node: ast.AST) -> bool:
    """``if TYPE_CHECKING:`` (or ``if typing.TYPE_CHECKING:``)."""
    if not isinstance(node, ast.If):
        return False
    test = node.test
    return (isinstance(test, ast.Name) and test.id == 'TYPE_CHECKING') or (
        isinstance(test, ast.Attribute) and test.attr == 'TYPE_CHECKING')


def imports_of(module: str, path: Path, modules: dict[str, Path]) -> list[tuple[str, int, bool]]:
    """The project modules ``module`` imports: (name, line, inside a function or class)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = []

    def visit(node: ast.AST, nested: bool) -> None:
        for child in ast.iter_child_nodes(node):
            if _is_type_checking_block(child):
                for other in child.orelse:
                    visit(ast.Module(body=[other], type_ignores=[]), nested)
                continue
            inner = nested or isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef))
            if isinstance(child, ast.Import):
                for alias in child.names:
                    target = _resolve(alias.name, modules)
                    if target:
                        found.append((target, child.lineno, nested))
            elif isinstance(child, ast.ImportFrom):
                if child.level:
                    base = package.split(".")
                    base = base[:len(base) - (child.level - 1)]
                    stem = ".".join(base + ([child.module] if child.module else []))
                else:
                    stem = child.module or ""
                for alias in child.names:
                    target = _resolve(f"{stem}.{alias.name}", modules) or _resolve(stem, modules)
                    if target:
                        found.append((target, child.lineno, nested))
            visit(child, inner)

    visit(tree, False)
    return found


def import_graph() -> dict[str, set[str]]:
    """Each project module and the project modules it imports (any depth)."""
    modules = module_files()
    return {name: {target for target, _, _ in imports_of(name, path, modules) if target != name}
            for name, path in modules.items()}


def hidden_imports() -> list[tuple[str, int, str]]:
    """Imports of project modules made inside functions or classes: (file, line, target)."""
    modules = module_files()
    return [(str(path.relative_to(ROOT)), line, target)
            for name, path in modules.items()
            for target, line, nested in imports_of(name, path, modules) if nested]


def nested_import_statements(path: Path) -> int:
    """How many import statements of any module (stdlib, third-party, project) sit inside functions."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    functions = [n for n in ast.walk(tree) if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]
    inside = {id(n) for f in functions for n in ast.walk(f) if isinstance(n, (ast.Import, ast.ImportFrom))}
    return len(inside)


def circles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan, iterative)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found = []
    counter = 0
    for root in sorted(graph):
        if root in index:
            continue
        work = [(root, iter(sorted(graph[root])))]
        index[root] = low[root] = counter
        counter += 1
        stack.append(root)
        on_stack.add(root)
        while work:
            node, children = work[-1]
            advanced = False
            for child in children:
                if child not in index:
                    index[child] = low[child] = counter
                    counter += 1
                    stack.append(child)
                    on_stack.add(child)
                    work.append((child, iter(sorted(graph.get(child, ())))))
                    advanced = True
                    break
                if child in on_stack:
                    low[node] = min(low[node], index[child])
            if advanced:
                continue
            work.pop()
            if work:
                low[work[-1][0]] = min(low[work[-1][0]], low[node])
            if low[node] == index[node]:
                component = []
                while True:
                    member = stack.pop()
                    on_stack.discard(member)
                    component.append(member)
                    if member == node:
                        break
                if len(component) > 1:
                    found.append(sorted(component))
    return found


def test_the_project_has_no_import_circles():
    graph = import_graph()
    found = circles(graph)
    assert not found, "import circles:\n" + "\n".join(" <-> ".join(c) for c in found)


def test_a_circle_is_found_and_named():
    graph = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}, "e": {"e"}}
    assert circles(graph) == [["a", "b", "c"]]


def test_imports_inside_functions_count_and_type_checking_ones_do_not(tmp_path, monkeypatch):
    """A circle closed by an import inside a function is a circle; one under TYPE_CHECKING is not."""
    package = tmp_path / "touch_sim"
    package.mkdir()
    (package / "__init__.py").write_text("")
    (package / "low.py").write_text("def f():\n    from . import high\n    return high\n")
    (package / "high.py").write_text("from touch_sim import low\n")
    (package / "typed.py").write_text("from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n"
                                      "    from .high import x\nelse:\n    from .low import f\n")
    monkeypatch.setattr(sys.modules[__name__], "ROOT", tmp_path)
    modules = module_files()
    assert imports_of("touch_sim.low", modules["touch_sim.low"], modules) == [("touch_sim.high", 2, True)]
    assert imports_of("touch_sim.typed", modules["touch_sim.typed"], modules) == [("touch_sim.low", 5, False)]
    assert circles(import_graph()) == [["touch_sim.high", "touch_sim.low"]]


if __name__ == "__main__":
    for circle in circles(import_graph()):
        print(len(circle), " ".join(circle))
    hidden = hidden_imports()
    files = module_files()
    print(f"{len(hidden)} imports of project modules inside functions or classes, "
          f"{sum(nested_import_statements(path) for path in files.values())} import statements of any module "
          "inside functions")
    for package in PACKAGES:
        paths = [path for name, path in files.items() if name.split(".")[0] == package]
        print(f"  {package}: {sum(1 for f, _, _ in hidden if f.startswith(package + '/'))} project, "
              f"{sum(nested_import_statements(path) for path in paths)} any")
