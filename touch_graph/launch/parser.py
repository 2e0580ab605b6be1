"""Read a ROS 2 YAML launch file (ros2/launch's ``launch_yaml`` + ``launch_ros`` frontend) into a checked parse tree.

Supported elements and attributes are :data:`ELEMENTS`; anything else, including ROS 2
elements the launcher does not run (``executable``, ``timer``...), is a
:class:`~touch_graph.errors.LaunchError` naming file, line, what was found and what is
supported. Every string is parsed as a substitution template here, so a typo in ``$(...)``
is reported before anything runs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import ConfigError, LaunchError
from ..yamlconf import YamlDict, YamlList, did_you_mean, load_yaml
from .substitutions import Location, Template, TemplateSyntaxError, literal_text, parse_template

__all__ = [
    'ELEMENTS', 'PARAM_TYPES', 'PROCESS_ATTRIBUTES', 'Action', 'ArgAction', 'Condition', 'GroupAction',
    'IncludeAction', 'LaunchFile', 'LetAction', 'NodeAction', 'ParamDecl', 'PushNamespaceAction', 'RemapDecl', 'Str',
    'parse_launch_file',
]

_CONDITION = ('if', 'unless')
#: element -> supported attributes (``if``/``unless`` everywhere). ``push-ros-namespace`` is the
#: spelling of ROS 2 Humble and older, ``push_ros_namespace`` of newer distributions.
ELEMENTS: dict[str, tuple[str, ...]] = {
    'arg': ('name', 'default', 'description', 'choice', 'choices', *_CONDITION),
    'let': ('name', 'value', *_CONDITION),
    'include': ('file', 'arg', 'let', *_CONDITION),
    'group': ('scoped', 'forwarding', 'keep', 'children', *_CONDITION),
    'push_ros_namespace': ('namespace', *_CONDITION),
    'push-ros-namespace': ('namespace', *_CONDITION),
    'node': ('pkg', 'exec', 'name', 'namespace', 'param', 'remap', 'args', 'ros_args', 'output',
             'respawn', 'respawn_delay', 'respawn_max_retries', 'sigterm_timeout', 'sigkill_timeout', *_CONDITION),
}
#: Attributes of a ``node`` that make it a process of its own (ros2 launch's process attributes).
PROCESS_ATTRIBUTES = ('respawn', 'respawn_delay', 'respawn_max_retries', 'sigterm_timeout', 'sigkill_timeout')
#: ROS 2 launch elements and node attributes that exist but that one in-process graph cannot honour.
_ROS_ONLY_ELEMENTS = ('executable', 'timer', 'set_env', 'set-env', 'unset_env', 'unset-env', 'append_env',
                      'set_parameter', 'set-parameter', 'set_parameters_from_file', 'set_remap', 'set-remap',
                      'log', 'for', 'node_container', 'composable_node_container', 'load_composable_node',
                      'lifecycle_node', 'set_use_sim_time', 'set_ros_log_dir', 'shutdown')
_ROS_ONLY_NODE_ATTRIBUTES = ('exec_name', 'node-name', 'cwd', 'env', 'shell', 'launch-prefix', 'launch_prefix',
                             'emulate_tty', 'additional_env', 'on_exit', 'to_cloud')
#: ``param`` ``type`` identifiers of launch_ros (launch/frontend/type_utils.py).
PARAM_TYPES = ('str', 'bool', 'int', 'float', 'list_of_str', 'list_of_bool', 'list_of_int', 'list_of_float', 'yaml')
_OUTPUTS = ('screen', 'log', 'both')


@dataclass(frozen=True)
class Str:
    """A string parameter value, kept as a template until the launch file runs."""

    template: Template


ParamScalar = bool | int | float | Str


@dataclass(frozen=True)
class Condition:
    """``if`` / ``unless`` templates of an element (both may be absent)."""

    if_: Template | None = None
    unless: Template | None = None


@dataclass(frozen=True)
class ArgAction:
    """``arg``: declare a launch argument (ROS ``DeclareLaunchArgument``)."""

    name: str
    default: Template | None
    description: str
    choices: tuple[str, ...] | None
    where: Location
    condition: Condition = Condition()


@dataclass(frozen=True)
class LetAction:
    """``let``: set a launch configuration (ROS ``SetLaunchConfiguration``)."""

    name: Template
    value: Template
    where: Location
    condition: Condition = Condition()


@dataclass(frozen=True)
class IncludeAction:
    """``include``: read another YAML launch file with ``(name, value, where)`` arguments."""

    file: Template
    arguments: tuple[tuple[Template, Template, Location], ...]
    where: Location
    condition: Condition = Condition()


@dataclass(frozen=True)
class GroupAction:
    """``group``: children, optionally scoped (configurations and namespace pop at its end)."""

    children: tuple[Action, ...]
    scoped: bool
    forwarding: bool
    keep: tuple[tuple[Template, Template, Location], ...]
    where: Location
    condition: Condition = Condition()


@dataclass(frozen=True)
class PushNamespaceAction:
    """``push_ros_namespace``: prefix the namespace of the nodes that follow (in this scope)."""

    namespace: Template
    where: Location
    condition: Condition = Condition()


@dataclass(frozen=True)
class ParamDecl:
    """One ``param`` item: ``name`` + ``value`` (optionally ``type``), ``name`` + nested ``param``, or ``from``."""

    where: Location
    name: Template | None = None
    value: ParamScalar | tuple[ParamScalar, ...] | None = None
    type: str | None = None
    children: tuple[ParamDecl, ...] = ()
    from_file: Template | None = None


@dataclass(frozen=True)
class RemapDecl:
    """One ``remap`` item: ``from`` -> ``to``."""

    source: Template
    target: Template
    where: Location


@dataclass(frozen=True)
class NodeAction:
    """``node``: a node of package ``pkg`` and executable ``exec`` to start."""

    pkg: Template
    exec: Template
    name: Template | None
    namespace: Template | None
    params: tuple[ParamDecl, ...]
    remaps: tuple[RemapDecl, ...]
    args: Template | None
    ros_args: Template | None
    output: str
    where: Location
    condition: Condition = Condition()
    #: process attributes as written: a YAML bool or number, or a template (``$(var respawn)``)
    process: tuple[tuple[str, Any, Location], ...] = ()


Action = ArgAction | LetAction | IncludeAction | GroupAction | PushNamespaceAction | NodeAction


@dataclass(frozen=True)
class LaunchFile:
    """A parsed launch file: its absolute path and its top-level actions in order."""

    path: Path
    actions: tuple[Action, ...]


# ------------------------------------------------------------------------------------ helpers

def _where(container: Any, key: Any, path: str) -> Location:
    line = container.line_of(key) if isinstance(container, (YamlDict, YamlList)) else None
    return Location(path, line)


def _template(value: Any, what: str, where: Location) -> Template:
    if not isinstance(value, str):
        hint = f" (quote it: '{value}')" if isinstance(value, (bool, int, float)) else ''
        raise where.error(f'{what} must be a string{hint}; got {type(value).__name__} {value!r}')
    try:
        return parse_template(value)
    except TemplateSyntaxError as err:
        raise where.error(f'{what}: {err}') from err


def _attr(attrs: YamlDict, key: str, element: str, path: str, required: bool = False) -> Template | None:
    if key not in attrs:
        if required:
            raise LaunchError(f"'{element}' needs attribute '{key}'", path, attrs.line)
        return None
    return _template(attrs[key], f"'{key}' of '{element}'", _where(attrs, key, path))


def _literal(attrs: YamlDict, key: str, element: str, path: str) -> str | None:
    template = _attr(attrs, key, element, path)
    if template is None:
        return None
    text = literal_text(template)
    if text is None:
        raise _where(attrs, key, path).error(f"'{key}' of '{element}' cannot use substitutions (ros2 launch needs "
                                             'it before anything runs, e.g. for --show-args)')
    return text


def _bool(attrs: YamlDict, key: str, element: str, path: str, default: bool) -> bool:
    if key not in attrs:
        return default
    value = attrs[key]
    if not isinstance(value, bool):
        raise _where(attrs, key, path).error(f"'{key}' of '{element}' must be true or false; got {value!r}")
    return value


def _check_attributes(attrs: YamlDict, element: str, path: str, allowed: tuple[str, ...]) -> None:
    for key in attrs:
        if key in allowed:
            continue
        where = _where(attrs, key, path)
        if element == 'node' and key in _ROS_ONLY_NODE_ATTRIBUTES:
            raise where.error(f"attribute '{key}' of 'node' is not supported: a node runs from its class (in the "
                              f'launcher or in a process of its own), not as a program; remove it. Supported: '
                              f'{", ".join(allowed)}')
        raise where.error(f"unknown attribute '{key}' of '{element}'{did_you_mean(key, allowed)}; "
                          f'supported: {", ".join(allowed)}')


def _entity_list(value: Any, what: str, where: Location) -> YamlList:
    if not isinstance(value, list) or not all(isinstance(item, dict) for item in value):
        raise where.error(f'{what} must be a list of mappings (- {{...}}); got {value!r}')
    return value  # type: ignore[return-value]


def _condition(attrs: YamlDict, element: str, path: str) -> Condition:
    return Condition(_attr(attrs, 'if', element, path), _attr(attrs, 'unless', element, path))


def _name_values(items: YamlList, what: str, path: str) -> tuple[tuple[Template, Template, Location], ...]:
    out = []
    for item in items:
        _check_attributes(item, what, path, ('name', 'value'))
        name = _attr(item, 'name', what, path, required=True)
        value = _attr(item, 'value', what, path, required=True)
        out.append((name, value, Location(path, item.line)))
    return tuple(out)  # type: ignore[arg-type]


# ----------------------------------------------------------------------------------- elements

def _parse_arg(attrs: YamlDict, path: str, where: Location) -> ArgAction:
    name = _literal(attrs, 'name', 'arg', path)
    if name is None:
        raise where.error("'arg' needs attribute 'name'")
    choices: tuple[str, ...] | None = None
    if 'choice' in attrs and 'choices' in attrs:
        raise _where(attrs, 'choices', path).error("'arg' has both 'choice' and 'choices'; keep one "
                                                   '(choices: [a, b] or choice: [{value: a}, {value: b}])')
    if 'choice' in attrs:
        items = _entity_list(attrs['choice'], "'choice' of 'arg'", _where(attrs, 'choice', path))
        values = []
        for item in items:
            _check_attributes(item, 'choice', path, ('value',))
            value = _literal(item, 'value', 'choice', path)
            if value is None:
                raise LaunchError("'choice' needs attribute 'value'", path, item.line)
            values.append(value)
        choices = tuple(values)
    elif 'choices' in attrs:
        raw = attrs['choices']
        if not isinstance(raw, list) or not raw or not all(isinstance(c, str) for c in raw):
            raise _where(attrs, 'choices', path).error(
                f"'choices' of 'arg' must be a non-empty list of strings (quote numbers: ['1', '2']); got {raw!r}")
        choices = tuple(raw)
    if choices is not None and not choices:
        raise _where(attrs, 'choice', path).error("'choice' of 'arg' is empty; give at least one value or remove it")
    default = _attr(attrs, 'default', 'arg', path)
    if choices is not None and default is not None:
        text = literal_text(default)
        if text is not None and text not in choices:
            raise _where(attrs, 'default', path).error(
                f"default {text!r} of arg '{name}' is not one of its choices: {', '.join(choices)}")
    description = _literal(attrs, 'description', 'arg', path) or ''
    return ArgAction(name, default, description, choices, where, _condition(attrs, 'arg', path))


def _parse_param(item: YamlDict, path: str) -> ParamDecl:
    where = Location(path, item.line)
    _check_attributes(item, 'param', path, ('name', 'value', 'type', 'param', 'from'))
    if 'from' in item:
        if len(item) > 1:
            extra = ', '.join(k for k in item if k != 'from')
            raise where.error(f"a 'param' with 'from' (a parameter file) takes no other attributes; got {extra}")
        return ParamDecl(where, from_file=_attr(item, 'from', 'param', path))
    name = _attr(item, 'name', 'param', path)
    if name is None:
        raise where.error("'param' needs 'name' (with 'value' or nested 'param') or 'from' (a parameter file)")
    if ('value' in item) == ('param' in item):
        raise where.error("'param' needs exactly one of 'value' or nested 'param' (a list of name/value items)")
    if 'param' in item:
        if 'type' in item:
            raise _where(item, 'type', path).error("'type' goes with 'value', not with nested 'param'")
        children = _entity_list(item['param'], "nested 'param'", _where(item, 'param', path))
        return ParamDecl(where, name=name, children=tuple(_parse_param(child, path) for child in children))
    type_ = None
    if 'type' in item:
        type_ = item['type']
        if type_ not in PARAM_TYPES:
            raise _where(item, 'type', path).error(
                f"unknown param type {type_!r}{did_you_mean(str(type_), PARAM_TYPES)}; "
                f"one of: {', '.join(PARAM_TYPES)}")
    return ParamDecl(where, name=name, value=_param_value(item['value'], _where(item, 'value', path)), type=type_)


def _param_scalar(value: Any, where: Location) -> ParamScalar:
    if isinstance(value, (bool, int, float)):
        return value
    if isinstance(value, str):
        return Str(_template(value, "'value' of 'param'", where))
    if isinstance(value, dict):
        raise where.error("a 'param' value cannot be a mapping; nest parameters as in ros2 launch: "
                          "'- {name: group, param: [{name: x, value: 1}]}' gives 'group.x'")
    raise where.error(f"a 'param' value must be a bool, number, string or list of those; got {value!r}")


def _param_value(value: Any, where: Location) -> ParamScalar | tuple[ParamScalar, ...]:
    if isinstance(value, list):
        return tuple(_param_scalar(item, where) for item in value)
    if value is None:
        raise where.error("'value' of 'param' is empty; write '' for an empty string")
    return _param_scalar(value, where)


def _parse_node(attrs: YamlDict, path: str, where: Location) -> NodeAction:
    for key in ('pkg', 'exec'):
        if key not in attrs:
            raise where.error(f"'node' needs '{key}' (pkg: the package, exec: its executable, e.g. "
                              "pkg: social_touch, exec: bear_driver)")
    output = _literal(attrs, 'output', 'node', path) or 'screen'
    if output not in _OUTPUTS:
        raise _where(attrs, 'output', path).error(f"'output' of 'node' must be one of {', '.join(_OUTPUTS)}; "
                                                  f'got {output!r}')
    params = ()
    if 'param' in attrs:
        items = _entity_list(attrs['param'], "'param' of 'node'", _where(attrs, 'param', path))
        params = tuple(_parse_param(item, path) for item in items)
    remaps = []
    if 'remap' in attrs:
        for item in _entity_list(attrs['remap'], "'remap' of 'node'", _where(attrs, 'remap', path)):
            _check_attributes(item, 'remap', path, ('from', 'to'))
            remaps.append(RemapDecl(_attr(item, 'from', 'remap', path, required=True),  # type: ignore[arg-type]
                                    _attr(item, 'to', 'remap', path, required=True),  # type: ignore[arg-type]
                                    Location(path, item.line)))
    process = []
    for key in PROCESS_ATTRIBUTES:
        if key in attrs:
            value = attrs[key]
            here = _where(attrs, key, path)
            if isinstance(value, str):
                value = _template(value, f"'{key}' of 'node'", here)
            elif not isinstance(value, (bool, int, float)):
                raise here.error(f"'{key}' of 'node' must be a {'bool' if key == 'respawn' else 'number'}; "
                                 f'got {value!r}')
            process.append((key, value, here))
    return NodeAction(
        pkg=_attr(attrs, 'pkg', 'node', path, required=True), exec=_attr(attrs, 'exec', 'node', path, required=True),
        name=_attr(attrs, 'name', 'node', path), namespace=_attr(attrs, 'namespace', 'node', path),
        params=params, remaps=tuple(remaps), args=_attr(attrs, 'args', 'node', path),
        ros_args=_attr(attrs, 'ros_args', 'node', path), output=output, where=where,
        condition=_condition(attrs, 'node', path), process=tuple(process))  # type: ignore[arg-type]


def _parse_group(element: Any, path: str, where: Location) -> GroupAction:
    if isinstance(element, list):  # ``- group: [children...]``
        return GroupAction(_parse_actions(element, path, 'group'), True, True, (), where)
    attrs: YamlDict = element
    if 'children' not in attrs:
        raise where.error("'group' needs 'children' (a list of elements), or write the list directly: "
                          "'- group: [...]'")
    keep = ()
    if 'keep' in attrs:
        keep = _name_values(_entity_list(attrs['keep'], "'keep' of 'group'", _where(attrs, 'keep', path)),
                            'keep', path)
    return GroupAction(
        children=_parse_actions(attrs['children'], path, 'group', _where(attrs, 'children', path)),
        scoped=_bool(attrs, 'scoped', 'group', path, True), forwarding=_bool(attrs, 'forwarding', 'group', path, True),
        keep=keep, where=where, condition=_condition(attrs, 'group', path))


def _parse_include(element: Any, path: str, where: Location) -> IncludeAction:
    if isinstance(element, str):  # ``- include: path/to/file.launch.yaml``
        return IncludeAction(_template(element, "'include'", where), (), where)
    attrs: YamlDict = element
    arguments: list[tuple[Template, Template, Location]] = []
    for key in ('arg', 'let'):
        if key in attrs:
            items = _entity_list(attrs[key], f"'{key}' of 'include'", _where(attrs, key, path))
            arguments.extend(_name_values(items, f'{key} of include', path))
    return IncludeAction(_attr(attrs, 'file', 'include', path, required=True),  # type: ignore[arg-type]
                         tuple(arguments), where, _condition(attrs, 'include', path))


def _parse_action(item: Any, path: str, where: Location) -> Action:
    if not isinstance(item, dict) or len(item) != 1:
        keys = ', '.join(repr(k) for k in item) if isinstance(item, dict) else repr(item)
        raise where.error(f'each launch item is a mapping with one key, the element (e.g. "- node: {{...}}"); got '
                          f'{keys}. If these are attributes, indent them under the element')
    kind, element = next(iter(item.items()))
    if kind not in ELEMENTS:
        if kind in _ROS_ONLY_ELEMENTS:
            raise where.error(f"ROS 2 launch element '{kind}' is not supported by the in-process launcher; "
                              f'supported: {", ".join(ELEMENTS)}')
        raise where.error(f"unknown element '{kind}'{did_you_mean(str(kind), ELEMENTS)}; "
                          f'supported: {", ".join(ELEMENTS)}')
    if kind == 'group':
        if not isinstance(element, (dict, list)):
            raise where.error(f"'group' must be a mapping with 'children' or a list of elements; got {element!r}")
        return _parse_group(element, path, where)
    if kind == 'include' and isinstance(element, str):
        return _parse_include(element, path, where)
    if not isinstance(element, dict):
        raise where.error(f"'{kind}' must be a mapping of attributes ({', '.join(ELEMENTS[kind])}); got {element!r}")
    _check_attributes(element, kind, path, ELEMENTS[kind])
    if kind == 'arg':
        return _parse_arg(element, path, where)
    if kind == 'let':
        return LetAction(_attr(element, 'name', 'let', path, required=True),  # type: ignore[arg-type]
                         _attr(element, 'value', 'let', path, required=True),  # type: ignore[arg-type]
                         where, _condition(element, 'let', path))
    if kind == 'include':
        return _parse_include(element, path, where)
    if kind == 'node':
        return _parse_node(element, path, where)
    return PushNamespaceAction(_attr(element, 'namespace', kind, path, required=True),  # type: ignore[arg-type]
                               where, _condition(element, kind, path))


def _parse_actions(items: Any, path: str, parent: str, where: Location | None = None) -> tuple[Action, ...]:
    if items is None:
        return ()
    if not isinstance(items, list):
        line = getattr(items, 'line', None)
        where = Location(path, line) if line is not None else where or Location(path)
        kind = 'a mapping' if isinstance(items, dict) else f'{type(items).__name__} {items!r}'
        raise where.error(f"the elements of '{parent}' must be a list ('- node: ...'); got {kind}")
    return tuple(_parse_action(item, path, _where(items, i, path)) for i, item in enumerate(items))


def parse_launch_file(path: str | Path) -> LaunchFile:
    """Parse a YAML launch file (``launch: [elements...]``).

    Raises:
        LaunchError: for a missing file, YAML syntax, an unknown element or attribute, a bad
            substitution, a missing required attribute, naming the file and line.
    """
    path = Path(path).resolve()
    if path.suffix not in ('.yaml', '.yml'):
        raise LaunchError('only YAML launch files (*.launch.yaml) can run in-process; Python and XML launch '
                          'files need ros2 launch', str(path))
    try:
        root = load_yaml(path)
    except ConfigError as err:  # missing file or YAML syntax: the same location, as a launch error
        raise LaunchError(err.bare_message, err.path, err.line) from err
    if not isinstance(root, dict) or list(root) != ['launch']:
        found = ', '.join(repr(k) for k in root) if isinstance(root, dict) else \
            ('an empty file' if root is None else f'a {type(root).__name__}')
        raise LaunchError(f"a launch file is a mapping with the single key 'launch' (launch: [...]); got {found}",
                          str(path), getattr(root, 'line', 1))
    return LaunchFile(path, _parse_actions(root['launch'], str(path), 'launch', _where(root, 'launch', str(path))))
