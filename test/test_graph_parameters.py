"""Node parameters: declarations, overrides from files/launch/-p, type errors that name the source."""

import pytest

from touch_graph.errors import ConfigError, ParameterError
from touch_graph.runtime import (
    Context,
    FloatingPointRange,
    InvalidParameterValueException,
    Node,
    Parameter,
    ParameterDescriptor,
    ParameterNotDeclaredException,
    SetParametersResult,
)
from touch_graph.runtime.param_yaml import pattern_matches
from touch_graph.runtime.parameters import load_parameter_file, parse_ros_args


@pytest.fixture
def ctx():
    context = Context('sim')
    context.init()
    yield context
    context.try_shutdown()


PARAMS = """\
/bear/subtype:
  ros__parameters:
    alpha: 0.4
    window: 20
    cutoffs:
      tickle: 3
/**:
  ros__parameters:
    frame_id: bear_link
other:
  ros__parameters:
    alpha: 9.0
"""


def test_file_overrides_match_by_name_and_wildcard(ctx, tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text(PARAMS)
    node = Node('subtype', namespace='bear', context=ctx, cli_args=['--ros-args', '--params-file', str(path)])
    assert node.declare_parameter('alpha', 0.3).value == 0.4
    assert node.declare_parameter('window', 10).value == 20
    assert node.declare_parameter('cutoffs.tickle', 2.5).value == 3.0  # int accepted for a double
    assert node.declare_parameter('frame_id', 'x').value == 'bear_link'
    assert node.declare_parameter('beta', 1.5).value == 1.5


def test_wrong_type_in_a_file_names_file_line_and_parameter(ctx, tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('subtype:\n  ros__parameters:\n    window: twenty\n')
    node = Node('subtype', context=ctx, cli_args=['--ros-args', '--params-file', str(path)])
    with pytest.raises(ParameterError) as err:
        node.declare_parameter('window', 20)
    text = str(err.value)
    assert f'{path}:3' in text and "'window'" in text and 'integer' in text and "'twenty'" in text


def test_malformed_parameter_files_are_config_errors(tmp_path):
    bad = tmp_path / 'bad.yaml'
    bad.write_text('node:\n  ros_parameters:\n    a: 1\n')
    with pytest.raises(ConfigError, match='ros__parameters'):
        load_parameter_file(bad)
    bad.write_text('node:\n  ros__parameters:\n    a: [1, x]\n')
    with pytest.raises(ConfigError, match=r':3:.*one type'):
        load_parameter_file(bad)
    with pytest.raises(ConfigError, match='file not found'):
        load_parameter_file(tmp_path / 'missing.yaml')


def test_precedence_overrides_beat_cli_beat_files(ctx, tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('n:\n  ros__parameters:\n    a: 1\n    b: 1\n    c: 1\n')
    node = Node('n', context=ctx, cli_args=['--ros-args', '--params-file', str(path), '-p', 'b:=2', '-p', 'c:=2'],
                parameter_overrides=[Parameter('c', value=3)])
    assert [node.declare_parameter(k, 0).value for k in 'abc'] == [1, 2, 3]


def test_ranges_read_only_and_set_callbacks(ctx):
    node = Node('n', context=ctx, parameter_overrides=[Parameter('threshold', value=1.5)])
    in_unit = ParameterDescriptor(floating_point_range=[FloatingPointRange(0.0, 1.0)])
    with pytest.raises(ParameterError, match=r'must be in \[0.0, 1.0\]'):
        node.declare_parameter('threshold', 0.3, in_unit)
    node.declare_parameter('gain', 0.3, ParameterDescriptor(floating_point_range=[FloatingPointRange(0.0, 1.0)]))
    node.declare_parameter('port', '/dev/ttyACM0', ParameterDescriptor(read_only=True))
    seen = []

    def veto(params):
        seen.extend(p.name for p in params)
        return SetParametersResult(successful=all(p.value != 0.5 for p in params), reason='0.5 is unlucky')
    node.add_on_set_parameters_callback(veto)
    ok, out_of_range, wrong_type, vetoed, read_only = node.set_parameters([
        Parameter('gain', value=0.7), Parameter('gain', value=2.0), Parameter('gain', value='high'),
        Parameter('gain', value=0.5), Parameter('port', value='x')])
    assert ok.successful and node.get_parameter('gain').value == 0.7
    assert not out_of_range.successful and 'must be in' in out_of_range.reason
    assert not wrong_type.successful and 'double' in wrong_type.reason
    assert not vetoed.successful and vetoed.reason == '0.5 is unlucky'
    assert not read_only.successful and 'read-only' in read_only.reason
    with pytest.raises(ParameterNotDeclaredException, match='gain'):
        node.get_parameter('gian')


def test_declaring_runs_the_set_callbacks_with_each_parameter_as_rclpy_does(ctx):
    # rclpy's declare_parameter(s) is a set: every on-set callback sees each parameter as it is declared
    # (the override's value, not yet declared), a refusal raises and leaves it undeclared, a raise propagates.
    node = Node('n', context=ctx, parameter_overrides=[Parameter('b', value=5)])
    seen = []

    def only_small(params):
        seen.append([(p.name, p.value, node.has_parameter(p.name)) for p in params])
        return SetParametersResult(successful=all(p.value < 10 for p in params), reason='too big')
    node.add_on_set_parameters_callback(only_small)
    node.declare_parameters('', [('a', 1), ('b', 2)])
    assert seen == [[('a', 1, False)], [('b', 5, False)]]
    with pytest.raises(InvalidParameterValueException, match=r"Invalid parameter value \(12\) for parameter. "
                                                             r"Reason: too big \(parameter 'c'\)"):
        node.declare_parameter('c', 12)
    assert not node.has_parameter('c')
    node.add_on_set_parameters_callback(lambda params: 1 / 0)
    with pytest.raises(ZeroDivisionError):
        node.declare_parameter('d', 1)
    assert not node.has_parameter('d')


def test_node_matching_rules():
    assert pattern_matches('/**', '/x/y/a')
    assert pattern_matches('/**/a', '/a') and pattern_matches('/**/a', '/x/y/a')
    assert not pattern_matches('/x/*', '/x/y/a')
    assert pattern_matches('/x/*/a', '/x/y/a')


def test_ros_args_parsing_errors():
    args = parse_ros_args(['prog', '--ros-args', '-r', 'a:=b', '-p', 'x:=[1, 2]', '--log-level', 'debug'])
    assert args.remaps == ['a:=b'] and args.params == [('x', [1, 2])] and args.log_level == 'debug'
    with pytest.raises(ParameterError, match='unknown argument'):
        parse_ros_args(['--ros-args', '--bogus'])
    with pytest.raises(ParameterError, match='name:=value'):
        parse_ros_args(['--ros-args', '-p', 'x=1'])


def test_an_empty_list_default_takes_the_descriptor_type(ctx):
    from touch_graph.runtime import ParameterType
    node = Node('n', context=ctx, parameter_overrides=[Parameter('other', value=['a'])])
    topics = node.declare_parameter('topics', [], ParameterDescriptor(type=ParameterType.STRING_ARRAY))
    assert topics.value == [] and topics.type_ == ParameterType.STRING_ARRAY
    assert node.declare_parameter('other', [], ParameterDescriptor(type=ParameterType.STRING_ARRAY)).value == ['a']
