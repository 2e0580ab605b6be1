"""A context's place in a DDS domain: one participant, a writer per publisher, a reader per subscription.

Design (one :class:`DdsParticipant` per initialised, networked
:class:`~touch_graph.runtime.Context`, as rmw_cyclonedds has one participant per context):

- **Entities**: the participant (user data ``enclave=/;`` as rcl sets it), one DDS
  publisher and one DDS subscriber, one topic per DDS topic name, and one DataWriter per
  runtime ``Publisher`` / one DataReader per runtime ``Subscription``, created and deleted
  as the context's graph listener reports them (:mod:`.endpoints`). Each has the QoS ROS 2
  gives it (:mod:`.qos`) and a GID of its own, so ``ros_discovery_info`` lists node by node.
- **No loopback**: readers and writers ignore the endpoints of their own participant, so
  DDS never echoes a process's samples back to it and a writer whose only readers are
  local counts no match; inside the process the runtime delivers in memory as before.
- **Samples wake the executor itself**: an executor of a networked context waits on a
  Cyclone wait set holding the read conditions of its subscriptions' readers
  (:mod:`.waker`), so a remote sample wakes the thread that runs the callback, which takes
  and decodes it there: one thread hand-over, as with rclpy. A reader whose node no
  executor spins keeps at most its depth of samples in DDS, as in ROS 2.
- **One discovery thread** (``dds-<domain>``) waits on the discovery readers
  (:mod:`.discovery`) and a guard condition: it keeps the graph view, publishes
  ``ros_discovery_info`` and subscription statistics when they changed, and reports
  incompatible QoS. Node callbacks never run in it.
- **Shutdown**: :meth:`close` (called by ``Context.shutdown``) stops and joins the
  thread, deletes the participant with everything in it and releases the domain (the last
  user deletes it, and Cyclone's threads with it).

Peers that vanish or links that break are Cyclone's business: writers keep at most their
history depth of unacknowledged samples, so nothing waits on a reader that is gone.
"""

from __future__ import annotations

import contextlib
import itertools
import logging
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.pub import Publisher as DdsPublisherEntity
from cyclonedds.sub import Subscriber as DdsSubscriberEntity
from cyclonedds.topic import Topic as DdsTopic

from .. import type_description
from ..errors import GraphError
from .cdds import WaitSet, delete_entity, forget
from .config import DiscoveryOptions, read_discovery
from .config import domain_id as env_domain_id
from .discovery import GraphDiscovery
from .domain import acquire_domain, release_domain
from .endpoints import DdsReader, DdsWriter
from .idl import idl_struct
from .names import dds_topic_name, ros_topic_name
from .qos import POLICY_NAMES, TYPE_CONSISTENCY_POLICY
from .services import DdsClient, DdsService
from .waker import DdsWaker

__all__ = ['DdsParticipant']

_log = logging.getLogger('touch_graph.dds')
#: How often the discovery thread looks at QoS statuses and refreshes what it publishes, s.
HOUSEKEEPING_S = 0.5
#: Housekeeping rounds an incompatible type waits for its endpoint's discovery, to name its type.
TYPE_REPORT_TRIES = 4


class DdsParticipant:
    """The DDS participant of a context.

    Args:
        context: an initialised :class:`~touch_graph.runtime.Context`.
        domain: the domain id (default ``$ROS_DOMAIN_ID``).
        discovery: discovery options (default from ``$ROS_AUTOMATIC_DISCOVERY_RANGE`` / ``$ROS_STATIC_PEERS``).
        enclave: the SROS2 enclave announced in the participant's user data.
    """

    def __init__(self, context: Any, *, domain: int | None = None, discovery: DiscoveryOptions | None = None,
                 enclave: str = '/') -> None:
        self.context = context
        self.domain_id = env_domain_id() if domain is None else domain
        self.discovery_options = discovery or read_discovery()
        self.enclave = enclave
        self.config = acquire_domain(self.domain_id, self.discovery_options)
        self._lock = threading.RLock()
        self._closed = False
        try:
            self.participant = DomainParticipant(self.domain_id,
                                                 qos=Qos(Policy.Userdata(data=f'enclave={enclave};'.encode())))
        except Exception as err:
            release_domain(self.domain_id)
            raise GraphError(f'cannot join DDS domain {self.domain_id}: {err}') from err
        forget(self.participant)
        self.gid = self.participant.get_guid().bytes
        self.dds_publisher = DdsPublisherEntity(self.participant)
        self.dds_subscriber = DdsSubscriberEntity(self.participant)
        forget(self.dds_publisher)
        forget(self.dds_subscriber)
        self._topics: dict[str, DdsTopic] = {}
        self._hashes: dict[str, str] = {}
        self.writers: dict[int, DdsWriter] = {}  # id(runtime Publisher) -> writer
        self.readers: dict[int, DdsReader] = {}  # id(runtime Subscription) -> reader
        self.services: dict[int, Any] = {}  # id(runtime Service) -> DdsService
        self.clients: dict[int, Any] = {}  # id(runtime Client) -> DdsClient
        self.csids = itertools.count(1)  # client/service ids, as rmw_cyclonedds counts them per participant
        self._keys = itertools.count(1)
        self._handlers: dict[int, Callable[[], None]] = {}
        self._pending: deque[Callable[[], None]] = deque()
        self._incompatible: list[list] = []  # [endpoint, count change, policy id, tries] to report
        self.waitset = WaitSet(self.participant._ref)
        self.graph = GraphDiscovery(self)
        context.add_graph_listener(self._on_local_graph)
        self._thread = threading.Thread(target=self._run, name=f'dds-{self.domain_id}', daemon=True)
        self._thread.start()

    # ------------------------------------------------------------------ entities
    def topic(self, ros_name: str, type_name: str) -> DdsTopic:
        """The DDS topic ``rt/<ros_name>`` with ``type_name``'s DDS type (one per name)."""
        return self.dds_topic(dds_topic_name(ros_name), type_name)

    def dds_topic(self, key: str, type_name: str, store: Any = None, *, struct: Any = None,
                  dds_name: str = '') -> DdsTopic:
        """The DDS topic ``key`` (one per key) of ``type_name``, or of ``struct`` (a service's wire type).

        ``dds_name``: the topic's DDS name when it is not ``key`` (a second type on one topic).
        """
        with self._lock:
            topic = self._topics.get(key)
            if topic is None:
                topic = self._topics[key] = DdsTopic(self.participant, dds_name or key,
                                                     struct or idl_struct(type_name, store))
                forget(topic)
            return topic

    def type_hash(self, type_name: str) -> str:
        """The ``RIHS01_...`` hash ROS 2 (Iron and later) computes for ``type_name`` ('' if unknown)."""
        with self._lock:
            value = self._hashes.get(type_name)
            if value is None:
                try:
                    value = type_description.type_hash(type_name)
                except Exception:  # a type rosbags cannot hash: announce none, as rmw does then
                    value = ''
                self._hashes[type_name] = value
            return value

    def attach(self, condition_ref: int, handler: Callable[[], None]) -> int:
        """Call ``handler()`` in the receive thread whenever ``condition_ref`` triggers; returns its key."""
        key = next(self._keys)
        with self._lock:
            self._handlers = {**self._handlers, key: handler}
        self.waitset.attach(condition_ref, key)
        return key

    def detach(self, condition_ref: int, key: int) -> None:
        self.waitset.detach(condition_ref)
        with self._lock:
            self._handlers = {k: h for k, h in self._handlers.items() if k != key}

    def call_soon(self, fn: Callable[[], None]) -> None:
        """Run ``fn()`` in the receive thread (safe from any thread)."""
        self._pending.append(fn)
        self.waitset.wake()

    # ------------------------------------------------------------------ the local graph
    def _on_local_graph(self, event: str, endpoint: Any) -> None:
        if self._closed:
            return
        try:
            if event == 'publisher_added':
                self._add_writer(endpoint)
            elif event == 'publisher_removed':
                self._remove_writer(endpoint)
            elif event == 'subscription_added':
                self._add_reader(endpoint)
            elif event == 'subscription_removed':
                self._remove_reader(endpoint)
            elif event in ('service_added', 'client_added'):
                self._add_pair(endpoint, event == 'service_added')
            elif event in ('service_removed', 'client_removed'):
                self._remove_pair(endpoint, event == 'service_removed')
        finally:
            self.graph.local_changed()

    def _add_writer(self, publisher: Any) -> None:
        try:
            writer = DdsWriter(self, publisher)
        except Exception as err:  # the node goes on in process; say why others will not see it
            publisher.node.get_logger().error(f"publisher on '{publisher.topic_name}' is not on the network: {err}")
            return
        with self._lock:
            self.writers[id(publisher)] = writer
        publisher._dds = writer

    def _remove_writer(self, publisher: Any) -> None:
        with self._lock:
            writer = self.writers.pop(id(publisher), None)
        publisher._dds = None
        if writer is not None:
            delete_entity(writer.ref)

    def _add_reader(self, subscription: Any) -> None:
        try:
            reader = DdsReader(self, subscription)
        except Exception as err:
            subscription.node.get_logger().error(
                f"subscription to '{subscription.topic_name}' is not on the network: {err}")
            return
        with self._lock:
            self.readers[id(subscription)] = reader
        subscription._dds = reader
        executor = subscription._executor
        if executor is not None:  # made while its node spins: that executor takes from it
            executor._attach_reader(reader)

    def _remove_reader(self, subscription: Any) -> None:
        with self._lock:
            reader = self.readers.pop(id(subscription), None)
        subscription._dds = None
        if reader is not None:
            if reader.waker is not None:
                reader.waker.detach(reader)
            delete_entity(reader.ref)

    def _add_pair(self, entity: Any, is_service: bool) -> None:
        try:
            pair = (DdsService if is_service else DdsClient)(self, entity)
        except Exception as err:  # the node goes on in process; say why others will not see it
            what = 'service' if is_service else 'client of'
            entity.node.get_logger().error(f"{what} '{entity.srv_name}' is not on the network: {err}")
            return
        with self._lock:
            (self.services if is_service else self.clients)[id(entity)] = pair
        entity._dds = pair
        executor = entity._executor
        if executor is not None:
            executor._attach_reader(pair)

    def _remove_pair(self, entity: Any, is_service: bool) -> None:
        with self._lock:
            pair = (self.services if is_service else self.clients).pop(id(entity), None)
        entity._dds = None
        if pair is not None:
            if pair.waker is not None:
                pair.waker.detach(pair)
            if hasattr(pair, 'close_plain'):
                pair.close_plain()
            delete_entity(pair.reader)
            delete_entity(pair.writer)

    def make_waker(self) -> Any:
        """A :class:`~touch_graph.dds.waker.DdsWaker` for an executor of this context."""
        return DdsWaker(self.participant._ref, owner=self)

    # ------------------------------------------------------------------ receive thread
    def _run(self) -> None:
        next_housekeeping = 0.0
        while not self._closed:
            try:
                keys = self.waitset.wait(int(HOUSEKEEPING_S * 1e9))
            except Exception as err:  # pragma: no cover - the participant was deleted under us
                if not self._closed:
                    _log.error('DDS receive thread: %s', err)
                return
            if self._closed:
                return
            handlers = self._handlers
            for key in keys:
                handler = handlers.get(key)
                if handler is not None:
                    self._guarded(handler)
            while self._pending:
                self._guarded(self._pending.popleft())
            now = time.monotonic()
            if now >= next_housekeeping:
                next_housekeeping = now + HOUSEKEEPING_S
                self._guarded(self.housekeeping)

    def _guarded(self, fn: Callable[[], None]) -> None:
        try:
            fn()
        except Exception as err:  # one bad sample or handler must not stop the receive thread
            if not self._closed:
                _log.exception('DDS receive thread: %s failed: %s', getattr(fn, '__qualname__', fn), err)

    def housekeeping(self) -> None:
        """Report new incompatible QoS (as rclcpp's default event handlers word it); refresh the graph;
        fail service calls whose server left."""
        self.graph.housekeeping()
        with self._lock:
            writers = list(self.writers.values())
            readers = list(self.readers.values())
            pairs = [*self.services.values(), *self.clients.values()]
            clients = list(self.clients.values())
        checks = [(w, w.writer, True, dds_topic_name(w.topic_name), w.type_name) for w in writers]
        checks += [(r, r.reader, False, dds_topic_name(r.topic_name), r.type_name) for r in readers]
        checks += [(pair, *check) for pair in pairs for check in pair.qos_checks()]
        for owner, entity, is_writer, dds_name, type_name in checks:
            try:
                status = (entity.get_offered_incompatible_qos_status() if is_writer
                          else entity.get_requested_incompatible_qos_status())
            except Exception:  # deleted by its node in the meantime
                continue
            if status.total_count_change:
                self._incompatible.append([owner, is_writer, dds_name, type_name, status.total_count_change,
                                           int(status.last_policy_id), 0])
        self._incompatible = [item for item in self._incompatible if not self._report_incompatible(item)]
        for client in clients:
            client.check_server()
        for pair in pairs:
            if hasattr(pair, 'check_clients'):
                pair.check_clients()

    def _report_incompatible(self, item: list) -> bool:
        """Log one ``[owner, is writer, DDS topic, type, change, policy, tries]``; False: try again later
        (the foreign type is not discovered yet)."""
        owner, is_writer, dds_name, type_name, change, policy, tries = item
        other, verb = ('subscription', 'requesting') if is_writer else ('publisher', 'offering')
        outcome = 'No messages will be sent to it.' if is_writer else 'No messages will be received from it.'
        logger = owner.node.get_logger()
        shown = ros_topic_name(dds_name) or dds_name
        if policy == TYPE_CONSISTENCY_POLICY:
            theirs = self.graph.foreign_types(dds_name, type_name)
            if not theirs and tries < TYPE_REPORT_TRIES:
                item[6] += 1
                return False
            logger.warn(f"New {other} discovered on topic '{shown}', {verb} an incompatible type: "
                        f"{', '.join(theirs) or 'another layout'} does not match ours, "
                        f"'{type_name}'. {outcome}")
        else:
            logger.warn(f"New {other} discovered on topic '{shown}', {verb} incompatible QoS. "
                        f"{outcome} Last incompatible policy: {POLICY_NAMES.get(policy, str(policy))}")
        owner.incompatible = getattr(owner, 'incompatible', 0) + int(change)
        return True

    # ------------------------------------------------------------------ lifecycle
    def close(self) -> None:
        """Stop the receive thread, delete the participant and everything in it, release the domain. Idempotent."""
        with self._lock:
            if self._closed:
                return
            self._closed = True
        self.context.remove_graph_listener(self._on_local_graph)
        self.waitset.wake()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=10.0)
        for pub_id in list(self.writers):
            self.writers.pop(pub_id).publisher._dds = None
        for sub_id in list(self.readers):
            self.readers.pop(sub_id).subscription._dds = None
        for table in (self.services, self.clients):
            for key in list(table):
                table.pop(key).entity._dds = None
        with contextlib.suppress(Exception):
            self.graph.close()
        delete_entity(self.participant)
        release_domain(self.domain_id)

    @property
    def closed(self) -> bool:
        return self._closed
