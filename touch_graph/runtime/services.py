"""Services and clients with rclpy's names: ``create_service``, ``create_client``, ``call_async``, ``call``.

A server's ``callback(request, response) -> response`` runs in the executor spinning its node; a
client's ``call_async`` returns a :class:`~.task.Future` completed by the executor spinning the
client's node. A server in the client's context gets the request object itself; otherwise it goes
over DDS (:mod:`touch_graph.dds.services`). A callback that raises or returns no ``Response`` is
counted (``errors``) and ends its executor's spin, as in rclpy. A request with no server fails at
once with :class:`~touch_graph.errors.ServiceCallError`, as do requests of a server that vanishes.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from ..errors import GraphError, ServiceCallError
from ..srv_types import service_type_of
from .endpoints import QueuedEntity
from .executors import SingleThreadedExecutor
from .qos import KEEP_ALL_LIMIT, QoSProfile
from .task import Future

if TYPE_CHECKING:
    from .node import Node

__all__ = ['Client', 'Service']

#: Sequence numbers of requests, one counter per process as rmw_cyclonedds has.
_sequence = itertools.count(1)
#: How often wait_for_service looks, s.
WAIT_POLL_S = 0.05


class _LocalReply:
    """Where a server in the process sends its response: a client of the same context."""

    __slots__ = ('client', 'seq')

    def __init__(self, client: Client, seq: int) -> None:
        self.client = client
        self.seq = seq

    def send(self, response: Any) -> None:
        self.client._deliver(self.seq, response)

    def fail(self, error: BaseException) -> None:
        self.client._deliver(self.seq, error)


class Service(QueuedEntity):
    """``node.create_service(SrvType, 'name', callback)``; ``callback(request, response) -> response``.

    Attributes:
        srv_type: the service class; ``srv_name``: the resolved name.
        received: requests queued; dropped: requests dropped from a full queue (depth).
        replied: responses sent. errors: requests whose callback raised or returned no Response.
    """

    def __init__(self, node: Node, srv_type: Any, srv_name: str, callback: Callable[[Any, Any], Any],
                 qos: QoSProfile) -> None:
        super().__init__(node, qos)
        self.srv_type = srv_type
        self.service_type = service_type_of(srv_type)
        self.srv_name = srv_name
        self.callback = callback
        self.replied = 0
        self.errors = 0
        self._destroyed = False
        self._handler = self._handle
        self._what = f"service '{srv_name}'"

    @property
    def service_name(self) -> str:
        return self.srv_name

    def _handle(self, item: tuple[Any, Any]) -> None:
        request, reply = item
        try:
            response = self.callback(request, self.srv_type.Response())
        except Exception:
            self.errors += 1
            raise  # it ends the server's spin, as in rclpy; the client gets nothing
        if type(response) is not self.srv_type.Response:
            self.errors += 1
            raise TypeError(f'the callback of service {self.srv_name} returned {type(response).__name__}, not a '
                            f'{self.service_type} Response (return the response it was given); the client gets '
                            'no response')
        reply.send(response)
        self.replied += 1

    def _enqueue_local(self, item: tuple[Any, Any]) -> None:
        queue = self._queue
        if len(queue) == queue.maxlen:  # keep last N, as the DDS reader does; the dropped caller learns it
            _, reply = queue.popleft()
            self.dropped += 1
            reply.fail(ServiceCallError(f"service '{self.srv_name}' dropped the request: {queue.maxlen} newer "
                                        'ones were waiting (its node is busy or not spinning)'))
        super()._enqueue_local(item)

    def _fail_queued(self, why: str) -> None:
        """Fail the requests still queued (the service is going away)."""
        while self._queue:
            _, reply = self._queue.popleft()
            reply.fail(ServiceCallError(f"service '{self.srv_name}' {why} before replying"))
        self._ready = False

    def destroy(self) -> bool:
        return self.node.destroy_service(self)


class Client(QueuedEntity):
    """``node.create_client(SrvType, 'name')``: ``call_async``, ``call``, ``wait_for_service``.

    Attributes:
        srv_type: the service class; ``srv_name``: the resolved name.
        late: responses that came for no pending request (timed out, removed, or a second server's).
    """

    def __init__(self, node: Node, srv_type: Any, srv_name: str, qos: QoSProfile) -> None:
        # Responses are never dropped for lack of room: each one completes a future someone waits on.
        super().__init__(node, QoSProfile(depth=KEEP_ALL_LIMIT, reliability=qos.reliability,
                                          durability=qos.durability))
        self.qos_profile = qos
        self.srv_type = srv_type
        self.service_type = service_type_of(srv_type)
        self.srv_name = srv_name
        self.late = 0
        self._pending: dict[int, Future] = {}
        self._destroyed = False
        self._handler = self._complete
        self._what = f"client of '{srv_name}'"

    @property
    def service_name(self) -> str:
        return self.srv_name

    # ------------------------------------------------------------------ calls
    def call_async(self, request: Any) -> Future:
        """Send ``request``; the returned future completes with the response (or a ServiceCallError).

        Raises:
            TypeError: ``request`` is not this service's Request.
            GraphError: the client was destroyed.
        """
        if type(request) is not self.srv_type.Request:
            raise TypeError(f'{self.node.get_fully_qualified_name()} calls {self.srv_name} ({self.service_type}) '
                            f'with a {type(request).__name__}, not a {self.service_type} Request')
        if self._destroyed:
            raise GraphError(f"client of '{self.srv_name}' was destroyed")
        seq = next(_sequence)
        future = Future()
        future._client_seq = seq  # type: ignore[attr-defined]  # for remove_pending_request
        self._pending[seq] = future
        local = self.node.context._services.get(self.srv_name)
        if local:
            local[0]._enqueue((request, _LocalReply(self, seq)))
            return future
        dds = self._dds
        if dds is None:
            why = ('no server for it: this graph is not on the network (Context(network=False)); '
                   'wait_for_service() first')
        else:
            why = dds.send_request(seq, request)
        if why:
            self._pending.pop(seq, None)
            future.set_exception(ServiceCallError(f"cannot call '{self.srv_name}' ({self.service_type}): {why}"))
        return future

    def call(self, request: Any, timeout_sec: float | None = None) -> Any:
        """Send ``request`` and wait for the response; None after ``timeout_sec`` (wall time), as in rclpy.

        Unlike rclpy this never deadlocks: when no thread spins the client's node, it spins
        it here until the response comes. Called from a callback of the executor spinning
        the node, it raises GraphError instead of waiting forever (use ``call_async``).

        Raises:
            ServiceCallError: no server, or it vanished mid-call.
        """
        executor = self.node.executor
        if executor is not None and executor.spinning_thread() == threading.get_ident():
            raise GraphError(f"client.call() on '{self.srv_name}' from a callback of the executor spinning "
                             f'{self.node.get_fully_qualified_name()}: that thread is the one that must take the '
                             'response, so the call would never return. Use call_async() with add_done_callback, '
                             'or spin the node in another thread')
        future = self.call_async(request)
        if not future.done():
            if executor is None:
                helper = SingleThreadedExecutor(context=self.node.context)
                helper.add_node(self.node)
                try:
                    helper.spin_until_future_complete(future, timeout_sec)
                finally:
                    helper.remove_node(self.node)
            elif executor._spin_lock.acquire(blocking=False):  # nobody spins it now: do it here
                try:
                    executor.spin_until_future_complete(future, timeout_sec)
                finally:
                    executor._spin_lock.release()
            else:
                future.wait(timeout_sec)
        if not future.done():
            self.remove_pending_request(future)
            return None
        return future.result()

    def remove_pending_request(self, future: Future) -> None:
        """Forget a request: its response, if one still comes, is ignored (and counted in ``late``)."""
        self._pending.pop(getattr(future, '_client_seq', None), None)

    # ------------------------------------------------------------------ availability
    def service_is_ready(self) -> bool:
        """True when a server can receive a request now: one in this graph, or one matched over DDS."""
        if self.node.context._services.get(self.srv_name):
            return True
        dds = self._dds
        return dds is not None and dds.server_ready()

    def wait_for_service(self, timeout_sec: float | None = None) -> bool:
        """Wait (wall time) until :meth:`service_is_ready`; False after ``timeout_sec`` (None: for ever)."""
        deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
        while self.node.context.ok() and not self.service_is_ready():
            left = WAIT_POLL_S if deadline is None else min(WAIT_POLL_S, deadline - time.monotonic())
            if left <= 0:
                break
            time.sleep(left)
        return self.service_is_ready()

    # ------------------------------------------------------------------ responses
    def _deliver(self, seq: int, value: Any) -> None:
        """A response (or an exception) for request ``seq``, from any thread."""
        if self._executor is None:
            self._complete((seq, value))  # nobody spins the node: complete in the delivering thread
        else:
            self._enqueue((seq, value))

    def _complete(self, item: tuple[int, Any]) -> None:
        seq, value = item
        future = self._pending.pop(seq, None)
        if future is None:
            self.late += 1
            return
        if isinstance(value, BaseException):
            future.set_exception(value)
        else:
            future.set_result(value)

    def _fail_pending(self, why: str, seqs: list[int] | None = None) -> None:
        """Fail requests under way (all, or ``seqs``) with a ServiceCallError saying ``why`` (any thread)."""
        for seq in list(self._pending) if seqs is None else seqs:
            if seq in self._pending:
                self._deliver(seq, ServiceCallError(f"call to '{self.srv_name}' failed: {why}"))

    def destroy(self) -> bool:
        return self.node.destroy_client(self)
