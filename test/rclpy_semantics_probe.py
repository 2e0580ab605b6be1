"""What a raising callback does to spin, on real rclpy or on our runtime: the same code on both.

``python test/rclpy_semantics_probe.py rclpy|ours`` prints one JSON object: for each case, what
happened (``raised <Type>: <text>``, ``returned``...). test/test_rclpy_semantics.py runs it on both
backends and compares. Our runtime runs with ``SOCIAL_TOUCH_NETWORK=0`` (in the process only); real
rclpy in the ``ROS_DOMAIN_ID`` it is given.
"""

from __future__ import annotations

import importlib
import json
import sys
from typing import Any


def backend(name: str) -> tuple[Any, Any, Any]:
    """(rclpy module, get_message, get_service) of ``name`` ('rclpy' or 'ours')."""
    if name == 'rclpy':
        rclpy = importlib.import_module('rclpy')
        importlib.import_module('rclpy.executors')

        def get(kind: str) -> Any:
            def load(typename: str) -> Any:
                package, _, type_name = typename.split('/')
                return getattr(importlib.import_module(f'{package}.{kind}'), type_name)
            return load
        return rclpy, get('msg'), get('srv')
    from touch_graph import runtime
    from touch_graph.messages import get_message
    from touch_graph.srv_types import get_service
    return runtime, get_message, get_service


def outcome(fn: Any) -> str:
    try:
        fn()
    except Exception as err:  # what the case is about
        return f'raised {type(err).__name__}: {err}'.splitlines()[0]
    return 'returned'


def run(name: str) -> dict[str, Any]:
    rclpy, get_message, get_service = backend(name)
    executors = importlib.import_module(rclpy.__name__ + '.executors')
    parameter_module = importlib.import_module(rclpy.__name__ + '.parameter' if name == 'rclpy' else rclpy.__name__)
    Parameter = parameter_module.Parameter
    String = get_message('std_msgs/msg/String')
    SetBool = get_service('std_srvs/srv/SetBool')
    SetParameters = get_service('rcl_interfaces/srv/SetParameters')
    ParameterMsg = get_message('rcl_interfaces/msg/Parameter')
    ParameterValue = get_message('rcl_interfaces/msg/ParameterValue')
    rclpy.init()
    out: dict[str, Any] = {}

    # A timer that raises: every way of spinning ends with its exception; the node still runs after.
    node = rclpy.create_node('timer_raises')
    ticks = []

    def tick() -> None:
        ticks.append(1)
        if len(ticks) % 2:
            raise ValueError('timer raised')
    node.create_timer(0.01, tick)
    out['spin_once'] = outcome(lambda: rclpy.spin_once(node, timeout_sec=2.0))
    out['spin_once_next'] = outcome(lambda: rclpy.spin_once(node, timeout_sec=2.0))  # the even tick: no error
    out['rclpy.spin'] = outcome(lambda: rclpy.spin(node))
    for kind in ('SingleThreadedExecutor', 'MultiThreadedExecutor'):
        executor = getattr(executors, kind)()
        executor.add_node(node)
        out[f'{kind}.spin'] = outcome(executor.spin)
        executor.remove_node(node)
    node.destroy_node()

    # A subscription that raises.
    node = rclpy.create_node('subscription_raises')
    pub = node.create_publisher(String, '/probe_chatter', 10)

    def listen(msg: Any) -> None:
        raise RuntimeError(f'subscription raised on {msg.data}')
    node.create_subscription(String, '/probe_chatter', listen, 10)
    executor = executors.SingleThreadedExecutor()
    executor.add_node(node)
    pub.publish(String(data='hello'))
    out['subscription'] = outcome(lambda: [executor.spin_once(timeout_sec=0.5) for _ in range(10)])

    # A service callback that raises: the server's spin ends, the client has no response.
    def serve(request: Any, response: Any) -> Any:
        raise KeyError('service raised')
    node.create_service(SetBool, '/probe_switch', serve)
    client = node.create_client(SetBool, '/probe_switch')
    client.wait_for_service(timeout_sec=5.0)
    future = client.call_async(SetBool.Request(data=True))
    out['service'] = outcome(lambda: executor.spin_until_future_complete(future, timeout_sec=5.0))
    out['service_client_done'] = future.done()

    # An on-set-parameters callback that raises while parameters are set.
    node.declare_parameter('gain', 1)

    def on_set(params: list[Any]) -> Any:
        if any(p.name == 'gain' and p.value == 5 for p in params):
            raise ArithmeticError('on-set raised')
        return rclpy_result(successful=True)
    rclpy_result = (importlib.import_module('rcl_interfaces.msg').SetParametersResult if name == 'rclpy'
                    else rclpy.SetParametersResult)
    node.add_on_set_parameters_callback(on_set)
    out['set_parameters'] = outcome(lambda: node.set_parameters([Parameter('gain', value=5)]))
    out['set_parameters_atomically'] = outcome(lambda: node.set_parameters_atomically([Parameter('gain', value=5)]))
    out['gain_after'] = node.get_parameter('gain').value
    out['set_parameters_accepted'] = [r.successful for r in node.set_parameters([Parameter('gain', value=3)])]

    # ... and through the node's set_parameters service: the server's spin ends with it.
    param_client = node.create_client(SetParameters, f'{node.get_fully_qualified_name()}/set_parameters')
    param_client.wait_for_service(timeout_sec=5.0)
    value = ParameterValue(type=2, integer_value=5)
    future = param_client.call_async(SetParameters.Request(parameters=[ParameterMsg(name='gain', value=value)]))
    out['set_parameters_service'] = outcome(lambda: executor.spin_until_future_complete(future, timeout_sec=5.0))
    out['set_parameters_service_client_done'] = future.done()
    node.destroy_node()
    out.update(qos_matching(rclpy, executors, String))
    rclpy.shutdown()
    return out


def qos_matching(rclpy: Any, executors: Any, String: type) -> dict[str, str]:
    """Which (publisher, subscription) QoS pairs deliver, in one process: 'received' or 'nothing'."""
    qos = importlib.import_module(rclpy.__name__ + '.qos')
    Reliability, Durability = qos.ReliabilityPolicy, qos.DurabilityPolicy
    profiles = {
        'reliable': qos.QoSProfile(depth=10),
        'best_effort': qos.QoSProfile(depth=10, reliability=Reliability.BEST_EFFORT),
        'transient_local': qos.QoSProfile(depth=10, durability=Durability.TRANSIENT_LOCAL),
    }
    node = rclpy.create_node('qos_matching')
    executor = executors.SingleThreadedExecutor()
    executor.add_node(node)
    got: dict[str, list] = {}
    pubs = []
    for pub_name, pub_qos in profiles.items():
        for sub_name, sub_qos in profiles.items():
            key = f'qos {pub_name} publisher -> {sub_name} subscription'
            topic = f'/qos_{pub_name}_to_{sub_name}'
            got[key] = []
            node.create_subscription(String, topic, got[key].append, sub_qos)
            pubs.append(node.create_publisher(String, topic, pub_qos))
    for _ in range(10):  # discovery (real DDS); nothing to wait for on ours
        executor.spin_once(timeout_sec=0.05)
    for pub in pubs:
        for k in range(3):
            pub.publish(String(data=str(k)))
    for _ in range(40):
        executor.spin_once(timeout_sec=0.05)
    node.destroy_node()
    return {key: 'received' if messages else 'nothing' for key, messages in got.items()}


if __name__ == '__main__':
    print(json.dumps(run(sys.argv[1])))
