"""``social-touch param list | get | set | describe | dump | load | delete``, as ``ros2 param`` prints them.

Every call goes through the node's parameter services, so it works on any ROS 2 node of the
domain too. A value given on the command line is typed by rcl's rules (``25`` an integer,
``25.0`` a double, ``[1, 2]`` an integer array, ``true`` a bool, anything else a string).

Imports inside functions: the DDS tool, the runtime's parameters and the service types load in the
verb that calls a service, so ``social-touch param --help`` and argument errors stay quick.
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from collections.abc import Iterator
from typing import Any

import yaml

from ..daemon.client import graph_source
from ..errors import ConfigError, GraphError, ParameterError
from .daemon import add_no_daemon
from .options import seconds

__all__ = ['add_arguments', 'run']

_TYPE_WORDS = {0: 'not set', 1: 'boolean', 2: 'integer', 3: 'double', 4: 'string', 5: 'byte array',
               6: 'boolean array', 7: 'integer array', 8: 'double array', 9: 'string array'}
#: ``ros2 param get`` labels, by ParameterType.
_LABELS = {1: 'Boolean value is:', 2: 'Integer value is:', 3: 'Double value is:', 4: 'String value is:',
           5: 'Byte values are:', 6: 'Boolean values are:', 7: 'Integer values are:', 8: 'Double values are:',
           9: 'String values are:'}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest='action', required=True, metavar='ACTION')

    def verb(name: str, text: str, node_optional: bool = False) -> argparse.ArgumentParser:
        p = sub.add_parser(name, help=text, description=text[0].upper() + text[1:] + '.')
        p.add_argument('node_name', nargs='?' if node_optional else None, help='the node, e.g. /bear/bear_gestures')
        p.add_argument('--include-hidden-nodes', action='store_true', help='consider hidden nodes as well')
        p.add_argument('--timeout', type=seconds, default=5.0, metavar='S',
                       help='wait at most S seconds for the parameter services, and again for each answer (default 5)')
        add_no_daemon(p)
        return p

    p = verb('list', 'list the parameters of a node (of every node when none is named)', node_optional=True)
    p.add_argument('--param-prefixes', nargs='+', default=[], metavar='PREFIX',
                   help='only parameters with these prefixes')
    p.add_argument('--param-type', action='store_true', help='also print each parameter type')
    p = verb('get', "print a parameter's value")
    p.add_argument('parameter_name', help='e.g. threshold')
    p.add_argument('--hide-type', action='store_true', help='print the value only')
    p = verb('set', 'set parameters; the node decides whether it can apply each at once')
    p.add_argument('params_and_values', nargs='+', metavar='name value',
                   help='one or more pairs: name value [name value ...]')
    p.add_argument('--atomic', action='store_true', help='set all of them or none (set_parameters_atomically)')
    p = verb('describe', 'describe parameters: type, description, constraints')
    p.add_argument('parameter_names', nargs='+', metavar='name')
    p = verb('dump', 'print every parameter of a node as a ROS 2 parameter file (YAML)')
    p = verb('load', 'set the parameters of a ROS 2 parameter file on a running node')
    p.add_argument('parameter_file', help='a parameter YAML file (node_name: {ros__parameters: {...}})')
    p.add_argument('--use-wildcard', action='store_true', help="also load the file's '/**' parameters")
    p = verb('delete', 'undeclare a parameter (only a dynamically typed one can be)')
    p.add_argument('parameter_name')


def run(args: argparse.Namespace) -> int:
    with graph_source(f'param_{args.action}', args.no_daemon) as graph, _caller(graph, args.action) as tool:
        return _VERBS[args.action](_Params(graph, tool, args), args)


@contextlib.contextmanager
def _caller(graph: Any, action: str) -> Iterator[Any]:
    """The participant that calls the parameter services: the graph's own without the daemon; with it, one that
    skips the discovery wait (the daemon knows the graph; each call waits for its service to match)."""
    from ..dds.tool import GraphTool  # lazy: see the module doc
    if isinstance(graph, GraphTool):
        yield graph
        return
    graph.require_graph()  # nobody there: say so before joining the domain
    with GraphTool(f'param_{action}', discovery_timeout_s=0.0) as tool:
        yield tool


class _Params:
    """Calls to a node's parameter services through a GraphTool (``tool``), the nodes from ``graph`` (the same tool,
    or the graph daemon's graph)."""

    def __init__(self, graph: Any, tool: Any, args: argparse.Namespace) -> None:
        self.graph = graph
        self.tool = tool
        self.timeout = args.timeout
        self.include_hidden = args.include_hidden_nodes

    def node(self, name: str) -> str:
        # a Fast DDS node's ros_discovery_info can come seconds after its endpoints: wait as for a service
        return self.graph.require_node(name, self.include_hidden, wait_s=self.timeout)

    def call(self, node: str, service: str, **fields: Any) -> Any:
        """The response of ``node``'s parameter service ``service`` (e.g. ``get_parameters``) to ``fields``."""
        from ..runtime.parameter_service import PARAMETER_SERVICES  # lazy: see the module doc
        from ..srv_types import get_service  # lazy: see the module doc
        srv_type = get_service(PARAMETER_SERVICES[service])
        return self.tool.call(srv_type, f'{node}/{service}', srv_type.Request(**fields), self.timeout)

    def names(self, node: str, prefixes: list[str]) -> list[str]:
        """Every parameter name of ``node`` (under ``prefixes``), sorted."""
        return sorted(self.call(node, 'list_parameters', prefixes=prefixes, depth=0).result.names)


def _list(params: _Params, args: argparse.Namespace) -> int:
    view = params.graph.require_graph()
    if args.node_name:
        nodes = [params.node(args.node_name)]
    else:  # every node that serves parameters (ros2 param list does the same)
        # a Fast DDS participant's endpoints come after the participant, and its node (ros_discovery_info)
        # seconds after its services: wait (at most 2 s) for some parameter service, then for their nodes
        def serving(v: Any) -> set[str]:
            return {name.rsplit('/', 1)[0] for name in v.services if name.endswith('/list_parameters')}
        params.graph.wait_until(lambda v: bool(serving(v)), min(params.timeout, 2.0))
        servers = serving(params.graph.graph())
        params.graph.wait_until(lambda v: servers <= {n.name for n in v.visible_nodes(True)}, params.timeout)
        view = params.graph.graph()
        nodes = sorted(n.name for n in view.visible_nodes(args.include_hidden_nodes)
                       if f'{n.name}/list_parameters' in n.services)
    for node in nodes:
        names = params.names(node, args.param_prefixes)
        if not args.node_name:
            print(f'{node}:')
        types = {}
        if args.param_type and names:
            described = params.call(node, 'describe_parameters', names=names).descriptors
            types = {d.name: _TYPE_WORDS.get(d.type, str(d.type)) for d in described}
        for name in names:
            print(f'  {name} (type: {types.get(name, "not set")})' if args.param_type else f'  {name}')
    return 0


def _get(params: _Params, args: argparse.Namespace) -> int:
    from ..runtime.parameters import value_of  # lazy: see the module doc
    node = params.node(args.node_name)
    values = params.call(node, 'get_parameters', names=[args.parameter_name]).values
    if not values or values[0].type == 0:
        print('Parameter not set', file=sys.stderr)
        return 1
    value = value_of(values[0])
    if values[0].type not in _LABELS:
        print(f"Unknown parameter type '{values[0].type}'", file=sys.stderr)
        return 1
    print(value if args.hide_type else f'{_LABELS[values[0].type]} {value}')
    return 0


def _set(params: _Params, args: argparse.Namespace) -> int:
    from ..runtime.param_yaml import parse_parameter_value  # lazy: see the module doc
    from ..runtime.parameters import Parameter, parameter_msg  # lazy: see the module doc
    pairs = args.params_and_values
    if len(pairs) % 2:
        raise GraphError(f'parameters are name value pairs (name value [name value ...]); got {len(pairs)} '
                         'argument(s)')
    node = params.node(args.node_name)
    parameters = []
    for name, text in zip(pairs[::2], pairs[1::2], strict=True):
        try:
            parameters.append(Parameter(name, value=parse_parameter_value(text, f'value of {name}')))
        except (ConfigError, ParameterError) as err:
            raise GraphError(f"cannot use {text!r} as the value of '{name}': {err}") from err
    messages = [parameter_msg(p) for p in parameters]
    if args.atomic:
        result = params.call(node, 'set_parameters_atomically', parameters=messages).result
        return _report('Set parameters atomically successful', 'Setting parameters atomically failed', result)
    results = params.call(node, 'set_parameters', parameters=messages).results
    failed = 0
    for parameter, result in zip(parameters, results, strict=False):
        prefix = f'{parameter.name}: ' if len(parameters) > 1 else ''
        failed += _report(f'{prefix}Set parameter successful', f'{prefix}Setting parameter failed', result)
    return 1 if failed or len(results) != len(parameters) else 0


def _report(ok: str, failed: str, result: Any) -> int:
    """Print a SetParametersResult as ros2 param does; 1 if it failed."""
    text = (ok if result.successful else failed) + (f': {result.reason}' if result.reason else '')
    print(text, file=sys.stdout if result.successful else sys.stderr)
    return 0 if result.successful else 1


def _describe(params: _Params, args: argparse.Namespace) -> int:
    node = params.node(args.node_name)
    descriptors = params.call(node, 'describe_parameters', names=args.parameter_names).descriptors
    if not descriptors:
        print(f'Parameter not set: one of {", ".join(args.parameter_names)} is not declared by {node}',
              file=sys.stderr)
        return 1
    for d in descriptors:
        print('Parameter name:', d.name)
        print('  Type:', _TYPE_WORDS.get(d.type, str(d.type)))
        if d.description:
            print('  Description:', d.description)
        print('  Constraints:')
        if d.read_only:
            print('    Read only: true')
        ranges = [*d.floating_point_range, *d.integer_range]
        if ranges:
            print('    Min value:', ranges[0].from_value)
            print('    Max value:', ranges[0].to_value)
            if ranges[0].step:
                print('    Step:', ranges[0].step)
        if d.additional_constraints:
            print('    Additional constraints:', d.additional_constraints)
    return 0


def _dump(params: _Params, args: argparse.Namespace) -> int:
    from ..runtime.parameters import value_of  # lazy: see the module doc
    node = params.node(args.node_name)
    names = params.names(node, [])
    values = params.call(node, 'get_parameters', names=names).values if names else []
    tree: dict[str, Any] = {}
    for name, value in zip(names, values, strict=False):
        here = tree
        *path, leaf = name.split('.')
        for part in path:
            here = here.setdefault(part, {})
        here[leaf] = value_of(value)
    print(yaml.dump({node: {'ros__parameters': tree}}, default_flow_style=False))
    return 0


def _load(params: _Params, args: argparse.Namespace) -> int:
    from ..runtime.parameters import Parameter, load_parameter_file, parameter_msg  # lazy: see the module doc
    node = params.node(args.node_name)
    overrides = load_parameter_file(args.parameter_file)
    chosen: dict[str, Any] = {}
    keys = (['/**'] if args.use_wildcard else []) + [node, node.lstrip('/')]
    for key in keys:
        for name, value in overrides.nodes.get(key, {}).items():
            chosen[name] = value.value
    if not chosen:
        hint = '' if args.use_wildcard else "; --use-wildcard adds the file's /** parameters"
        raise GraphError(f"{args.parameter_file} has no parameters for '{node}' (its node keys: "
                         f"{', '.join(overrides.nodes) or 'none'}){hint}")
    parameters = [Parameter(name, value=value) for name, value in chosen.items()]
    results = params.call(node, 'set_parameters', parameters=[parameter_msg(p) for p in parameters]).results
    failed = 0
    for parameter, result in zip(parameters, results, strict=False):
        failed += _report(f'Set parameter {parameter.name} successful', f'Set parameter {parameter.name} failed',
                          result)
    return 1 if failed else 0


def _delete(params: _Params, args: argparse.Namespace) -> int:
    from ..runtime.parameters import Parameter, ParameterType, parameter_msg  # lazy: see the module doc
    node = params.node(args.node_name)
    message = parameter_msg(Parameter(args.parameter_name, ParameterType.NOT_SET, None))
    [result] = params.call(node, 'set_parameters', parameters=[message]).results
    return _report('Deleted parameter successfully', 'Deleting parameter failed', result)


_VERBS = {'list': _list, 'get': _get, 'set': _set, 'describe': _describe, 'dump': _dump, 'load': _load,
          'delete': _delete}
