"""ROS 2's parameter services on every node, as rclpy's ``ParameterService`` serves them.

``/<node>/describe_parameters``, ``get_parameters``, ``get_parameter_types``,
``list_parameters``, ``set_parameters`` and ``set_parameters_atomically``
(``rcl_interfaces/srv/...``), so ``ros2 param`` and ``social-touch param`` read and set
the parameters of our nodes, in the process or across the network. The callbacks run in
the node's executor, like any service's; setting goes through the node's
on-set-parameters callbacks, which decide what the node can apply live.

Answers follow rclpy (Jazzy): a request naming one undeclared parameter gets an empty
list back from get/describe/types; set reports each refusal with its reason.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..messages import get_message
from ..srv_types import get_service
from .parameters import (
    ParameterNotDeclaredException,
    SetParametersResult,
    descriptor_msg,
    parameter_from_msg,
    parameter_value,
)

if TYPE_CHECKING:
    from .node import Node

__all__ = ['PARAMETER_SERVICES', 'ParameterService']

SEPARATOR = '.'
#: Service name (relative to the node) -> type.
PARAMETER_SERVICES = {
    'describe_parameters': 'rcl_interfaces/srv/DescribeParameters',
    'get_parameters': 'rcl_interfaces/srv/GetParameters',
    'get_parameter_types': 'rcl_interfaces/srv/GetParameterTypes',
    'list_parameters': 'rcl_interfaces/srv/ListParameters',
    'set_parameters': 'rcl_interfaces/srv/SetParameters',
    'set_parameters_atomically': 'rcl_interfaces/srv/SetParametersAtomically',
}


def _result_msg(result: SetParametersResult) -> Any:
    return get_message('rcl_interfaces/msg/SetParametersResult')(successful=bool(result.successful),
                                                                    reason=str(result.reason))


def _each_declared(names: list[str], answer: Callable[[str], Any]) -> list[Any]:
    """``answer`` for each name; an empty list when one is not declared (rclpy)."""
    try:
        return [answer(n) for n in names]
    except ParameterNotDeclaredException:
        return []


class ParameterService:
    """The six parameter services of ``node`` (``~/get_parameters``...)."""

    def __init__(self, node: Node) -> None:
        self.node = node
        self.services = [node.create_service(get_service(srv_type), f'~/{name}', getattr(self, f'_{name}'))
                         for name, srv_type in PARAMETER_SERVICES.items()]

    def _describe_parameters(self, request: Any, response: Any) -> Any:
        response.descriptors = _each_declared(request.names,
                                              lambda n: descriptor_msg(self.node.describe_parameter(n)))
        return response

    def _get_parameters(self, request: Any, response: Any) -> Any:
        response.values = _each_declared(request.names, lambda n: parameter_value(self.node.get_parameter(n)))
        return response

    def _get_parameter_types(self, request: Any, response: Any) -> Any:
        response.types = _each_declared(request.names, lambda n: int(self.node.get_parameter(n).type_))
        return response

    def _list_parameters(self, request: Any, response: Any) -> Any:
        names, prefixes = list_parameters(list(self.node._parameters), list(request.prefixes), int(request.depth))
        response.result.names = names
        response.result.prefixes = prefixes
        return response

    def _set_parameters(self, request: Any, response: Any) -> Any:
        results = []
        for msg in request.parameters:
            try:
                result = self.node.set_parameters_atomically([parameter_from_msg(msg)])
            except ParameterNotDeclaredException as err:
                result = SetParametersResult(False, str(err))
            results.append(_result_msg(result))
        response.results = results
        return response

    def _set_parameters_atomically(self, request: Any, response: Any) -> Any:
        try:
            result = self.node.set_parameters_atomically([parameter_from_msg(m) for m in request.parameters])
        except ParameterNotDeclaredException as err:
            result = SetParametersResult(False, str(err))
        response.result = _result_msg(result)
        return response

    def destroy(self) -> None:
        for service in self.services:
            self.node.destroy_service(service)


def list_parameters(names: list[str], prefixes: list[str], depth: int) -> tuple[list[str], list[str]]:
    """rclpy's ``Node.list_parameters``: ``(names, prefixes)`` under ``prefixes`` down to ``depth`` (0: all).

    >>> list_parameters(['a', 'b.c', 'b.d.e'], [], 0)
    (['a', 'b.c', 'b.d.e'], ['b', 'b.d'])
    >>> list_parameters(['a', 'b.c', 'b.d.e'], [], 1)
    (['a'], [])
    >>> list_parameters(['a', 'b.c', 'b.d.e'], ['b'], 1)
    (['b.c'], ['b'])
    """
    out_names: list[str] = []
    out_prefixes: list[str] = []
    recursive = not prefixes and depth == 0

    def shallow(name: str) -> bool:
        return name.count(SEPARATOR) < depth

    def under_a_prefix(name: str) -> bool:
        return any(name == prefix or (name.startswith(prefix + SEPARATOR)
                                      and (depth == 0 or shallow(name[len(prefix) + 1:]))) for prefix in prefixes)

    for name in names:
        wanted = recursive or (not prefixes and shallow(name)) or under_a_prefix(name)
        if not wanted:
            continue
        out_names.append(name)
        prefix = name.rpartition(SEPARATOR)[0]
        if prefix and prefix not in out_prefixes:
            out_prefixes.append(prefix)
    return out_names, out_prefixes
