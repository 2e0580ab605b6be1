"""Services over DDS with ROS 2's request/reply mapping: calls between graphs, the graph view, and calls that
must neither block nor kill a node (a server gone mid-call, a foreign request type, a timeout)."""

import threading
import time
from dataclasses import dataclass

from cyclonedds.core import Policy, Qos
from cyclonedds.domain import DomainParticipant
from cyclonedds.idl import IdlStruct
from cyclonedds.idl.types import int64, uint64
from cyclonedds.pub import DataWriter
from cyclonedds.topic import Topic
from cyclonedds.util import duration
from dds_testing import SpinningGraph, wait_until

from touch_graph.dds.cdds import delete_entity
from touch_graph.errors import ServiceCallError
from touch_graph.runtime import Parameter
from touch_graph.srv_types import get_service

SetBool = get_service('std_srvs/srv/SetBool')
GetParameters = get_service('rcl_interfaces/srv/GetParameters')


def serve(graph, callback, name='/switch', node='server'):
    server = graph.add_node(node)
    return server, graph.call(lambda: server.create_service(SetBool, name, callback))


def echo(request, response):
    response.success = request.data
    response.message = f'data was {request.data}'
    return response


def test_a_call_between_graphs_and_the_parameter_services_over_dds(dds_domain):
    a, b = SpinningGraph(), SpinningGraph()
    try:
        _, service = serve(a, echo)
        target = a.add_node('target', parameter_overrides=[Parameter('rate', value=25.0)],
                            automatically_declare_parameters_from_overrides=True)
        caller = b.add_node('caller')
        client = b.call(lambda: caller.create_client(SetBool, '/switch'))
        assert client.wait_for_service(timeout_sec=10)
        assert client.call(SetBool.Request(data=True), timeout_sec=5) == SetBool.Response(success=True,
                                                                                          message='data was True')
        assert service._dds.gone == service._dds.unmatched == 0 and client._dds.sent == 1
        params = b.call(lambda: caller.create_client(GetParameters, '/target/get_parameters'))
        assert params.wait_for_service(timeout_sec=10)
        values = params.call(GetParameters.Request(names=['rate', 'use_sim_time']), timeout_sec=5).values
        assert [(v.type, v.double_value, v.bool_value) for v in values] == [(3, 25.0, False), (1, 0.0, False)]
        assert target.get_parameter('rate').value == 25.0

        def listed():
            # Discovery reaches the view entity by entity: wait for every one the assertions below read.
            view = b.view()
            info = view.services.get('/switch')
            callers = view.find_nodes('/caller')
            return (info is not None and info.servers == {'/server'} and info.clients == {'/caller'}
                    and '/target/get_parameters' in view.services and len(callers) == 1
                    and '/target/get_parameters' in callers[0].clients)
        wait_until(listed, 10, 'the services with their servers and clients in the graph view')
        view = b.view()
        assert view.services['/target/get_parameters'].type_name == 'rcl_interfaces/srv/GetParameters'
        [server_info] = view.find_nodes('/server')
        assert server_info.services['/switch'] == 'std_srvs/srv/SetBool'
        assert '/server/set_parameters' in server_info.services
        [caller_info] = view.find_nodes('/caller')
        assert caller_info.clients == {'/switch': 'std_srvs/srv/SetBool',
                                       '/target/get_parameters': 'rcl_interfaces/srv/GetParameters'}
    finally:
        a.close()
        b.close()


def test_two_clients_each_get_their_own_replies(dds_domain):
    a, b = SpinningGraph(), SpinningGraph()
    try:
        serve(a, echo)
        caller = b.add_node('caller')
        first = b.call(lambda: caller.create_client(SetBool, '/switch'))
        second = b.call(lambda: caller.create_client(SetBool, '/switch'))
        assert first.wait_for_service(10) and second.wait_for_service(10)
        futures = [(client, client.call_async(SetBool.Request(data=i % 2 == 0)))
                   for i, client in enumerate([first, second] * 5)]
        wait_until(lambda: all(f.done() for _, f in futures), 10, 'every reply')
        assert [f.result().success for _, f in futures] == [i % 2 == 0 for i in range(10)]
        # every reply reaches both clients; each keeps its own and counts the other's
        assert first._dds.foreign == second._dds.foreign == 5 and first.late == second.late == 0
    finally:
        a.close()
        b.close()


def test_a_server_leaving_mid_call_fails_the_call_and_blocks_nobody(dds_domain):
    a, b = SpinningGraph(), SpinningGraph()
    release = threading.Event()
    try:
        def slow(request, response):
            release.wait(10)
            return echo(request, response)
        serve(a, slow)
        caller = b.add_node('caller')
        client = b.call(lambda: caller.create_client(SetBool, '/switch'))
        assert client.wait_for_service(10)
        started = time.monotonic()
        assert client.call(SetBool.Request(data=True), timeout_sec=0.5) is None  # the timeout, not a hang
        assert time.monotonic() - started < 5 and not client._pending
        future = client.call_async(SetBool.Request(data=True))
        a.context.transport.close()  # the server's process leaves the domain with the request under way
        wait_until(future.done, 10, 'the pending call to fail')
        assert isinstance(future.exception(), ServiceCallError)
        assert 'left the graph before replying' in str(future.exception())
        assert not client.service_is_ready()
    finally:
        release.set()
        a.close()
        b.close()


@dataclass
class ForeignSetBoolRequest(IdlStruct, typename='std_srvs::srv::dds_::SetBool_Request_'):
    """Our service's request type name with another layout: no header, a 64-bit field."""

    client: uint64
    value: int64


def test_a_foreign_request_layout_is_refused_and_reported_the_server_lives(dds_domain, capsys):
    a = SpinningGraph()
    foreign = DomainParticipant(dds_domain)
    try:
        _, service = serve(a, echo)
        topic = Topic(foreign, 'rq/switchRequest', ForeignSetBoolRequest)
        writer = DataWriter(foreign, topic, Qos(Policy.Reliability.Reliable(duration(seconds=1)),
                                                Policy.DataRepresentation(use_cdrv0_representation=True)))
        wait_until(lambda: 'incompatible type' in capsys.readouterr().err or service._dds.incompatible, 15,
                   'the incompatible request type to be reported')
        assert service._dds.incompatible >= 1
        writer.write(ForeignSetBoolRequest(client=1, value=2))
        time.sleep(0.3)
        assert service.received == 0  # nothing of that layout reached the callback
        b = SpinningGraph()
        try:
            caller = b.add_node('caller')
            client = b.call(lambda: caller.create_client(SetBool, '/switch'))
            assert client.wait_for_service(10)
            assert client.call(SetBool.Request(data=False), timeout_sec=5).message == 'data was False'
        finally:
            b.close()
    finally:
        delete_entity(foreign)
        a.close()


def test_service_endpoints_announce_their_types_hash_as_rmw_fastrtps_does(dds_domain):
    """``serviceid=...;typehash=...;`` (``clientid=`` for a client): on ``rq/`` the request's hash, on
    ``rr/`` the response's, as a Jazzy rclpy node on Fast DDS announces them (seen in discovery)."""
    from touch_graph.dds.discovery import user_data_value
    from touch_graph.type_description import type_hash
    a, b = SpinningGraph(), SpinningGraph()
    try:
        serve(a, echo)
        caller = b.add_node('caller')
        b.call(lambda: caller.create_client(SetBool, '/switch'))
        request, response = type_hash('std_srvs/srv/SetBool_Request'), type_hash('std_srvs/srv/SetBool_Response')
        # as ros-jazzy-std-srvs 5.3.6 installs them (share/std_srvs/srv/SetBool.json)
        assert request == 'RIHS01_c62fbb99d94e1b25e8ef9e109f9581956bb1b3361a45a4e5810c36a90d29932e'
        assert response == 'RIHS01_d0814e7f7b4880ab77e9c57426c7aa1562ab69f11eef8e2e968812f9cbd0b059'

        def announced():
            endpoints = dict(a.context.transport.graph._endpoints)
            found = {(e['kind'], e['topic'], user_data_value(e['qos_raw'], 'typehash'),
                      'server' if user_data_value(e['qos_raw'], 'serviceid') else 'client')
                     for e in endpoints.values() if e['topic'] in ('rq/switchRequest', 'rr/switchReply')}
            return found == {('reader', 'rq/switchRequest', request, 'server'),
                             ('writer', 'rr/switchReply', response, 'server'),
                             ('writer', 'rq/switchRequest', request, 'client'),
                             ('reader', 'rr/switchReply', response, 'client')}
        wait_until(announced, 10, 'the service endpoints with their type hashes')
    finally:
        a.close()
        b.close()
