"""``Node`` with rclpy's constructor, endpoints, parameters, logger and clock.

A node class written against this module runs unchanged on real rclpy (import the names
from :mod:`touch_graph.compat`). Node classes that a launch file can start take
``**kwargs`` and forward them::

    class BearDriver(Node):
        def __init__(self, **kwargs):
            super().__init__('bear_driver', **kwargs)
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from ..errors import GraphError, ParameterError
from .clock import Clock, ClockType
from .context import Context, get_default_context
from .endpoints import Publisher, Subscription, Timer
from .logging import RcutilsLogger
from .names import (
    RemapRule,
    apply_remaps,
    expand_topic_name,
    fully_qualified_name,
    normalize_namespace,
    validate_node_name,
)
from .parameters import (
    Parameter,
    ParameterDescriptor,
    ParameterNotDeclaredException,
    ParameterSource,
    ParameterType,
    SetParametersResult,
    check_ranges,
    coerce_to_type,
    parse_ros_args,
)
from .qos import DurabilityPolicy, QoSProfile, qos_profile_from

__all__ = ['Node']


class Node:
    """A node of the in-process graph (rclpy.node.Node)."""

    def __init__(self, node_name: str, *, context: Context | None = None, cli_args: list[str] | None = None,
                 namespace: str | None = None, use_global_arguments: bool = True, enable_rosout: bool = True,
                 start_parameter_services: bool = True, parameter_overrides: list[Parameter] | None = None,
                 allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False) -> None:
        self.context = context or get_default_context()
        if not self.context.ok():
            raise GraphError('the context is not initialised: call init() (rclpy.init()) before creating nodes')
        args = parse_ros_args(cli_args)
        if args.unparsed:
            raise GraphError(f'unexpected arguments for node {node_name!r}: {args.unparsed} '
                             '(node arguments go after --ros-args)')
        global_args = self.context.global_args if use_global_arguments else None
        rules = [RemapRule.parse(r) for r in args.remaps]
        if global_args is not None:
            rules += [RemapRule.parse(r) for r in global_args.remaps]
        for rule in rules:
            if rule.source == '__node' and rule.applies_to(node_name):
                node_name = rule.target
                break
        for rule in rules:
            if rule.source == '__ns' and rule.applies_to(node_name):
                namespace = rule.target
                break
        self._name = validate_node_name(node_name)
        self._namespace = normalize_namespace(namespace)
        self._fqn = fully_qualified_name(self._name, self._namespace)
        self._remaps = rules
        logger_name = self._fqn.lstrip('/').replace('/', '.')
        self._logger = RcutilsLogger(logger_name, self.context.now_ns)
        if args.log_level:
            self._logger.set_level(args.log_level)
        self._clock = Clock(self.context.time_source, ClockType.ROS_TIME)
        self.publishers: list[Publisher] = []
        self.subscriptions: list[Subscription] = []
        self.timers: list[Timer] = []
        self.executor = None
        self.callback_errors = 0
        self._destroyed = False

        # Parameters, as rclpy resolves them: the context's --ros-args, then the node's own (each
        # its files and -p values merged in argument order), then parameter_overrides.
        self._parameters: dict[str, Parameter] = {}
        self._descriptors: dict[str, ParameterDescriptor] = {}
        self._overrides: dict[str, tuple[Any, Any]] = {}
        self._override_keys: dict[str, str] = {}  # parameter -> the file's node key it came from
        for source_args in ((global_args, args) if global_args is not None else (args,)):
            for name, (value, key) in source_args.overrides().for_node(self._fqn).items():
                self._overrides[name] = (value.value, value)
                self._override_keys[name] = key
        for param in parameter_overrides or []:
            # A launch file's param carries where it was written (file:line) in `source`.
            source = getattr(param, 'source', None) or ParameterSource('parameter_overrides')
            self._overrides[param.name] = (param.value, source)
            self._override_keys[param.name] = self._fqn
        self._allow_undeclared = allow_undeclared_parameters
        self._set_callbacks: list[Callable[[list[Parameter]], SetParametersResult]] = []
        self.declare_parameter('use_sim_time', False)
        if automatically_declare_parameters_from_overrides:
            for name, (value, _) in list(self._overrides.items()):
                if name not in self._parameters:
                    self.declare_parameter(name, value)

        with self.context._lock:
            self.context.nodes.append(self)
        self.context._notify('node_added', self)

    # ------------------------------------------------------------------ identity
    def get_name(self) -> str:
        return self._name

    def get_namespace(self) -> str:
        return self._namespace

    def get_fully_qualified_name(self) -> str:
        return self._fqn

    def get_logger(self) -> RcutilsLogger:
        return self._logger

    def get_clock(self) -> Clock:
        return self._clock

    def resolve_topic_name(self, topic: str, *, only_expand: bool = False) -> str:
        expanded = expand_topic_name(topic, self._name, self._namespace)
        return expanded if only_expand else apply_remaps(expanded, self._remaps, self._name, self._namespace)

    # ------------------------------------------------------------------ endpoints
    def _check_alive(self) -> None:
        if self._destroyed:
            raise GraphError(f'node {self._fqn} was destroyed')

    def create_publisher(self, msg_type: type, topic: str, qos_profile: QoSProfile | int, **_ignored: Any) -> Publisher:
        """A publisher of ``msg_type`` on ``topic`` (expanded and remapped); qos is a depth or a profile."""
        self._check_alive()
        qos = qos_profile_from(qos_profile)
        name = self.resolve_topic_name(topic)
        with self.context._lock:
            topic_obj = self.context._topic_for(name, msg_type, f'publisher of {self._fqn}')
            pub = Publisher(self, topic_obj, qos)
            topic_obj.publishers.append(pub)
            self.publishers.append(pub)
        self.context._notify('publisher_added', pub)
        return pub

    def create_subscription(self, msg_type: type, topic: str, callback: Callable[[Any], None],
                            qos_profile: QoSProfile | int, *, raw: bool = False,
                            ignore_local_publications: bool = False, **_ignored: Any) -> Subscription:
        """A subscription; ``callback(msg)`` runs in the executor (``raw=True``: CDR bytes;
        ``ignore_local_publications``: skip what this node itself publishes)."""
        self._check_alive()
        if not callable(callback):
            raise TypeError(f'subscription callback must be callable, got {callback!r}')
        qos = qos_profile_from(qos_profile)
        name = self.resolve_topic_name(topic)
        with self.context._lock:
            topic_obj = self.context._topic_for(name, msg_type, f'subscription of {self._fqn}')
            sub = Subscription(self, topic_obj, callback, qos, raw=raw,
                               ignore_local_publications=ignore_local_publications)
            topic_obj.subscriptions = (*topic_obj.subscriptions, sub)
            topic_obj.raw_subscriptions += int(raw)
            topic_obj.info_subscriptions += int(sub.with_info)
            self.subscriptions.append(sub)
            if self.executor is not None:
                sub._executor = self.executor
        if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
            from .. import messages
            for pub in topic_obj.publishers:
                for msg in pub._latched or ():
                    item = messages.serialize(msg, topic_obj.type_name) if raw else msg
                    if sub.with_info:
                        now = self.context.now_ns()
                        item = (item, {'source_timestamp': now, 'received_timestamp': now})
                    sub._enqueue(item)
        self.context._notify('subscription_added', sub)
        return sub

    def create_timer(self, timer_period_sec: float, callback: Callable[[], None], callback_group: Any = None,
                     clock: Clock | None = None, autostart: bool = True) -> Timer:
        """Call ``callback()`` every ``timer_period_sec`` seconds of ROS time."""
        self._check_alive()
        if not timer_period_sec > 0:
            raise ValueError(f'timer period must be > 0 s, got {timer_period_sec}')
        timer = Timer(self, round(timer_period_sec * 1e9), callback, autostart=autostart)
        self.timers.append(timer)
        if self.executor is not None:
            timer._executor = self.executor
            self.executor._schedule(timer)
        return timer

    def destroy_publisher(self, publisher: Publisher) -> bool:
        if publisher not in self.publishers:
            return False
        with self.context._lock:
            self.publishers.remove(publisher)
            publisher._topic.publishers.remove(publisher)
            publisher._destroyed = True
            self.context._drop_topic_if_unused(publisher._topic)
        self.context._notify('publisher_removed', publisher)
        return True

    def destroy_subscription(self, subscription: Subscription) -> bool:
        if subscription not in self.subscriptions:
            return False
        with self.context._lock:
            self.subscriptions.remove(subscription)
            topic = subscription._topic
            topic.subscriptions = tuple(s for s in topic.subscriptions if s is not subscription)
            topic.raw_subscriptions -= int(subscription.raw)
            topic.info_subscriptions -= int(subscription.with_info)
            subscription._queue.clear()
            subscription._executor = None
            self.context._drop_topic_if_unused(topic)
        self.context._notify('subscription_removed', subscription)
        return True

    def destroy_timer(self, timer: Timer) -> bool:
        if timer not in self.timers:
            return False
        timer.cancel()
        self.timers.remove(timer)
        return True

    def destroy_node(self) -> None:
        """Remove the node and its endpoints from the graph; safe to call twice."""
        if self._destroyed:
            return
        for pub in list(self.publishers):
            self.destroy_publisher(pub)
        for sub in list(self.subscriptions):
            self.destroy_subscription(sub)
        for timer in list(self.timers):
            self.destroy_timer(timer)
        if self.executor is not None:
            self.executor.remove_node(self)
        with self.context._lock:
            if self in self.context.nodes:
                self.context.nodes.remove(self)
        self._destroyed = True
        self.context._notify('node_removed', self)

    # ------------------------------------------------------------------ graph queries
    # On a networked context these see the whole domain (DDS discovery), as rclpy's do.
    def _graph_view(self) -> Any:
        transport = self.context.transport
        return transport.graph.view() if transport is not None else None

    def get_topic_names_and_types(self) -> list[tuple[str, list[str]]]:
        view = self._graph_view()
        if view is None:
            return self.context.topic_names_and_types()
        return sorted((name, sorted(t.types)) for name, t in view.topics.items())

    def get_node_names(self) -> list[str]:
        return [name for name, _ in self.get_node_names_and_namespaces()]

    def get_node_names_and_namespaces(self) -> list[tuple[str, str]]:
        view = self._graph_view()
        if view is None:
            return [(n.get_name(), n.get_namespace()) for n in self.context.nodes]
        out = []
        for node in view.nodes:
            namespace, _, name = node.name.rpartition('/')
            out.append((name, namespace or '/'))
        return out

    def count_publishers(self, topic_name: str) -> int:
        return self._count(topic_name, 'publishers')

    def count_subscribers(self, topic_name: str) -> int:
        return self._count(topic_name, 'subscriptions')

    def _count(self, topic_name: str, kind: str) -> int:
        name = self.resolve_topic_name(topic_name)
        view = self._graph_view()
        if view is not None:
            topic = view.topics.get(name)
            return len(getattr(topic, kind)) if topic else 0
        topic = self.context.topics.get(name)
        return len(getattr(topic, kind)) if topic else 0

    # ------------------------------------------------------------------ parameters
    def declare_parameter(self, name: str, value: Any = None, descriptor: ParameterDescriptor | None = None,
                          ignore_override: bool = False) -> Parameter:
        """Declare ``name`` with default ``value``; an override (file, launch, -p) of the same
        type replaces the default. Raises ParameterError on a type mismatch or a value
        outside the descriptor's ranges, naming where the value came from."""
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
        if descriptor.dynamic_typing:
            declared_type = ParameterType.NOT_SET
        descriptor.name = name
        descriptor.type = int(declared_type)
        self._parameters[name] = param
        self._descriptors[name] = descriptor
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
        self._require(name)
        del self._parameters[name]
        del self._descriptors[name]

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
        return self._descriptors[name]

    def add_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], SetParametersResult]) -> None:
        self._set_callbacks.insert(0, callback)

    def remove_on_set_parameters_callback(self, callback: Callable[[list[Parameter]], SetParametersResult]) -> None:
        self._set_callbacks.remove(callback)

    def set_parameters(self, parameter_list: list[Parameter]) -> list[SetParametersResult]:
        """Set each parameter on its own (rclpy semantics); results say why one was refused."""
        return [self._set_atomically([p]) for p in parameter_list]

    def set_parameters_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        return self._set_atomically(parameter_list)

    def _set_atomically(self, parameter_list: list[Parameter]) -> SetParametersResult:
        checked = []
        for param in parameter_list:
            if param.name not in self._parameters:
                if not self._allow_undeclared:
                    return SetParametersResult(False, f"parameter '{param.name}' is not declared")
                self._descriptors[param.name] = ParameterDescriptor(name=param.name, type=int(param.type_))
                checked.append(param)
                continue
            descriptor = self._descriptors[param.name]
            if descriptor.read_only:
                return SetParametersResult(False, f"parameter '{param.name}' is read-only")
            value = param.value
            if descriptor.type:
                try:
                    value = coerce_to_type(param.name, value, ParameterType(descriptor.type), self._fqn, None)
                except ParameterError as err:
                    return SetParametersResult(False, str(err))
            problem = check_ranges(param.name, value, descriptor, self._fqn)
            if problem:
                return SetParametersResult(False, problem)
            checked.append(Parameter(param.name, value=value) if value is not None else param)
        for callback in self._set_callbacks:
            result = callback(checked)
            if not result.successful:
                return result
        for param in checked:
            self._parameters[param.name] = param
        return SetParametersResult(True, '')
