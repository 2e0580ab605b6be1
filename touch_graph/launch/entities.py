"""Evaluate a parsed launch file as ros2/launch does: arguments, scopes, namespaces, includes -> node specs.

``arg`` keeps a value already set; a ``group`` is scoped by default, an ``include`` is not;
``push_ros_namespace`` sets the ``ros_namespace`` configuration. Parameter values from
substitutions are read as YAML (``'3'`` -> 3) unless the ``param`` has a ``type``; literal
strings stay strings. Nothing is started.
"""

from __future__ import annotations

import os
import shlex
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from ..errors import ConfigError, LaunchError
from ..paths import launch_share
from ..yamlconf import YamlBoundsError, did_you_mean, safe_load
from .parser import (
    Action,
    ArgAction,
    Condition,
    GroupAction,
    IncludeAction,
    LaunchFile,
    LetAction,
    NodeAction,
    ParamDecl,
    PushNamespaceAction,
    RemapDecl,
    Str,
    parse_launch_file,
)
from .specs import (
    NAMESPACE_PATTERN,
    NODE_NAME_PATTERN,
    TOPIC_PATTERN,
    DeclaredArgument,
    LaunchPlan,
    NodeSpec,
    ParamData,
    ParamFile,
    ParamValue,
    ProcessOptions,
    prefix_namespace,
)
from .substitutions import Location, Scope, Template, Text, evaluate, evaluate_condition, literal_text

__all__ = ['MAX_INCLUDE_DEPTH', 'collect_arguments', 'evaluate_launch']

#: Deepest include nesting accepted (a cycle is reported as one before this).
MAX_INCLUDE_DEPTH = 32


# ------------------------------------------------------------------------------- evaluation

class _Evaluator:
    """Walks actions in order, keeping the scope (configurations, current file) and the output."""

    def __init__(self, arguments: Mapping[str, str], environ: Mapping[str, str],
                 find_package_share: Callable[[str], Path], dry_run: bool = False) -> None:
        self.scope = Scope(dict(arguments), None, environ, {}, find_package_share)
        self.from_command_line = set(arguments)
        self.dry_run = dry_run  # collect declarations only: ignore conditions, skip nodes, tolerate failures
        self.files: dict[Path, LaunchFile] = {}
        self.stack: list[tuple[Path, Location | None]] = []
        self.nodes: list[NodeSpec] = []
        self.declared: dict[str, DeclaredArgument] = {}
        self.unresolved_includes: list[Location] = []

    def text(self, template: Template, where: Location) -> str:
        return evaluate(template, self.scope, where)

    # -- files
    def run_file(self, path: Path, included_from: Location | None) -> None:
        path = path.resolve()
        chain = [p for p, _ in self.stack]
        if path in chain:
            cycle = ' -> '.join(str(p) for p in [*chain[chain.index(path):], path])
            raise (included_from or Location(str(path))).error(f'include cycle: {cycle}')
        if len(self.stack) >= MAX_INCLUDE_DEPTH:
            raise (included_from or Location(str(path))).error(f'includes nested deeper than {MAX_INCLUDE_DEPTH}')
        if path not in self.files:
            self.files[path] = parse_launch_file(path)
        previous = self.scope.launch_file
        self.stack.append((path, included_from))
        self.scope.launch_file = path
        try:
            self.visit_all(self.files[path].actions)
        finally:
            self.stack.pop()
            self.scope.launch_file = previous

    def visit_all(self, actions: tuple[Action, ...]) -> None:
        for action in actions:
            if self.dry_run or self.condition_holds(action.condition, action.where):
                self.visit(action)

    def condition_holds(self, condition: Condition, where: Location) -> bool:
        if condition.if_ is not None and not evaluate_condition(self.text(condition.if_, where), 'if', where):
            return False
        return condition.unless is None or not evaluate_condition(self.text(condition.unless, where), 'unless', where)

    def visit(self, action: Action) -> None:
        if isinstance(action, ArgAction):
            self.declare(action)
        elif isinstance(action, LetAction):
            self.soft(self.let, action.name, action.value, action.where)
        elif isinstance(action, PushNamespaceAction):
            self.soft(self.push_namespace, action)
        elif isinstance(action, GroupAction):
            self.group(action)
        elif isinstance(action, IncludeAction):
            self.include(action)
        elif not self.dry_run:
            self.nodes.append(self.node(action))

    def soft(self, step: Callable[..., None], *args: Any) -> None:
        """Run ``step``; in a dry run, a value that cannot be computed yet is skipped, not an error."""
        try:
            step(*args)
        except LaunchError:
            if not self.dry_run:
                raise

    def push_namespace(self, action: PushNamespaceAction) -> None:
        pushed = self.text(action.namespace, action.where)
        self.scope.configurations['ros_namespace'] = self.namespace(
            prefix_namespace(self.scope.configurations.get('ros_namespace'), pushed), action.where)

    def let(self, name: Template, value: Template, where: Location) -> None:
        key = self.text(name, where)
        if not key:
            raise where.error('a launch configuration name is empty')
        self.scope.configurations[key] = self.text(value, where)

    # -- arguments
    def declare(self, action: ArgAction) -> None:
        default = None if action.default is None else (literal_text(action.default) or _show(action.default))
        self.declared.setdefault(action.name, DeclaredArgument(action.name, action.description, default,
                                                               action.choices, action.where))
        configurations = self.scope.configurations
        if action.name not in configurations:
            if action.default is None:
                if self.dry_run:
                    return
                raise action.where.error(self._missing_argument(action))
            try:
                configurations[action.name] = self.text(action.default, action.where)
            except LaunchError:
                if self.dry_run:
                    return
                raise
        value = configurations[action.name]
        if action.choices is not None and value not in action.choices and not self.dry_run:
            source = ' (from the command line)' if action.name in self.from_command_line else ''
            raise action.where.error(f"launch argument '{action.name}' is {value!r}{source}, not one of: "
                                     f'{", ".join(action.choices)}{did_you_mean(value, action.choices)}')

    def _missing_argument(self, action: ArgAction) -> str:
        if len(self.stack) > 1 and self.stack[-1][1] is not None:
            return (f"launch argument '{action.name}' has no default and was not given; pass it from the include "
                    f"at {self.stack[-1][1]} with 'arg: [{{name: {action.name}, value: ...}}]'")
        return f"launch argument '{action.name}' is required (no default); pass it as {action.name}:=VALUE"

    # -- structure
    def group(self, action: GroupAction) -> None:
        saved = dict(self.scope.configurations)
        kept = []
        for name, value, where in action.keep:
            try:
                kept.append((self.text(name, where), self.text(value, where)))
            except LaunchError:
                if not self.dry_run:
                    raise
        if action.scoped and not action.forwarding:
            self.scope.configurations.clear()
        self.scope.configurations.update(kept)
        try:
            self.visit_all(action.children)
        finally:
            if action.scoped:
                self.scope.configurations.clear()
                self.scope.configurations.update(saved)

    def include(self, action: IncludeAction) -> None:
        try:
            text = self.text(action.file, action.where)
        except LaunchError:
            if not self.dry_run:
                raise
            text = ''  # a dry run: not known before the launch runs
        path = Path(text)
        if not text or not path.is_file():
            if self.dry_run:
                self.unresolved_includes.append(action.where)
                return
            raise action.where.error(f'included launch file not found: {text} (a relative path is relative to the '
                                     'current directory, as in ros2 launch; use $(dirname)/... for a file next to '
                                     'this one or $(find-pkg-share PKG)/launch/...)')
        for name, value, where in action.arguments:
            self.soft(self.let, name, value, where)
        self.run_file(path, action.where)

    # -- nodes
    def namespace(self, namespace: str | None, where: Location) -> str | None:
        if namespace is not None and not NAMESPACE_PATTERN.match(namespace):
            raise where.error(f'invalid namespace {namespace!r}: tokens of letters, digits and underscores '
                              "(not starting with a digit) separated by '/', e.g. /robot/bear")
        return namespace

    def node(self, action: NodeAction) -> NodeSpec:
        where = action.where
        pkg, exec_ = self.text(action.pkg, where), self.text(action.exec, where)
        if not pkg or not exec_:
            raise where.error(f"'pkg' and 'exec' of 'node' must not be empty; got pkg={pkg!r}, exec={exec_!r}")
        name = None if action.name is None else self.text(action.name, where)
        if name is not None and not NODE_NAME_PATTERN.match(name):
            raise where.error(f'invalid node name {name!r}: letters, digits and underscores, not starting with '
                              'a digit (e.g. bear_driver)')
        own = None if action.namespace is None else self.text(action.namespace, where)
        namespace = self.namespace(prefix_namespace(self.scope.configurations.get('ros_namespace'), own), where)
        params: list[ParamValue | ParamFile] = []
        for decl in action.params:
            params += self.params(decl, '')
        spec = NodeSpec(pkg, exec_, name, namespace, tuple(params), tuple(self.remap(r) for r in action.remaps),
                        where.path, where.line, self.split(action.args, 'args', where),
                        self.split(action.ros_args, 'ros_args', where), action.output,
                        self.process(action.process) if action.process else None)
        if spec.full_name is not None:
            for other in self.nodes:
                if other.full_name == spec.full_name:
                    raise where.error(f'two nodes named {spec.full_name} (the other at {other.where}); give one '
                                      "a different 'name' or 'namespace'")
        return spec

    def process(self, attributes: tuple[tuple[str, Any, Location], ...]) -> ProcessOptions:
        """The process options of a node's ``respawn``, ``respawn_delay``... (as ros2 launch reads them)."""
        values: dict[str, Any] = {}
        for key, raw, where in attributes:
            value = raw if isinstance(raw, (bool, int, float)) else _from_yaml(self.text(raw, where))
            if key == 'respawn':
                if isinstance(value, str) and value.lower() in ('true', 'false'):
                    value = value.lower() == 'true'
                if not isinstance(value, bool):
                    raise where.error(f"'respawn' of 'node' must be true or false; got {value!r}")
            elif key == 'respawn_max_retries':
                if isinstance(value, bool) or not isinstance(value, int) or value < -1:
                    raise where.error(f"'respawn_max_retries' of 'node' must be an integer >= -1 (-1: no limit); "
                                      f'got {value!r}')
            elif isinstance(value, bool) or not isinstance(value, (int, float)) or not 0 <= value < 1e6:
                raise where.error(f"'{key}' of 'node' must be a number of seconds >= 0; got {value!r}")
            values[key] = float(value) if key.endswith(('_delay', '_timeout')) else value
        return ProcessOptions(**values)

    def split(self, template: Template | None, what: str, where: Location) -> tuple[str, ...]:
        if template is None:
            return ()
        text = self.text(template, where)
        try:
            return tuple(shlex.split(text))
        except ValueError as err:
            raise where.error(f"'{what}' of 'node' is not a valid argument list ({err}): {text!r}") from err

    def remap(self, decl: RemapDecl) -> tuple[str, str]:
        source, target = self.text(decl.source, decl.where), self.text(decl.target, decl.where)
        for role, name in (('from', source), ('to', target)):
            if not TOPIC_PATTERN.match(name):
                raise decl.where.error(f"remap '{role}' {name!r} is not a valid ROS name: tokens of letters, digits "
                                       "and underscores separated by '/', optionally starting with '/' or '~'")
        return source, target

    def params(self, decl: ParamDecl, prefix: str) -> list[ParamValue | ParamFile]:
        where = decl.where
        if decl.from_file is not None:
            text = self.text(decl.from_file, where)
            path = Path(text)
            if not path.is_file():
                raise where.error(f'parameter file not found: {text} (a relative path is relative to the current '
                                  'directory, as in ros2 launch; use $(dirname)/... or $(find-pkg-share PKG)/...)')
            return [ParamFile(path.resolve())]
        name = self.text(decl.name, where) if decl.name is not None else ''
        if not name or any(not NODE_NAME_PATTERN.match(token) for token in name.split('.')):
            raise where.error(f'invalid parameter name {name!r}: dot-separated tokens of letters, digits and '
                              'underscores (e.g. cutoffs.tickle)')
        full = f'{prefix}{name}'
        if decl.children:
            out: list[ParamValue | ParamFile] = []
            for child in decl.children:
                out += self.params(child, full + '.')
            return out
        return [ParamValue(full, _param_value(decl, full, self), decl.where)]


def _show(template: Template) -> str:
    """A template's source-like text, for a default that uses substitutions."""
    out = []
    for part in template:
        if isinstance(part, Text):
            out.append(part.text)
        else:
            args = [_show(arg) for arg in part.args]
            out.append(f'$({part.name}{"".join(" " + (a if " " not in a else repr(a)) for a in args)})')
    return ''.join(out)


# --------------------------------------------------------------------------- parameter values

_SCALARS: dict[str, type] = {'str': str, 'bool': bool, 'int': int, 'float': float}


def _from_yaml(text: str) -> Any:
    """Text read with YAML rules (``'3'`` -> 3, ``'[1, 2]'`` -> [1, 2]); text that is not YAML stays text."""
    if not text:
        return ''
    try:
        return safe_load(text, 'a parameter value')
    except YamlBoundsError:
        raise  # too large or too deep to be a parameter value, as YAML or as text
    except ConfigError:
        return text


def _coerce_scalar(value: Any, type_: str, name: str, where: Location, declared: str | None = None) -> Any:
    """``value`` as the scalar ``type_``; ``declared`` is the param's own type for the message (list_of_...)."""
    scalar = _SCALARS[type_]
    if scalar is float and isinstance(value, int) and not isinstance(value, bool):
        return float(value)
    if isinstance(value, scalar) and not (scalar is int and isinstance(value, bool)):
        return value
    raise where.error(f"param '{name}' has type {declared or type_} but the value is {type(value).__name__} "
                      f'{value!r}')


def _item(item: Any, type_: str | None, name: str, where: Location, evaluator: _Evaluator,
          declared: str | None = None) -> Any:
    """One value (``type_``: None or a scalar type name)."""
    if isinstance(item, Str):
        text = evaluator.text(item.template, where)
        if type_ == 'str':
            return text
        if type_ is None and literal_text(item.template) is not None:
            return text  # launch_ros: a literal string stays a string ...
        value = _from_yaml(text)  # ... while a substitution's result is read as YAML
    else:
        value = item
    return value if type_ is None else _coerce_scalar(value, type_, name, where, declared)


def _param_value(decl: ParamDecl, name: str, evaluator: _Evaluator) -> ParamData:
    where, raw = decl.where, decl.value
    type_ = None if decl.type in (None, 'yaml') else decl.type
    list_type = type_.removeprefix('list_of_') if type_ is not None and type_.startswith('list_of_') else None
    if isinstance(raw, tuple):
        if type_ is not None and list_type is None:
            raise where.error(f"param '{name}' has type {type_} but its value is a list; use type list_of_{type_}")
        items = tuple(_item(item, list_type, name, where, evaluator, decl.type) for item in raw)
        return _uniform(items, name, where)
    if list_type is not None:
        items = _item(raw, None, name, where, evaluator)
        if isinstance(items, str) and isinstance(raw, Str):
            items = _from_yaml(items)
        if not isinstance(items, list):
            raise where.error(f"param '{name}' has type {type_} but the value {items!r} is not a list")
        return _uniform(tuple(_coerce_scalar(item, list_type, name, where, type_) for item in items), name, where)
    value = _item(raw, type_, name, where, evaluator)
    if isinstance(value, list):
        return _uniform(tuple(value), name, where)
    return _check_scalar(value, name, where)


def _check_scalar(value: Any, name: str, where: Location) -> Any:
    if isinstance(value, (bool, int, float, str)):
        return value
    what = 'empty (null)' if value is None else f'a {type(value).__name__}'
    raise where.error(f"param '{name}' is {what} after substitution ({value!r}); a ROS parameter is a bool, "
                      "int, float, string or a list of one of those. Quote the value or set 'type: str'")


def _uniform(values: tuple[Any, ...], name: str, where: Location) -> ParamData:
    if not values:
        raise where.error(f"param '{name}' is an empty list; ROS 2 cannot tell its element type, so give at least "
                          'one item (or leave the parameter at its default)')
    for value in values:
        if isinstance(value, (list, tuple, dict)) or value is None:
            raise where.error(f"param '{name}': list items must be bools, numbers or strings; got {value!r}")
    kinds = {bool if isinstance(v, bool) else float if isinstance(v, (int, float)) else str for v in values}
    if len(kinds) > 1:
        raise where.error(f"param '{name}': the items of a list must share one type (bools, numbers or strings); "
                          f'got {list(values)!r}')
    if kinds == {float} and any(isinstance(v, float) for v in values):
        return tuple(float(v) for v in values)  # ints among floats become floats, as in launch_ros
    return values


# -------------------------------------------------------------------------------- entry points

def evaluate_launch(path: str | Path, arguments: Mapping[str, str] | None = None, *,
                    environ: Mapping[str, str] | None = None,
                    find_package_share: Callable[[str], Path] = launch_share,
                    check_arguments: bool = True) -> LaunchPlan:
    """Evaluate the launch file at ``path`` with ``arguments`` (``name -> value``, as ``name:=value``).

    Args:
        check_arguments: reject an argument name that no ``arg`` of the file (or of its includes)
            declares, listing the declared ones.

    Raises:
        LaunchError: naming the file and line of the first problem.
    """
    arguments = dict(arguments or {})
    environ = os.environ if environ is None else environ
    check = check_arguments and bool(arguments)
    static: list[DeclaredArgument] = []
    if check:
        # Checked before running, so a typo is reported as such and not as a missing argument.
        static, unresolved = collect_arguments(path, arguments, environ=environ, find_package_share=find_package_share)
        if not unresolved:
            _check_known(arguments, static, path)
    evaluator = _Evaluator(arguments, environ, find_package_share)
    evaluator.run_file(Path(path), None)
    if check:
        _check_known(arguments, static + list(evaluator.declared.values()), path)
    return LaunchPlan(Path(path).resolve(), evaluator.nodes, list(evaluator.declared.values()),
                      dict(evaluator.scope.configurations))


def collect_arguments(path: str | Path, arguments: Mapping[str, str] | None = None, *,
                      environ: Mapping[str, str] | None = None,
                      find_package_share: Callable[[str], Path] = launch_share,
                      ) -> tuple[list[DeclaredArgument], list[Location]]:
    """Every ``arg`` of the file and of the includes whose path resolves, whatever the conditions.

    This is what ``--show-args`` lists (``ros2 launch -s`` does the same). Returns the
    arguments in file order and the locations of includes whose file could not be resolved
    without running the launch file.
    """
    evaluator = _Evaluator(dict(arguments or {}), os.environ if environ is None else environ, find_package_share,
                           dry_run=True)
    evaluator.run_file(Path(path), None)
    return list(evaluator.declared.values()), evaluator.unresolved_includes


def _check_known(arguments: Mapping[str, str], declared: list[DeclaredArgument], path: str | Path) -> None:
    names = list(dict.fromkeys(a.name for a in declared))
    for name in arguments:
        if name not in names:
            listing = ', '.join(names) if names else 'none'
            raise LaunchError(f"unknown launch argument '{name}'{did_you_mean(name, names)}; this launch file "
                              f'declares: {listing}', str(Path(path).resolve()))
