"""ROS 2 parameter files and -p values read by rcl's rules (the cases of rcl_yaml_param_parser's tests).

Each case restates, in our own files, a behaviour ros2/rcl's parser tests pin down: nested
namespace keys, wildcards, typing of plain/quoted/tagged scalars, special floats, repeated keys,
and the files rcl refuses.
"""

import math

import pytest
from hypothesis import given
from hypothesis import strategies as st

from touch_graph.errors import ConfigError, ParameterError
from touch_graph.runtime import Context, Node
from touch_graph.runtime.override_check import check_overrides
from touch_graph.runtime.param_yaml import ParameterOverrides, parse_parameter_value, parse_scalar, strtod, strtoll
from touch_graph.runtime.parameters import parse_ros_args


def read(text):
    return ParameterOverrides.from_file('p.yaml', text)


def values(text, key):
    return {name: v.value for name, v in read(text).nodes[key].items()}


def test_namespace_keys_above_ros__parameters_make_the_node_name():
    text = """\
robot:
  bear:
    bear_gestures:
      ros__parameters:
        subtype:
          threshold: 0.3
          window: {length: 20}
  skin_driver:
    ros__parameters: {rate_hz: 150}
/:
  monitor:
    ros__parameters: {verbose: true}
"""
    overrides = read(text)
    assert list(overrides.nodes) == ['/robot/bear/bear_gestures', '/robot/skin_driver', '/monitor']
    assert values(text, '/robot/bear/bear_gestures') == {'subtype.threshold': 0.3, 'subtype.window.length': 20}


def test_plain_scalars_are_typed_by_rcl_not_by_yaml():
    text = """\
n:
  ros__parameters:
    small: 1e-6        # YAML 1.1 (PyYAML) would say string
    clock: 1:30        # YAML 1.1 would say 90
    hex: 0x1F
    octal: 017         # strtoll base 0: octal, as in rcl
    eight: 08          # not octal, not decimal for strtoll: strtod reads 8.0
    yes_word: yes
    on_word: On
    tilde: ~           # not null for rcl: a string
    big: 99999999999999999999   # overflows int64: a double
    huge: 1e999        # overflows a double: a string
"""
    v = values(text, '/n')
    assert v == {'small': 1e-6, 'clock': '1:30', 'hex': 31, 'octal': 15, 'eight': 8.0, 'yes_word': True,
                 'on_word': True, 'tilde': '~', 'big': 1e20, 'huge': '1e999'}
    assert type(v['eight']) is float and type(v['big']) is float


def test_quoted_and_str_tagged_scalars_stay_strings():
    text = """\
n:
  ros__parameters:
    a: '7'
    b: "true"
    c: !!str 12.5
    list: [and, '7']
"""
    assert values(text, '/n') == {'a': '7', 'b': 'true', 'c': '12.5', 'list': ['and', '7']}


def test_tags_require_a_value_of_their_kind():
    text = """\
n:
  ros__parameters:
    b: !!bool off
    i: !!int -10
    f: !!float 1
    nan: !!float .nan
    unset: !!null null
"""
    v = values(text, '/n')
    assert v['b'] is False and v['i'] == -10 and v['f'] == 1.0 and type(v['f']) is float
    assert math.isnan(v['nan']) and v['unset'] is None
    for bad in ('!!bool eurt', '!!int 1.5', '!!float ten', '!!timestamp 2001-12-14'):
        with pytest.raises(ConfigError, match=r'p.yaml:3:'):
            read(f'n:\n  ros__parameters:\n    x: {bad}\n')


def test_special_floats_only_in_their_exact_spellings():
    text = """\
n:
  ros__parameters:
    words: [string, .nananan, .nAN, .infinf, .INf]
    numbers: [1.1, .nan, .NaN, .inf, +.Inf, -.INF]
"""
    v = values(text, '/n')
    assert v['words'] == ['string', '.nananan', '.nAN', '.infinf', '.INf']
    n = v['numbers']
    assert n[0] == 1.1 and math.isnan(n[1]) and math.isnan(n[2]) and n[3:] == [math.inf, math.inf, -math.inf]


def test_repeated_keys_merge_and_the_later_value_wins():
    text = """\
n:
  ros__parameters: {a: 1, b: 1}
/**:
  ros__parameters: {a: 5}
n:
  ros__parameters: {b: 2, c: 3}
"""
    overrides = read(text)
    assert list(overrides.nodes) == ['/n', '/**']
    assert values(text, '/n') == {'a': 1, 'b': 2, 'c': 3}
    # rclpy applies keys in the order they first appeared: /n, then /** (so a = 5 for /n).
    assert {k: v.value for k, (v, _) in overrides.for_node('/n').items()} == {'a': 5, 'b': 2, 'c': 3}


def test_merging_a_second_file_keeps_first_appearance_order():
    first = read('/**:\n  ros__parameters: {a: 1}\n/n:\n  ros__parameters: {a: 2}\n')
    first.merge(read('/**:\n  ros__parameters: {a: 3}\n'))
    assert first.for_node('/n')['a'][0].value == 2       # /n came after /** in the first file


@pytest.mark.parametrize('key, fqn, applies', [
    ('/**', '/a/b/c', True), ('/*', '/c', True), ('/*', '/a/c', False),
    ('/a/*', '/a/c', True), ('/a/*', '/a/b/c', False), ('/**/c', '/c', True), ('/**/c', '/a/b/c', True),
    ('/*/c', '/a/c', True), ('c', '/c', True), ('c', '/a/c', False), ('/a/c', '/a/c', True),
])
def test_wildcards_match_as_rclpy_matches(key, fqn, applies):
    text = f'{key}:\n  ros__parameters: {{x: 1}}\n'
    assert ('x' in read(text).for_node(fqn)) is applies


@pytest.mark.parametrize('text, problem', [
    ('ros__parameters:\n  a: 1\n', 'needs a node name'),                     # no node above it
    ('n:\n  ros__parameters:\n    a:\n', 'no value'),                         # a key without a value
    ('n:\n  params:\n    - a: 1\n', 'misspelt'),                              # a sequence where a node belongs
    ('n:\n  value: 3\n', 'misspelt'),                                         # a value before ros__parameters
    ('n:\n  ros__parameters:\n    a: &x 1\n    b: *x\n', 'aliases'),           # rcl refuses aliases
    ('n:\n  ros__parameters:\n    a: [1, 2.5]\n', 'one type'),                # mixed list
    ('n:\n  ros__parameters:\n    a: [[1]]\n', 'not lists'),
    ('n:\n  ros__parameters:\n    a: []\n', 'empty list'),
    ('/foo**:\n  ros__parameters: {a: 1}\n', 'invalid node name'),            # partial wildcards
    ('1n:\n  ros__parameters: {a: 1}\n', 'invalid node name'),
    ('n:\n  ros__parameters: {a: 1\n', 'YAML syntax'),
])
def test_files_rcl_refuses_are_errors_with_file_and_line(text, problem):
    with pytest.raises(ConfigError, match=problem) as err:
        read(text)
    assert str(err.value).startswith('p.yaml')


def test_ros_args_p_values_are_typed_the_same_way():
    args = parse_ros_args(['--ros-args', '-p', 'rate:=1e-6', '-p', 't:=1:30', '-p', "s:='on'", '-p', 'l:=[1, 2]'])
    assert args.params == [('rate', 1e-6), ('t', '1:30'), ('s', 'on'), ('l', [1, 2])]
    with pytest.raises(ParameterError, match='no value'):
        parse_ros_args(['--ros-args', '-p', 'rate:='])
    assert parse_parameter_value('"x"') == 'x'


def test_files_and_p_apply_in_argument_order(tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('/**:\n  ros__parameters: {a: 1}\n')
    ctx = Context('sim')
    ctx.init()
    try:
        later = Node('n', context=ctx, cli_args=['--ros-args', '--params-file', str(path), '-p', 'a:=2'])
        earlier = Node('m', context=ctx, cli_args=['--ros-args', '-p', 'a:=2', '--params-file', str(path)])
        assert later.declare_parameter('a', 0).value == 2 and earlier.declare_parameter('a', 0).value == 1
    finally:
        ctx.shutdown()


@given(st.integers(-(2 ** 63), 2 ** 63 - 1))
def test_every_int64_reads_back_as_written(value):
    assert parse_scalar(str(value)) == value and type(parse_scalar(str(value))) is int
    assert strtoll(hex(value)) == value


@given(st.floats(allow_nan=False, allow_infinity=False).filter(lambda x: x == 0 or abs(x) >= 2.2250738585072014e-308))
def test_every_normal_double_reads_back_exactly(value):
    text = repr(value)
    got = parse_scalar(text)
    assert got == value and (type(got) is float or float(text).is_integer())
    assert strtod(text) == value


class _Log:
    def __init__(self):
        self.lines = []

    def warning(self, text):
        self.lines.append(text)


def test_a_misspelt_parameter_is_reported_with_file_line_and_a_suggestion(tmp_path):
    path = tmp_path / 'p.yaml'
    path.write_text('/bear/gestures:\n  ros__parameters:\n    treshold: 0.4\n'
                    '/**:\n  ros__parameters:\n    use_sim_time: false\n    rate_hz: 5.0\n    colour: red\n')
    ctx = Context('sim')
    ctx.init(['--ros-args', '--params-file', str(path)])
    try:
        gestures = Node('gestures', namespace='bear', context=ctx)
        gestures.declare_parameter('threshold', 0.3)
        driver = Node('driver', namespace='bear', context=ctx)
        driver.declare_parameter('rate_hz', 10.0)
        log = _Log()
        found = check_overrides([gestures, driver], log)
        texts = [str(f) for f in found]
        assert texts[0] == (f"{path}:3: parameter 'treshold' is not declared by /bear/gestures "
                            "(did you mean 'threshold'?)")
        # /** reached both nodes; rate_hz is declared by one of them, colour by none
        assert len(found) == 2 and "'colour'" in texts[1] and '/bear/gestures, /bear/driver' in texts[1]
        assert len(log.lines) == 2 and 'strict-params' in log.lines[0]
        with pytest.raises(ParameterError, match=r'treshold.*\n.*colour'):
            check_overrides([gestures, driver], log, strict=True)
    finally:
        ctx.shutdown()


def test_nodes_that_allow_undeclared_parameters_take_every_override():
    ctx = Context('sim')
    ctx.init(['--ros-args', '-p', 'anything:=1'])
    try:
        node = Node('n', context=ctx, allow_undeclared_parameters=True)
        assert check_overrides([node], _Log()) == []
    finally:
        ctx.shutdown()
