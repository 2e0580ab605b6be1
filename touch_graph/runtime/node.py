"""``Node`` with rclpy's constructor, endpoints, parameters, logger and clock.

A node class may take rclpy's keyword arguments or none at all (``super().__init__('greeter')``);
a launcher gives the latter its context, remaps and parameters through :func:`node_arguments`.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from .. import messages
from ..errors import GraphError
from ..messages import get_message
from .clock import Clock, ClockType
from .context import Context, get_default_context
from .endpoints import Publisher, Subscription, Timer, warn_incompatible
from .graph_info import endpoints_info
from .guard_condition import GuardCondition
from .logging import RcutilsLogger
from .names import (
    RemapRule,
    apply_remaps,
    expand_topic_name,
    fully_qualified_name,
    normalize_namespace,
    validate_node_name,
)
from .node_parameters import NodeParameters
from .parameter_service import ParameterService
from .parameters import (
    Parameter,
    ParameterDescriptor,
    SetParametersResult,
    parse_ros_args,
)
from .qos import (
    DurabilityPolicy,
    QoSProfile,
    qos_profile_from,
    qos_profile_parameter_events,
    qos_profile_rosout_default,
    qos_profile_services_default,
)
from .services import Client, Service
from .type_description_service import TypeDescriptionService

__all__ = ['Node', 'node_arguments']

_rosout_guard = threading.local()
_pending = threading.local()   # arguments node_arguments() holds for the next Node of this thread


@contextmanager
def node_arguments(*, context: Context | None = None, cli_args: list[str] | None = None,
                   parameter_overrides: list[Parameter] | None = None) -> Iterator[dict[str, Any]]:
    """Give the next :class:`Node` this thread constructs these arguments, when its call passes none.

    How a launcher starts a node class with rclpy's constructor (``__init__(self)`` calling
    ``super().__init__('name')``): rclpy's node would read them from the process's context and
    ``--ros-args``; many nodes share a process here, so each gets its own this way. The yielded
    dict's ``'taken'`` says whether a node took them (a class that never calls ``Node.__init__`` does not).
    """
    pending = {'context': context, 'cli_args': cli_args, 'parameter_overrides': parameter_overrides,
               'taken': False}
    previous = getattr(_pending, 'value', None)
    _pending.value = pending
    try:
        yield pending
    finally:
        _pending.value = previous
_Log = get_message('rcl_interfaces/msg/Log')
_ParameterEvent = get_message('rcl_interfaces/msg/ParameterEvent')


class Node(NodeParameters):
    """A node of the graph (rclpy.node.Node): endpoints, timers, services, parameters, logger, clock.

    Like rclpy's, a node publishes ``/parameter_events`` and (``enable_rosout``) its log lines
    on ``/rosout``, and serves the parameter services (``start_parameter_services``).
    """

    def __init__(self, node_name: str, *, context: Context | None = None, cli_args: list[str] | None = None,
                 namespace: str | None = None, use_global_arguments: bool = True, enable_rosout: bool = True,
                 start_parameter_services: bool = True, parameter_overrides: list[Parameter] | None = None,
                 allow_undeclared_parameters: bool = False,
                 automatically_declare_parameters_from_overrides: bool = False) -> None:
        pending = getattr(_pending, 'value', None)
        if pending is not None and not pending['taken'] and context is None and cli_args is None \
                and parameter_overrides is None:
            pending['taken'] = True  # only the first node of the class's __init__ (not nodes it makes inside)
            context, cli_args = pending['context'], pending['cli_args']
            parameter_overrides = pending['parameter_overrides']
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
        self.services: list[Service] = []
        self.clients: list[Client] = []
        self.timers: list[Timer] = []
        self.guards: list[GuardCondition] = []
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
            source = getattr(param, 'source', None) or 'parameter_overrides'
            self._overrides[param.name] = (param.value, source)
            self._override_keys[param.name] = self._fqn
        self._allow_undeclared = allow_undeclared_parameters
        self._set_callbacks: list[Callable[[list[Parameter]], SetParametersResult]] = []
        self._post_set_callbacks: list[Callable[[list[Parameter]], None]] = []
        self._parameter_lock = threading.RLock()
        self._parameter_events = self.create_publisher(_ParameterEvent, '/parameter_events',
                                                       qos_profile_parameter_events)
        self._rosout = self.create_publisher(_Log, '/rosout', qos_profile_rosout_default) if enable_rosout else None
        if enable_rosout:
            self._logger.set_sink(self._publish_rosout)
        self.declare_parameter('use_sim_time', False)
        if automatically_declare_parameters_from_overrides:
            for name, (value, _) in list(self._overrides.items()):
                if name not in self._parameters:
                    self.declare_parameter(name, value)
        self._parameter_service = None
        if start_parameter_services:
            self._parameter_service = ParameterService(self)
            self._type_description_service = TypeDescriptionService(self)  # ~/get_type_description, as Jazzy's

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
            subs = topic_obj.subscriptions
        for sub in subs:
            warn_incompatible(pub, sub)
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
        unmatched = {pub for pub in list(topic_obj.publishers) if warn_incompatible(pub, sub)}
        if qos.durability == DurabilityPolicy.TRANSIENT_LOCAL:
            for pub in topic_obj.publishers:
                if pub in unmatched:
                    continue
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

    def create_service(self, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any], *,
                       qos_profile: QoSProfile = qos_profile_services_default, **_ignored: Any) -> Service:
        """A server of ``srv_type`` on ``srv_name`` (expanded and remapped); ``callback(request, response)``
        runs in the executor and returns the response."""
        self._check_alive()
        if not callable(callback):
            raise TypeError(f'service callback must be callable, got {callback!r}')
        name = self.resolve_service_name(srv_name)
        service = Service(self, srv_type, name, callback, qos_profile_from(qos_profile))
        with self.context._lock:
            self.context._add_service(service, f'service of {self._fqn}')
            self.services.append(service)
            if self.executor is not None:
                service._executor = self.executor
        self.context._notify('service_added', service)
        return service

    def create_client(self, srv_type: Any, srv_name: str, *,
                      qos_profile: QoSProfile = qos_profile_services_default, **_ignored: Any) -> Client:
        """A client of ``srv_type`` on ``srv_name`` (expanded and remapped)."""
        self._check_alive()
        client = Client(self, srv_type, self.resolve_service_name(srv_name), qos_profile_from(qos_profile))
        with self.context._lock:
            self.clients.append(client)
            if self.executor is not None:
                client._executor = self.executor
        self.context._notify('client_added', client)
        return client

    def resolve_service_name(self, service: str, *, only_expand: bool = False) -> str:
        """Service names expand and remap as topic names do (rcl)."""
        return self.resolve_topic_name(service, only_expand=only_expand)

    def destroy_service(self, service: Service) -> bool:
        if service not in self.services:
            return False
        with self.context._lock:
            self.services.remove(service)
            self.context._remove_service(service)
            service._destroyed = True
        service._fail_queued('was destroyed')
        service._executor = None
        self.context._notify('service_removed', service)
        return True

    def destroy_client(self, client: Client) -> bool:
        if client not in self.clients:
            return False
        with self.context._lock:
            self.clients.remove(client)
            client._destroyed = True
        client._queue.clear()
        client._executor = None
        client._fail_pending('the client was destroyed')
        self.context._notify('client_removed', client)
        return True

    def _waitables(self) -> list[Any]:
        """Everything of this node an executor takes work from: subscriptions, services, clients."""
        return [*self.subscriptions, *self.services, *self.clients]

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

    def create_guard_condition(self, callback: Callable[[], Any], callback_group: Any = None) -> GuardCondition:
        """A condition another thread triggers to have ``callback()`` run by this node's executor (rclpy's)."""
        self._check_alive()
        guard = GuardCondition(self, callback)
        self.guards.append(guard)
        return guard

    def destroy_guard_condition(self, guard: GuardCondition) -> bool:
        if guard not in self.guards:
            return False
        guard.destroy()
        self.guards.remove(guard)
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
        for service in list(self.services):
            self.destroy_service(service)
        for client in list(self.clients):
            self.destroy_client(client)
        for timer in list(self.timers):
            self.destroy_timer(timer)
        for guard in list(self.guards):
            self.destroy_guard_condition(guard)
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

    def get_publishers_info_by_topic(self, topic_name: str, no_mangle: bool = False) -> list[Any]:
        return endpoints_info(self, topic_name, 'publishers')

    def get_subscriptions_info_by_topic(self, topic_name: str, no_mangle: bool = False) -> list[Any]:
        return endpoints_info(self, topic_name, 'subscriptions')

    def count_publishers(self, topic_name: str) -> int:
        return self._count(topic_name, 'publishers')

    def count_subscribers(self, topic_name: str) -> int:
        return self._count(topic_name, 'subscriptions')

    def _count(self, topic_name: str, kind: str) -> int:
        name = self.resolve_topic_name(topic_name)
        transport = self.context.transport
        if transport is not None:  # counted without building the graph's view: a node may ask on every tick
            return transport.graph.count_endpoints(name, kind)
        topic = self.context.topics.get(name)
        return len(getattr(topic, kind)) if topic else 0

    # ------------------------------------------------------------------ rosout
    def _publish_rosout(self, severity: int, name: str, message: str, file: str, function: str, line: int) -> None:
        """Publish a log line on ``/rosout`` (``rcl_interfaces/Log``), as rcl's rosout handler does."""
        publisher = self._rosout
        if publisher is None or publisher._destroyed or getattr(_rosout_guard, 'busy', False):
            return
        _rosout_guard.busy = True  # a log line written while publishing one is not published again
        try:
            publisher.publish(_Log(stamp=self._clock.now().to_msg(), level=int(severity), name=name, msg=message,
                                   file=file, function=function, line=max(0, int(line))))
        except Exception:  # a log line that cannot go to /rosout still went to the console
            pass
        finally:
            _rosout_guard.busy = False
