"""A node's parameters with rclpy's API and semantics, and the ``/parameter_events`` they cause.

As in rclpy: declaring runs the on-set-parameters callbacks (a refusal raises
:class:`InvalidParameterValueException`), setting runs them newest first (the first refusal wins,
nothing changes; an exception goes to the caller), and each change publishes a
``rcl_interfaces/ParameterEvent``. Setting ``NOT_SET`` undeclares a dynamically typed parameter.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import Any

from ..errors import ParameterError
from .parameters import (
    InvalidParameterValueException,
    Parameter,
    ParameterDescriptor,
    ParameterNotDeclaredException,
    ParameterType,
    SetParametersResult,
    check_ranges,
    coerce_to_type,
    parameter_event,
)

__all__ = ['NodeParameters']


class NodeParameters:
    """The parameter half of :class:`~touch_graph.runtime.node.Node` (a mixin).

    The node sets ``_parameters``, ``_descriptors``, ``_overrides``, ``_override_keys``,
    ``_allow_undeclared``, ``_set_callbacks``, ``_post_set_callbacks``, ``_fqn`` and ``_parameter_events`` (a publisher
    or None) before it declares anything.
    """

    _parameters: dict[str, Parameter]
    _descriptors: dict[str, ParameterDescriptor]
    _overrides: dict[str, tuple[Any, Any]]
    _override_keys: dict[str, str]
    _allow_undeclared: bool
    _set_callbacks: list[Callable[[list[Parameter]], SetParametersResult]]
    _post_set_callbacks: list[Callable[[list[Parameter]], None]]
    _fqn: str
    _parameter_events: Any
    _parameter_lock: threading.RLock

    # ------------------------------------------------------------------ declaring
    def declare_parameter(self, name: str, value: Any = None, descriptor: ParameterDescriptor | None = None,
                          ignore_override: bool = False) -> Parameter:
        """Declare ``name`` with default ``value``; an override (file, launch, -p) of the same
        type replaces the default. Raises ParameterError on a type mismatch or a value
        outside the descriptor's ranges, naming where the value came from."""
        with self._parameter_lock:
            if name in self._parameters:
                raise ParameterError(f"parameter '{name}' of {self._fqn} is already declared")
            descriptor = descriptor or ParameterDescriptor()
            declared_type = ParameterType(descriptor.type) if descriptor.type else Parameter(name, value=value).type_
            source = None
            if name in self._overrides and not ignore_override:
                value, source = self._overrides[name]
                if not descriptor.dynamic_typing:
                    value = coerce_to_type(name, value, declared_type, self._fqn, source)
            problem = check_ranges(name, value, descriptor, self._fqn)
            if problem:
                raise ParameterError(f'{source}: {problem}' if source else problem)
            if value is None:
                param = Parameter(name, declared_type, None)
            elif descriptor.dynamic_typing or declared_type == ParameterType.NOT_SET:
                param = Parameter(name, value=value)
            else:
                param = Parameter(name, declared_type, value)  # an empty list takes the declared type
            for callback in self._set_callbacks:  # as rclpy: each declaration is a set; a raise propagates
                result = callback([param])
                if not result.successful:
                    raise InvalidParameterValueException(name, param.value, result.reason)
            if descriptor.dynamic_typing:
                declared_type = ParameterType.NOT_SET
            descriptor.name = name
            descriptor.type = int(declared_type)
            self._parameters[name] = param
            self._descriptors[name] = descriptor
            self._call_post_set([param])
        self._publish_parameter_event(new=[param])
        return param

    def declare_parameters(self, namespace: str, parameters: list[tuple],
                           ignore_override: bool = False) -> list[Parameter]:
        out = []
        for entry in parameters:
            name = f'{namespace}.{entry[0]}' if namespace else entry[0]
            value = entry[1] if len(entry) > 1 else None
            descriptor = entry[2] if len(entry) > 2 else None
            out.append(self.declare_parameter(name, value, descriptor, ignore_override))
        return out

    def undeclare_parameter(self, name: str) -> None:
        with self._parameter_lock:
            param = self._require(name)
            if self._descriptors[name].read_only:
                raise ParameterError(f"parameter '{name}' of {self._fqn} is read-only; it cannot be undeclared")
            del self._parameters[name]
            del self._descriptors[name]
        self._publish_parameter_event(deleted=[param])

    # ------------------------------------------------------------------ reading
    def has_parameter(self, name: str) -> bool:
        return name in self._parameters

    def _require(self, name: str) -> Parameter:
        param = self._parameters.get(name)
        if param is None:
            if self._allow_undeclared:
                return Parameter(name, ParameterType.NOT_SET, None)
            raise ParameterNotDeclaredException(f"parameter '{name}' of {self._fqn} is not declared; declared: "
                                                f'{", ".join(sorted(self._parameters))}')
        return param

    def override_origins(self) -> list[tuple[str, Any, str, bool]]:
        """``(name, source, node key, declared)`` of every override given to this node: where it was
        written, which parameter-file key brought it, and whether the node declared it (an
        undeclared one is a misspelt parameter or one meant for another node; a node that
        allows undeclared parameters takes them all)."""
        return [(name, source, self._override_keys.get(name, self._fqn),
                 self._allow_undeclared or name in self._parameters)
                for name, (_, source) in self._overrides.items()]

    def get_parameter(self, name: str) -> Parameter:
        return self._require(name)

    def get_parameters(self, names: list[str]) -> list[Parameter]:
        return [self._require(n) for n in names]

    def get_parameter_or(self, name: str, alternative_value: Parameter | None = None) -> Parameter:
        return self._parameters.get(name, alternative_value or Parameter(name, ParameterType.NOT_SET, None))

    def get_parameters_by_prefix(self, prefix: str) -> dict[str, Parameter]:
        start = prefix + '.' if prefix else ''
        return {n[len(start):]: p for n, p in self._parameters.items() if n.startswith(start)}

    def describe_parameter(self, name: str) -> ParameterDescriptor:
        self._require(name)
        return self._descriptors.get(name) or ParameterDescriptor(name=name)

    def describe_parameters(self, names: list[str]) -> list[ParameterDescriptor]:
        return [self.describe_parameter(n) for n in names]

    # ------------------------------------------------------------------ setting
    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], SetParametersResult]) -> None:
        self._set_callbacks.insert(0, callback)

    def remove_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], SetParametersResult]) -> None:
        self._set_callbacks.remove(callback)

    def add_post_set_parameters_callback(self, callback: Callable[[list[Parameter]], None]) -> None:
        """As rclpy: ``callback(parameters)`` after parameters were set (a declaration too), newest first."""
        if not callable(callback):
            raise TypeError(f'Callback must be callable, got {type(callback)}')
        self._post_set_callbacks.insert(0, callback)

    def remove_post_set_parameters_callback(self, callback: Callable[[list[Parameter]], None]) -> None:
        self._post_set_callbacks.remove(callback)

    def _call_post_set(self, parameter_list: list[Parameter]) -> None:
        for callback in list(self._post_set_callbacks):
            callback(parameter_list)

    def set_parameters(self, parameter_list: list[Parameter]) -> list[SetParametersResult]:
        """Set each parameter on its own (rclpy semantics); results say why one was refused."""
        return [self._set_atomically([p]) for p in parameter_list]

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        return self._set_atomically(parameter_list)

    def _check_one(self, param: Parameter) -> tuple[Parameter | None, str]:
        """The parameter as it would be stored (typed), or None and why it is refused."""
        name = param.name
        descriptor = self._descriptors.get(name)
        if name not in self._parameters:
            if not self._allow_undeclared:
                return None, f"parameter '{name}' is not declared"
            return param, ''
        if descriptor.read_only:
            return None, f"parameter '{name}' cannot be set because it is read-only"
        if name == 'use_sim_time' and param.value != self._parameters[name].value:
            return None, ("the clock is the context's: start the graph with --sim-time (social-touch launch) "
                          'instead of switching use_sim_time')
        if param.type_ == ParameterType.NOT_SET:
            if descriptor.type != ParameterType.NOT_SET:
                return None, f"cannot undeclare statically typed parameter '{name}'"
            return param, ''
        value = param.value
        if descriptor.type:
            try:
                value = coerce_to_type(name, value, ParameterType(descriptor.type), self._fqn, None)
            except ParameterError as err:
                return None, str(err)
        problem = check_ranges(name, value, descriptor, self._fqn)
        if problem:
            return None, problem
        return Parameter(name, value=value), ''

    def _set_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        with self._parameter_lock:
            checked = []
            for param in parameter_list:
                typed, why = self._check_one(param)
                if typed is None:
                    return SetParametersResult(False, why)
                checked.append(typed)
            for callback in self._set_callbacks:
                result = callback(checked)  # an exception goes to the caller, nothing changes (rclpy)
                if not result.successful:
                    return result
            new, changed, deleted = [], [], []
            for param in checked:
                old = self._parameters.get(param.name)
                if param.type_ == ParameterType.NOT_SET:
                    self._parameters.pop(param.name, None)
                    self._descriptors.pop(param.name, None)
                    if old is not None and old.type_ != ParameterType.NOT_SET:
                        deleted.append(param)
                    continue
                if param.name not in self._descriptors:  # an undeclared one, on a node that allows them
                    self._descriptors[param.name] = ParameterDescriptor(name=param.name, type=int(param.type_))
                (new if old is None or old.type_ == ParameterType.NOT_SET else changed).append(param)
                self._parameters[param.name] = param
            self._call_post_set(checked)
        self._publish_parameter_event(new=new, changed=changed, deleted=deleted)
        return SetParametersResult(True, '')

    # ------------------------------------------------------------------ events
    def _publish_parameter_event(self, new: list[Parameter] = (), changed: list[Parameter] = (),
                                 deleted: list[Parameter] = ()) -> None:
        publisher = self._parameter_events
        if publisher is None or publisher._destroyed or not (new or changed or deleted):
            return
        publisher.publish(parameter_event(self._fqn, self.get_clock().now().to_msg(), new, changed, deleted))
