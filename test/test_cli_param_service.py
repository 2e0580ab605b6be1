"""``social-touch param`` and ``service`` against a node running in another process, over DDS, as ros2 prints them."""

import textwrap
import time

import pytest
import yaml
from test_cli_graph_commands import running_graph

from touch_graph.cli import main as cli_main

# The lines these commands take in touch_graph/cli/main.py's COMMANDS table.
COMMANDS = {
    'param': ('touch_graph.cli.param', 'parameters of running nodes: list, get, set, describe, dump, load, delete'),
    'service': ('touch_graph.cli.service', 'services of the running graph: list, type, find, call'),
}

TUNER = textwrap.dedent('''
    import sys
    from touch_graph.compat import Node, ParameterDescriptor, SetParametersResult, get_service, rclpy
    from touch_graph.runtime import FloatingPointRange
    Trigger = get_service('std_srvs/srv/Trigger')

    class Tuner(Node):
        def __init__(self, **kwargs):
            super().__init__('tuner', namespace='/lab', **kwargs)
            self.declare_parameter('gain', 2.5, ParameterDescriptor(
                description='how loud', floating_point_range=[FloatingPointRange(0.0, 10.0, 0.0)]))
            self.declare_parameter('mode', 'calm', ParameterDescriptor(read_only=True))
            self.declare_parameter('tags', ['a', 'b'])
            self.declare_parameter('nested.level', 3)
            self.declare_parameter('extra', 'x', ParameterDescriptor(dynamic_typing=True))
            self.add_on_set_parameters_callback(self.on_set)
            self.resets = 0
            self.create_service(Trigger, '~/reset', self.reset)
            self.create_service(Trigger, '~/broken', lambda request, response: 1 / 0)

        def on_set(self, params):
            for p in params:
                if p.name == 'gain' and p.value == 7.0:
                    return SetParametersResult(successful=False, reason='seven is unlucky')
            return SetParametersResult(successful=True)

        def reset(self, request, response):
            self.resets += 1
            response.success = True
            response.message = f'reset {self.resets}'
            return response

    # A callback that raises ends spin_once, as in rclpy: this node's loop catches the broken service's
    # error and spins on, so the tests see a server that never answers one service and answers the others.
    rclpy.init(args=sys.argv[1:])
    node = Tuner()
    while rclpy.ok():
        try:
            rclpy.spin_once(node, timeout_sec=0.5)
        except ZeroDivisionError as err:
            node.get_logger().error(f'~/broken raised {err!r}; spinning on')
''')


@pytest.fixture(scope='module')
def tuner():
    yield from running_graph(TUNER, COMMANDS, lambda graph: '/lab/tuner/reset' in graph.services)


def cli(capsys, *argv):
    code = cli_main.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_param_list_get_and_describe(tuner, capsys):
    code, out, _ = cli(capsys, 'param', 'list', '/lab/tuner')
    assert code == 0 and out.splitlines() == ['  extra', '  gain', '  mode', '  nested.level', '  tags',
                                              '  use_sim_time']
    _, out, _ = cli(capsys, 'param', 'list', '--param-type', '--param-prefixes', 'nested')
    assert out.splitlines() == ['/lab/tuner:', '  nested.level (type: integer)']
    assert cli(capsys, 'param', 'get', 'lab/tuner', 'gain')[1] == 'Double value is: 2.5\n'
    assert cli(capsys, 'param', 'get', '/lab/tuner', 'tags', '--hide-type')[1] == "['a', 'b']\n"
    code, out, err = cli(capsys, 'param', 'get', '/lab/tuner', 'gian')
    assert code == 1 and out == '' and 'Parameter not set' in err
    _, out, _ = cli(capsys, 'param', 'describe', '/lab/tuner', 'gain', 'mode')
    assert out.splitlines() == ['Parameter name: gain', '  Type: double', '  Description: how loud', '  Constraints:',
                                '    Min value: 0.0', '    Max value: 10.0', 'Parameter name: mode', '  Type: string',
                                '  Constraints:', '    Read only: true']


def test_param_set_takes_effect_or_says_why_not(tuner, capsys):
    code, out, _ = cli(capsys, 'param', 'set', '/lab/tuner', 'gain', '4')  # an integer for a double: accepted
    assert (code, out) == (0, 'Set parameter successful\n')
    assert cli(capsys, 'param', 'get', '/lab/tuner', 'gain')[1] == 'Double value is: 4.0\n'
    code, _, err = cli(capsys, 'param', 'set', '/lab/tuner', 'mode', 'wild')
    assert code == 1 and err == "Setting parameter failed: parameter 'mode' cannot be set because it is read-only\n"
    code, _, err = cli(capsys, 'param', 'set', '/lab/tuner', 'gain', '7.0')
    assert code == 1 and err == 'Setting parameter failed: seven is unlucky\n'
    code, _, err = cli(capsys, 'param', 'set', '/lab/tuner', 'gain', '11.0')
    assert code == 1 and 'must be in [0.0, 10.0]' in err
    code, out, err = cli(capsys, 'param', 'set', '/lab/tuner', 'gain', '1.5', 'nested.level', 'deep')
    assert code == 1 and out == 'gain: Set parameter successful\n' and 'nested.level: Setting parameter failed' in err
    code, _, err = cli(capsys, 'param', 'set', '/lab/tuner', 'gain', '2.0', 'mode', 'x', '--atomic')
    assert code == 1 and err.startswith('Setting parameters atomically failed: ')
    assert cli(capsys, 'param', 'get', '/lab/tuner', 'gain')[1] == 'Double value is: 1.5\n'  # all or nothing
    code, _, err = cli(capsys, 'param', 'set', '/lab/tuner', 'gain')
    assert code == 1 and 'name value pairs' in err


def test_param_dump_load_and_delete(tuner, capsys, tmp_path):
    code, out, _ = cli(capsys, 'param', 'dump', '/lab/tuner')
    dumped = yaml.safe_load(out)
    assert code == 0 and dumped['/lab/tuner']['ros__parameters']['nested'] == {'level': 3}
    assert dumped['/lab/tuner']['ros__parameters']['tags'] == ['a', 'b']
    params = tmp_path / 'tuner.yaml'
    params.write_text('/**:\n  ros__parameters:\n    tags: [c]\n/lab/tuner:\n  ros__parameters:\n    nested:\n'
                      '      level: 5\n    mode: loud\n')
    code, out, err = cli(capsys, 'param', 'load', '/lab/tuner', str(params))
    assert code == 1 and out == 'Set parameter nested.level successful\n'
    assert err == "Set parameter mode failed: parameter 'mode' cannot be set because it is read-only\n"
    code, out, _ = cli(capsys, 'param', 'load', '/lab/tuner', str(params), '--use-wildcard')
    assert 'Set parameter tags successful' in out.splitlines()
    assert cli(capsys, 'param', 'get', '/lab/tuner', 'tags')[1] == "String values are: ['c']\n"
    assert cli(capsys, 'param', 'get', '/lab/tuner', 'nested.level')[1] == 'Integer value is: 5\n'
    assert cli(capsys, 'param', 'delete', '/lab/tuner', 'extra')[1] == 'Deleted parameter successfully\n'
    code, _, err = cli(capsys, 'param', 'delete', '/lab/tuner', 'gain')
    assert code == 1 and err == "Deleting parameter failed: cannot undeclare statically typed parameter 'gain'\n"


def test_unknown_node_is_a_clear_error(tuner, capsys):
    code, out, err = cli(capsys, 'param', 'list', '/lab/tunr')
    assert code == 1 and out == '' and "node '/lab/tunr' not found (did you mean '/lab/tuner'?)" in err


def test_service_list_type_find(tuner, capsys):
    code, out, _ = cli(capsys, 'service', 'list', '-t')
    lines = out.splitlines()
    assert code == 0 and '/lab/tuner/reset [std_srvs/srv/Trigger]' in lines
    assert '/lab/tuner/get_parameters [rcl_interfaces/srv/GetParameters]' in lines
    assert not any('_social_touch' in line for line in lines)  # the command's own node is hidden
    assert cli(capsys, 'service', 'list', '-c')[1].strip() == str(len(lines))
    assert cli(capsys, 'service', 'type', '/lab/tuner/reset')[1] == 'std_srvs/srv/Trigger\n'
    code, _, err = cli(capsys, 'service', 'type', '/lab/tuner/rest')
    assert code == 1 and "did you mean '/lab/tuner/reset'" in err
    assert cli(capsys, 'service', 'find', 'std_srvs/Trigger')[1] == '/lab/tuner/broken\n/lab/tuner/reset\n'


def test_service_call_prints_request_and_response(tuner, capsys):
    code, out, _ = cli(capsys, 'service', 'call', '/lab/tuner/reset', 'std_srvs/srv/Trigger')
    assert code == 0
    assert out.startswith('requester: making request: std_srvs.srv.Trigger_Request(structure_needs_at_least_one_'
                          'member=0)\n\nresponse:\nstd_srvs.srv.Trigger_Response(success=True, message=')
    code, out, _ = cli(capsys, 'service', 'call', '/lab/tuner/get_parameters', 'rcl_interfaces/srv/GetParameters',
                       '{names: [mode]}')
    assert code == 0 and "string_value='calm'" in out


def test_service_call_bad_input_is_a_clear_error(tuner, capsys):
    started = time.monotonic()
    code, _, err = cli(capsys, 'service', 'call', '/lab/nobody', 'std_srvs/srv/Trigger', '--timeout', '0.5')
    assert code == 1 and "service '/lab/nobody' is not available (waited 0.5 s)" in err
    assert time.monotonic() - started < 10
    code, _, err = cli(capsys, 'service', 'call', '/lab/tuner/broken', 'std_srvs/srv/Trigger', '--timeout', '1')
    assert code == 1 and "service '/lab/tuner/broken' did not answer within 1 s" in err  # its callback raised
    code, _, err = cli(capsys, 'service', 'call', '/lab/tuner/reset', 'std_srvs/srv/SetBool', '{dta: true}')
    assert code == 1 and "Failed to populate field: std_srvs/srv/SetBool_Request has no field 'dta'" in err
    code, _, err = cli(capsys, 'service', 'call', '/lab/tuner/reset', 'std_srvs/srv/Nope')
    assert code == 1 and "unknown service type 'std_srvs/srv/Nope'" in err
    # the broken server is alive and still answers the others
    assert cli(capsys, 'service', 'call', '/lab/tuner/reset', 'std_srvs/srv/Trigger')[0] == 0
