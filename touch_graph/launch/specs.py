"""What a launch file resolves to: node specs, declared arguments, the launch plan.

Plain frozen data with no graph code, so ``--print-description`` and tests can inspect a
launch file without starting anything, and the runner (:mod:`touch_graph.launch.runner`)
turns each :class:`NodeSpec` into rclpy-style constructor arguments.
"""

from __future__ import annotations

import json
import re
import shlex
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from .substitutions import Location

__all__ = [
    'NAMESPACE_PATTERN', 'NODE_NAME_PATTERN', 'TOPIC_PATTERN', 'DeclaredArgument', 'LaunchPlan', 'NodeSpec',
    'ParamData', 'ParamFile', 'ParamValue', 'ProcessOptions', 'prefix_namespace', 'spec_from_json', 'spec_to_json',
]

_TOKEN = r'[A-Za-z_][A-Za-z0-9_]*'
#: rcl's rules: a node name is one token; a namespace is absolute tokens; a remap side is a topic name.
NODE_NAME_PATTERN = re.compile(rf'^{_TOKEN}$')
NAMESPACE_PATTERN = re.compile(rf'^(/|(/{_TOKEN})+)$')
TOPIC_PATTERN = re.compile(rf'^(~|~/{_TOKEN}(/{_TOKEN})*|/?{_TOKEN}(/{_TOKEN})*|__node|__ns)$')
ParamData = bool | int | float | str | tuple[bool, ...] | tuple[int, ...] | tuple[float, ...] | tuple[str, ...]


@dataclass(frozen=True)
class ParamValue:
    """A parameter given in the launch file: dotted ``name``, a ROS parameter value, and where it
    was written (``file:line``, for errors and for the check of parameters no node declares)."""

    name: str
    value: ParamData
    where: Any = field(default=None, compare=False)


@dataclass(frozen=True)
class ParamFile:
    """A ROS 2 parameter file (``param: [{from: ...}]``), passed to the node as ``--params-file``."""

    path: Path


@dataclass(frozen=True)
class ProcessOptions:
    """How a node that runs as a process of its own is run, with ros2 launch's attribute names and defaults.

    Attributes:
        respawn: restart the process when it exits (not when the launch stops it).
        respawn_delay: seconds before a restart (a process that keeps dying soon after starting
            waits longer each time: see :mod:`touch_graph.launch.processes`).
        respawn_max_retries: restarts at most this many times (-1: no limit).
        sigterm_timeout, sigkill_timeout: at shutdown, seconds after SIGINT before SIGTERM, and
            after SIGTERM before SIGKILL.
    """

    respawn: bool = False
    respawn_delay: float = 0.0
    respawn_max_retries: int = -1
    sigterm_timeout: float = 5.0
    sigkill_timeout: float = 5.0


@dataclass(frozen=True)
class NodeSpec:
    """A node to start, fully resolved.

    Attributes:
        pkg, exec: the package and executable (the ``social_touch.nodes`` entry point name).
        name: the node name, or ``None`` for the node's default name.
        namespace: absolute namespace (``'/bear'``), or ``None`` for the node's default (``/``).
        params: parameter values and files in file order (``ParamValue`` / ``ParamFile``).
        remaps: ``(from, to)`` rules in file order.
        file, line: where the ``node`` element is, for error messages.
        args: extra command-line arguments (``args``), before ``--ros-args``.
        ros_args: extra ROS arguments (``ros_args``), after the generated ones.
        output: ``screen``/``log``/``both``; in-process, every node logs through the runtime's logger.
        process: how to run the node as a process of its own, when the launch file gave a process
            attribute (``respawn``...); None: it joins the launcher's process unless ``--processes``.
    """

    pkg: str
    exec: str
    name: str | None
    namespace: str | None
    params: tuple[ParamValue | ParamFile, ...]
    remaps: tuple[tuple[str, str], ...]
    file: str
    line: int | None
    args: tuple[str, ...] = ()
    ros_args: tuple[str, ...] = ()
    output: str = 'screen'
    process: ProcessOptions | None = None

    @property
    def where(self) -> Location:
        return Location(self.file, self.line)

    @property
    def full_name(self) -> str | None:
        """``/ns/name`` when the name is given, else ``None`` (the node picks its default name)."""
        if self.name is None:
            return None
        return f'/{self.name}' if self.namespace in (None, '/') else f'{self.namespace}/{self.name}'

    def parameter_values(self) -> list[ParamValue]:
        return [p for p in self.params if isinstance(p, ParamValue)]

    def parameter_files(self) -> list[Path]:
        return [p.path for p in self.params if isinstance(p, ParamFile)]

    def cli_args(self) -> list[str]:
        """rclpy ``args``: ``[args..., '--ros-args', '-r', '__node:=NAME', '-r', '__ns:=/NS', '-r', 'a:=b',
        '--params-file', F, ros_args...]`` (the ``--ros-args`` part only when something goes in it)."""
        ros: list[str] = []
        if self.name is not None:
            ros += ['-r', f'__node:={self.name}']
        if self.namespace is not None:
            ros += ['-r', f'__ns:={self.namespace}']
        for source, target in self.remaps:
            ros += ['-r', f'{source}:={target}']
        for path in self.parameter_files():
            ros += ['--params-file', str(path)]
        ros += self.ros_args
        return [*self.args, '--ros-args', *ros] if ros else list(self.args)

    def describe(self) -> str:
        """A few lines for ``--print-description``."""
        who = self.full_name or f'{self.namespace or ""}/<default name>'
        lines = [f'{who}  ({self.pkg}/{self.exec})  [{self.where}]']
        for param in self.params:
            if isinstance(param, ParamFile):
                lines.append(f'    params file: {param.path}')
            else:
                lines.append(f'    param {param.name} = {param.value!r}')
        lines += [f'    remap {source} -> {target}' for source, target in self.remaps]
        if self.args:
            lines.append(f'    args: {shlex.join(self.args)}')
        if self.ros_args:
            lines.append(f'    ros_args: {shlex.join(self.ros_args)}')
        if self.process is not None:
            p = self.process
            respawn = f'respawn after {p.respawn_delay:g} s' + (f', at most {p.respawn_max_retries} times'
                                                                if p.respawn_max_retries >= 0 else '')
            lines.append(f'    own process{", " + respawn if p.respawn else ""}')
        return '\n'.join(lines)


@dataclass(frozen=True)
class DeclaredArgument:
    """A launch argument as declared by ``arg`` (``default`` is its text, or ``None`` if required)."""

    name: str
    description: str
    default: str | None
    choices: tuple[str, ...] | None
    where: Location


@dataclass
class LaunchPlan:
    """What a launch file resolves to: nodes to start and the arguments it declared.

    Attributes:
        file: the launch file.
        nodes: node specs in start order.
        arguments: declared arguments (first declaration of each name), in file order.
        values: the value every launch configuration had when the file ended (top scope).
    """

    file: Path
    nodes: list[NodeSpec] = field(default_factory=list)
    arguments: list[DeclaredArgument] = field(default_factory=list)
    values: dict[str, str] = field(default_factory=dict)

    def describe(self) -> str:
        out = [f'launch file: {self.file}']
        if self.arguments:
            out.append('arguments:')
            out += [f'  {a.name} = {self.values.get(a.name, "<unset>")!r}' for a in self.arguments]
        out.append(f'nodes ({len(self.nodes)}):')
        out += ['  ' + spec.describe().replace('\n', '\n  ') for spec in self.nodes]
        return '\n'.join(out)


def prefix_namespace(base: str | None, namespace: str | None) -> str | None:
    """``namespace`` under ``base`` unless it is absolute, made absolute (launch_ros's rule).

    >>> prefix_namespace('/robot', 'bear'), prefix_namespace('/robot', '/skin'), prefix_namespace(None, 'a/')
    ('/robot/bear', '/skin', '/a')
    >>> prefix_namespace('/robot', None), prefix_namespace(None, None), prefix_namespace('/', 'x')
    ('/robot', None, '/x')
    """
    if base is None and namespace is None:
        return None
    if namespace is None:
        combined = base or '/'
    elif not base or namespace.startswith('/'):
        combined = namespace
    else:
        combined = base.rstrip('/') + '/' + namespace
    if combined != '/':
        combined = combined.rstrip('/') or '/'
    return combined if combined.startswith('/') else '/' + combined


def spec_to_json(spec: NodeSpec) -> str:
    """A node spec as JSON, for the process that runs it (:func:`spec_from_json` reads it back)."""
    params = [{'from': str(p.path)} if isinstance(p, ParamFile) else
              {'name': p.name, 'value': list(p.value) if isinstance(p.value, tuple) else p.value,
               'where': [p.where.path, p.where.line] if p.where is not None else None} for p in spec.params]
    data = asdict(replace(spec, params=()))
    data['params'] = params
    return json.dumps(data)


def spec_from_json(text: str) -> NodeSpec:
    """The node spec :func:`spec_to_json` wrote."""
    data = json.loads(text)
    params: list[ParamValue | ParamFile] = []
    for p in data.pop('params'):
        if 'from' in p:
            params.append(ParamFile(Path(p['from'])))
        else:
            value = tuple(p['value']) if isinstance(p['value'], list) else p['value']
            params.append(ParamValue(p['name'], value, Location(*p['where']) if p['where'] else None))
    process = data.pop('process')
    return NodeSpec(**{**data, 'params': tuple(params), 'remaps': tuple(tuple(r) for r in data['remaps']),
                       'args': tuple(data['args']), 'ros_args': tuple(data['ros_args']),
                       'process': ProcessOptions(**process) if process is not None else None})
