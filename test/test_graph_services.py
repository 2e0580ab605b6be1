"""Services in one process: rclpy's API (create_service, create_client, call_async, call, futures), delivery in
memory, and the calls that must neither block nor kill a node."""

import threading

import pytest

from touch_graph import runtime
from touch_graph.errors import GraphError, ServiceCallError
from touch_graph.runtime import Context, Node, SingleThreadedExecutor
from touch_graph.srv_types import get_service

SetBool = get_service('std_srvs/srv/SetBool')
Trigger = get_service('std_srvs/srv/Trigger')


@pytest.fixture
def graph():
    context = Context(network=False)
    context.init()
    executor = SingleThreadedExecutor(context=context)
    yield context, executor
    executor.shutdown()
    context.try_shutdown()


def _server(context, executor, callback=None, name='switch'):
    node = Node('server', context=context)
    seen = []

    def default(request, response):
        seen.append(request)
        response.success = request.data
        response.message = f'set to {request.data}'
        return response
    service = node.create_service(SetBool, name, callback or default)
    executor.add_node(node)
    return node, service, seen


def test_call_async_completes_in_memory_with_the_same_request_object(graph):
    context, executor = graph
    _, service, seen = _server(context, executor)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    client = caller.create_client(SetBool, '/switch')
    assert client.wait_for_service(timeout_sec=0.0)
    request = SetBool.Request(data=True)
    future = client.call_async(request)
    done = []
    future.add_done_callback(done.append)
    assert not future.done() and future.result() is None
    runtime.spin_until_future_complete(caller, future, executor=executor, timeout_sec=5)
    assert future.done() and done == [future]
    assert future.result() == SetBool.Response(success=True, message='set to True')
    assert seen[0] is request  # not serialised in the process
    assert (service.received, service.replied, service.errors) == (1, 1, 0)


def test_call_from_another_thread_waits_while_the_executor_spins(graph):
    context, executor = graph
    _server(context, executor)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    client = caller.create_client(SetBool, 'switch')
    thread = threading.Thread(target=lambda: executor.spin_until(lambda: stop.is_set(), 10), daemon=True)
    stop = threading.Event()
    thread.start()
    try:
        assert client.call(SetBool.Request(data=False), timeout_sec=5).message == 'set to False'
    finally:
        stop.set()
        executor.wake()
        thread.join(5)


def test_call_spins_the_node_itself_when_nobody_does(graph):
    context, executor = graph
    _server(context, executor)
    caller = Node('caller', context=context)  # in no executor
    client = caller.create_client(SetBool, 'switch')
    # The server's executor is not spun by anyone either: the call spins the caller, the server
    # callback runs when its executor spins; so spin the server in a thread, the caller here.
    stop = threading.Event()
    thread = threading.Thread(target=lambda: executor.spin_until(stop.is_set, 10), daemon=True)
    thread.start()
    try:
        assert client.call(SetBool.Request(data=True), timeout_sec=5).success is True
        assert caller.executor is None  # the helper executor let it go again
    finally:
        stop.set()
        executor.wake()
        thread.join(5)


def test_call_from_a_callback_of_its_own_executor_is_an_error_not_a_deadlock(graph):
    context, executor = graph
    _server(context, executor)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    client = caller.create_client(SetBool, 'switch')
    errors = []

    def tick():
        try:
            client.call(SetBool.Request(data=True), timeout_sec=1)
        except GraphError as err:
            errors.append(str(err))
    caller.create_timer(0.01, tick)
    executor.spin_until(lambda: errors, 5)
    assert 'would never return' in errors[0] and 'call_async' in errors[0]


def test_a_raising_server_ends_the_spin_as_in_rclpy_the_client_gets_nothing_and_the_next_spin_serves(graph):
    context, executor = graph
    calls = []

    def flaky(request, response):
        calls.append(request.data)
        if not request.data:
            raise RuntimeError('boom')
        response.success = True
        return response
    server, service, _ = _server(context, executor, flaky)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    client = caller.create_client(SetBool, 'switch')
    future = client.call_async(SetBool.Request(data=False))
    with pytest.raises(RuntimeError, match='boom') as raised:
        executor.spin_until_future_complete(future, timeout_sec=5)
    assert "the service '/switch' callback of node /server" in str(raised.value.__notes__)
    assert not future.done() and executor.last_failure == (server, "service '/switch'")
    assert (service.errors, server.callback_errors, client.late) == (1, 1, 0)
    # A node that spins again (rclpy.spin_once in a loop that catches) serves the next request.
    assert client.call(SetBool.Request(data=True), timeout_sec=5).success is True
    assert calls == [False, True]


def test_a_callback_returning_no_response_ends_the_spin_with_a_type_error_the_client_gets_nothing(graph):
    context, executor = graph
    _, service, _ = _server(context, executor, lambda request, response: None)
    caller = Node('caller', context=context)
    executor.add_node(caller)
    client = caller.create_client(SetBool, 'switch')
    future = client.call_async(SetBool.Request())
    with pytest.raises(TypeError, match='returned NoneType, not a std_srvs/srv/SetBool Response'):
        executor.spin_until_future_complete(future, timeout_sec=5)
    assert service.errors == 1 and not future.done()


def test_a_request_of_the_wrong_type_is_refused_at_the_call(graph):
    context, executor = graph
    _server(context, executor)
    client = Node('caller', context=context).create_client(SetBool, 'switch')
    with pytest.raises(TypeError, match='with a Trigger_Request, not a std_srvs/srv/SetBool Request'):
        client.call_async(Trigger.Request())


def test_no_server_fails_at_once_and_wait_for_service_times_out(graph):
    context, _ = graph
    client = Node('caller', context=context).create_client(SetBool, 'nobody')
    assert not client.service_is_ready()
    assert client.wait_for_service(timeout_sec=0.1) is False
    future = client.call_async(SetBool.Request())
    assert future.done()
    with pytest.raises(ServiceCallError, match=r"cannot call '/nobody'.*no server"):
        future.result()
    with pytest.raises(ServiceCallError):
        client.call(SetBool.Request(), timeout_sec=1)


def test_a_server_destroyed_with_requests_queued_fails_them(graph):
    context, executor = graph
    server, service, _ = _server(context, executor)
    caller = Node('caller', context=context)
    client = caller.create_client(SetBool, 'switch')
    future = client.call_async(SetBool.Request())
    assert service._queue and not future.done()  # nobody spun the server yet
    server.destroy_service(service)
    assert isinstance(future.exception(), ServiceCallError)
    assert 'was destroyed before replying' in str(future.exception())
    assert not client.service_is_ready()


def test_one_name_one_type_and_names_are_resolved_and_remapped(graph):
    context, executor = graph
    _server(context, executor, name='~/switch')
    other = Node('other', context=context)
    with pytest.raises(GraphError, match="already served as std_srvs/srv/SetBool"):
        other.create_service(Trigger, '/server/switch', lambda req, resp: resp)
    caller = Node('caller', context=context, cli_args=['--ros-args', '-r', 'toggle:=/server/switch'])
    client = caller.create_client(SetBool, 'toggle')
    assert client.srv_name == '/server/switch' and client.service_is_ready()


def test_future_api_as_rclpy():
    future = runtime.Future()
    order = []
    future.add_done_callback(lambda f: order.append('first'))
    future.add_done_callback(lambda f: 1 / 0)  # logged, the next one still runs
    future.add_done_callback(lambda f: order.append('third'))
    future.set_result(42)
    future.set_result(43)  # a second result is ignored
    assert future.result() == 42 and order == ['first', 'third']
    late = []
    future.add_done_callback(late.append)  # done already: runs at once
    assert late == [future]
    failed = runtime.Future()
    failed.set_exception(ValueError('x'))
    with pytest.raises(ValueError):
        failed.result()
    cancelled = runtime.Future()
    cancelled.cancel()
    assert cancelled.done() and cancelled.cancelled() and cancelled.result() is None


def test_a_full_request_queue_drops_the_oldest_and_tells_its_caller(graph):
    context, executor = graph
    _, service, _ = _server(context, executor)  # nobody spins it yet
    client = Node('caller', context=context).create_client(SetBool, 'switch')
    futures = [client.call_async(SetBool.Request(data=True)) for _ in range(12)]
    assert service.dropped == 2 and len(service._queue) == 10  # keep last 10, as the services QoS says
    for dropped in futures[:2]:
        assert isinstance(dropped.exception(), ServiceCallError) and 'dropped the request' in str(dropped.exception())
    executor.spin_until(lambda: all(f.done() for f in futures), 5)
    assert all(f.result().success for f in futures[2:])
