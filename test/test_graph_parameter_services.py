"""Every node serves ROS 2's parameter services and publishes /parameter_events and /rosout, as rclpy's do."""

import pytest

from touch_graph.messages import get_message
from touch_graph.runtime import (
    Context,
    FloatingPointRange,
    Node,
    Parameter,
    ParameterDescriptor,
    ParameterType,
    SetParametersResult,
    SingleThreadedExecutor,
)
from touch_graph.runtime.parameters import parameter_msg, value_of
from touch_graph.srv_types import get_service

ParameterEvent = get_message('rcl_interfaces/msg/ParameterEvent')
Log = get_message('rcl_interfaces/msg/Log')
srv = {name: get_service(f'rcl_interfaces/srv/{name}') for name in (
    'GetParameters', 'ListParameters', 'DescribeParameters', 'GetParameterTypes', 'SetParameters',
    'SetParametersAtomically')}


@pytest.fixture
def graph():
    context = Context(network=False)
    context.init()
    executor = SingleThreadedExecutor(context=context)
    events = []
    logs = []
    watcher = Node('watcher', context=context, start_parameter_services=False, enable_rosout=False)
    watcher.create_subscription(ParameterEvent, '/parameter_events', events.append, 100)
    watcher.create_subscription(Log, '/rosout', logs.append, 100)
    executor.add_node(watcher)
    target = Node('target', namespace='/robot', context=context)
    target.declare_parameter('threshold', 0.3, ParameterDescriptor(
        description='activation threshold', floating_point_range=[FloatingPointRange(0.0, 1.0, 0.0)]))
    target.declare_parameter('model', 'a.npz', ParameterDescriptor(read_only=True))
    target.declare_parameter('rule.alpha', 2)
    target.declare_parameter('rule.deep.beta', [1.0, 2.0])
    target.declare_parameter('anything', 'x', ParameterDescriptor(dynamic_typing=True))
    executor.add_node(target)
    yield context, executor, watcher, target, events, logs
    executor.shutdown()
    context.try_shutdown()


def call(executor, node, name, request):
    client = node.create_client(srv[type(request).__name__.removesuffix('_Request')], name)
    future = client.call_async(request)
    executor.spin_until_future_complete(future, 5)
    assert future.done()
    return future.result()


def test_the_six_services_are_there_with_ros2_names(graph):
    _, _, _, target, _, _ = graph
    assert sorted(s.srv_name for s in target.services) == [
        '/robot/target/describe_parameters', '/robot/target/get_parameter_types', '/robot/target/get_parameters',
        '/robot/target/get_type_description',  # not a parameter service, but started with them, as in Jazzy
        '/robot/target/list_parameters', '/robot/target/set_parameters', '/robot/target/set_parameters_atomically']


def test_get_list_describe_and_types(graph):
    _, executor, watcher, _, _, _ = graph
    response = call(executor, watcher, '/robot/target/get_parameters',
                    srv['GetParameters'].Request(names=['threshold', 'rule.deep.beta', 'model']))
    assert [value_of(v) for v in response.values] == [0.3, [1.0, 2.0], 'a.npz']
    undeclared = call(executor, watcher, '/robot/target/get_parameters',
                      srv['GetParameters'].Request(names=['threshold', 'nope']))
    assert undeclared.values == []  # rclpy (Jazzy): one undeclared name, an empty answer
    listed = call(executor, watcher, '/robot/target/list_parameters', srv['ListParameters'].Request())
    assert sorted(listed.result.names) == ['anything', 'model', 'rule.alpha', 'rule.deep.beta', 'threshold',
                                           'use_sim_time']
    assert sorted(listed.result.prefixes) == ['rule', 'rule.deep']
    shallow = call(executor, watcher, '/robot/target/list_parameters',
                   srv['ListParameters'].Request(prefixes=['rule'], depth=1))
    assert shallow.result.names == ['rule.alpha']
    described = call(executor, watcher, '/robot/target/describe_parameters',
                     srv['DescribeParameters'].Request(names=['threshold', 'model']))
    threshold, model = described.descriptors
    assert (threshold.name, threshold.type, threshold.description) == ('threshold', 3, 'activation threshold')
    assert (threshold.floating_point_range[0].from_value, threshold.floating_point_range[0].to_value) == (0.0, 1.0)
    assert model.read_only and model.type == 4
    types = call(executor, watcher, '/robot/target/get_parameter_types',
                 srv['GetParameterTypes'].Request(names=['rule.alpha', 'anything']))
    assert list(types.types) == [ParameterType.INTEGER, ParameterType.STRING]


def test_set_takes_effect_and_refusals_say_why(graph):
    _, executor, watcher, target, events, _ = graph
    seen = []

    def on_set(params):
        seen.append([(p.name, p.value) for p in params])
        return SetParametersResult(True, '')
    target.add_on_set_parameters_callback(on_set)
    request = srv['SetParameters'].Request(parameters=[
        parameter_msg(Parameter('threshold', value=0.5)),
        parameter_msg(Parameter('threshold', value=1.5)),          # outside its range
        parameter_msg(Parameter('model', value='b.npz')),          # read-only
        parameter_msg(Parameter('rule.alpha', value='three')),     # wrong type
        parameter_msg(Parameter('nope', value=1)),                 # undeclared
        parameter_msg(Parameter('rule.alpha', value=3))])
    results = call(executor, watcher, '/robot/target/set_parameters', request).results
    assert [r.successful for r in results] == [True, False, False, False, False, True]
    assert 'must be in [0.0, 1.0]' in results[1].reason
    assert results[2].reason == "parameter 'model' cannot be set because it is read-only"
    assert 'must be an integer' in results[3].reason
    assert "'nope' is not declared" in results[4].reason
    assert target.get_parameter('threshold').value == 0.5 and target.get_parameter('rule.alpha').value == 3
    assert seen == [[('threshold', 0.5)], [('rule.alpha', 3)]]  # only what passed the checks reached the node
    executor.spin_until(lambda: len([e for e in events if e.changed_parameters]) >= 2, 2)
    changed = [(p.name, value_of(p.value)) for e in events for p in e.changed_parameters]
    assert changed == [('threshold', 0.5), ('rule.alpha', 3)] and events[-1].node == '/robot/target'


def test_set_atomically_is_all_or_nothing(graph):
    _, executor, watcher, target, _, _ = graph
    request = srv['SetParametersAtomically'].Request(parameters=[
        parameter_msg(Parameter('threshold', value=0.7)), parameter_msg(Parameter('rule.alpha', value='x'))])
    result = call(executor, watcher, '/robot/target/set_parameters_atomically', request).result
    assert not result.successful and target.get_parameter('threshold').value == 0.3


def test_a_node_callback_decides_and_a_raising_ones_exception_goes_to_the_caller_as_in_rclpy(graph):
    _, executor, watcher, target, _, _ = graph
    target.add_on_set_parameters_callback(lambda params: SetParametersResult(False, 'not while touching'))
    result = target.set_parameters([Parameter('threshold', value=0.4)])[0]
    assert (result.successful, result.reason) == (False, 'not while touching')
    target.add_on_set_parameters_callback(lambda params: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        target.set_parameters([Parameter('threshold', value=0.4)])
    assert target.get_parameter('threshold').value == 0.3
    # Through the service, the exception ends the spin of the target's executor (rclpy's too).
    request = srv['SetParameters'].Request(parameters=[parameter_msg(Parameter('threshold', value=0.4))])
    with pytest.raises(ZeroDivisionError):
        call(executor, watcher, '/robot/target/set_parameters', request)
    assert target.get_parameter('threshold').value == 0.3


def test_delete_undeclares_a_dynamic_parameter_only_and_events_say_so(graph):
    _, executor, _, target, events, _ = graph
    executor.spin_until(lambda: len(events) >= 6, 2)
    assert [p.name for e in events for p in e.new_parameters if e.node == '/robot/target'] == [
        'use_sim_time', 'threshold', 'model', 'rule.alpha', 'rule.deep.beta', 'anything']
    refused = target.set_parameters([Parameter('threshold', ParameterType.NOT_SET, None)])[0]
    assert refused.reason == "cannot undeclare statically typed parameter 'threshold'"
    assert target.set_parameters([Parameter('anything', ParameterType.NOT_SET, None)])[0].successful
    assert not target.has_parameter('anything')
    executor.spin_until(lambda: any(e.deleted_parameters for e in events), 2)
    assert [p.name for e in events for p in e.deleted_parameters] == ['anything']


def test_use_sim_time_cannot_be_switched_live(graph):
    _, _, _, target, _, _ = graph
    result = target.set_parameters([Parameter('use_sim_time', value=True)])[0]
    assert not result.successful and '--sim-time' in result.reason


def test_log_lines_go_to_rosout(graph):
    _, executor, _, target, _, logs = graph
    target.get_logger().warning('the skin is hot')
    target.get_logger().get_child('calib').info('baseline done')
    executor.spin_until(lambda: len(logs) >= 2, 2)
    warn, info = logs[-2:]
    assert (warn.level, warn.name, warn.msg) == (Log.WARN, 'robot.target', 'the skin is hot')
    assert warn.file.endswith('test_graph_parameter_services.py') and warn.line > 0
    assert warn.function == 'test_log_lines_go_to_rosout'
    assert (info.level, info.name) == (Log.INFO, 'robot.target.calib')


def test_get_type_description_describes_the_types_the_node_uses(graph):
    from touch_graph import type_description
    from touch_graph.srv_types import get_service
    _, executor, watcher, _, _, _ = graph
    GetTypeDescription = get_service('type_description_interfaces/srv/GetTypeDescription')
    client = watcher.create_client(GetTypeDescription, '/robot/target/get_type_description')

    def ask(**fields):
        future = client.call_async(GetTypeDescription.Request(**fields))
        executor.spin_until_future_complete(future, 5.0)
        return future.result()
    response = ask(type_name='rcl_interfaces/msg/ParameterEvent')  # its /parameter_events publisher
    assert response.successful, response.failure_reason
    described = response.type_description
    assert described.type_description.type_name == 'rcl_interfaces/msg/ParameterEvent'
    assert [t.type_name for t in described.referenced_type_descriptions] == [
        'builtin_interfaces/msg/Time', 'rcl_interfaces/msg/Parameter', 'rcl_interfaces/msg/ParameterValue']
    right = type_description.type_hash('rcl_interfaces/msg/ParameterEvent')
    assert ask(type_name='rcl_interfaces/msg/ParameterEvent', type_hash=right).successful
    wrong = ask(type_name='rcl_interfaces/msg/ParameterEvent', type_hash='RIHS01_' + '0' * 64)
    assert not wrong.successful and right in wrong.failure_reason
    unused = ask(type_name='std_msgs/msg/Char')
    assert not unused.successful and 'not used by this node' in unused.failure_reason
    assert ask(type_name='rcl_interfaces/srv/GetParameters').successful  # a service it serves
