"""Evaluating launch files: arguments, scopes, namespaces, includes, parameter values -> NodeSpecs."""

import textwrap
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from touch_graph.errors import LaunchError
from touch_graph.launch import NodeSpec, ParamFile, ParamValue, collect_arguments, evaluate_launch, prefix_namespace

FILES = Path(__file__).parent / 'launch_files'


def write(directory, name, text):
    path = directory / name
    path.write_text(textwrap.dedent(text))
    return path


def plan_of(tmp_path, text, arguments=None, **kwargs):
    return evaluate_launch(write(tmp_path, 'main.launch.yaml', text), arguments, environ={}, **kwargs)


def node(name='n', **attributes):
    """A one-line node element for launch files written in tests."""
    extra = ''.join(f', {key}: {value}' for key, value in attributes.items())
    return f'- node: {{pkg: social_touch, exec: fake, name: {name}{extra}}}'


def test_the_multi_file_scene_resolves_namespaces_remaps_and_parameters():
    plan = evaluate_launch(FILES / 'scene.launch.yaml', {'rate': '30.0', 'robot': 'r2'}, environ={})
    assert [n.full_name for n in plan.nodes] == ['/r2/bear/driver', '/r2/bear/subtype', '/r2/skin/driver']
    driver = plan.nodes[0]
    assert driver.params == (
        ParamFile((FILES / 'params' / 'bear.yaml').resolve()), ParamValue('rate', 30.0),
        ParamValue('port', 'bearsim://'), ParamValue('cutoffs.tickle', 3), ParamValue('cutoffs.pat', 1.5))
    assert driver.cli_args() == [
        '--ros-args', '-r', '__node:=driver', '-r', '__ns:=/r2/bear', '-r', 'frame:=/touch/bear_frame',
        '--params-file', str((FILES / 'params' / 'bear.yaml').resolve())]
    skin = plan.nodes[2]
    assert skin.file == str((FILES / 'skin.launch.yaml').resolve()) and skin.line == 3
    assert skin.params == (ParamValue('rows', 12), ParamValue('gains', (1.0, 2.5)))
    assert plan.values['with_skin'] == 'true'
    assert [a.name for a in plan.arguments] == ['robot', 'rate', 'with_skin', 'skin_ns']


def test_a_condition_removes_a_whole_include():
    plan = evaluate_launch(FILES / 'scene.launch.yaml', {'with_skin': 'false'}, environ={})
    assert [n.full_name for n in plan.nodes] == ['/teddy/bear/driver', '/teddy/bear/subtype']


def test_if_and_unless(tmp_path):
    quoted_eval = '"$(eval \\"\'$(var sim)\' == \'true\'\\")"'  # the usual ROS idiom, quoted for YAML
    plan = plan_of(tmp_path, f"""\
        launch:
        - arg: {{name: sim, default: 'true'}}
        {node('a', **{'if': '$(var sim)'})}
        {node('b', unless='$(var sim)')}
        {node('c', **{'if': quoted_eval})}
        {node('d', **{'if': '$(not $(var sim))'})}
        """)
    assert [n.name for n in plan.nodes] == ['a', 'c']
    with pytest.raises(LaunchError, match=r"main.launch.yaml:2: 'if' must evaluate to true/false/1/0 .*'maybe'"):
        plan_of(tmp_path, f"""\
            launch:
            {node('a', **{'if': 'maybe'})}
            """)


def test_scoped_group_restores_configurations_and_namespace_unscoped_does_not(tmp_path):
    plan = plan_of(tmp_path, f"""\
        launch:
        - let: {{name: tag, value: outer}}
        - group:
            children:
            - push_ros_namespace: {{namespace: inner}}
            - let: {{name: tag, value: inner}}
            {node('a', namespace='$(var tag)')}
        {node('b', namespace='$(var tag)')}
        - group:
            scoped: false
            children:
            - push_ros_namespace: {{namespace: leaked}}
            - let: {{name: tag, value: leaked}}
        {node('c', namespace='$(var tag)')}
        """)
    assert [n.full_name for n in plan.nodes] == ['/inner/inner/a', '/outer/b', '/leaked/leaked/c']


def test_group_without_forwarding_starts_empty_but_keeps(tmp_path):
    plan = plan_of(tmp_path, f"""\
        launch:
        - let: {{name: a, value: A}}
        - let: {{name: b, value: B}}
        - group:
            forwarding: false
            keep: [{{name: b, value: $(var b)}}]
            children:
            {node('x', namespace='$(var b)')}
        """)
    assert plan.nodes[0].namespace == '/B'
    with pytest.raises(LaunchError, match=r"main.launch.yaml:7: \$\(var a\): launch argument 'a' is not declared"):
        plan_of(tmp_path, """\
            launch:
            - let: {name: a, value: A}
            - group:
                forwarding: false
                keep: []
                children:
                - node: {pkg: p, exec: e, name: x,
                          namespace: $(var a)}
            """)


@pytest.mark.parametrize(('base', 'namespace', 'expected'), [
    (None, None, None), (None, 'a', '/a'), ('/r', 'a', '/r/a'), ('/r', '/abs', '/abs'), ('/', 'a', '/a'),
    ('/r', None, '/r'), ('r', 'a/', '/r/a'), ('/r/', 'a', '/r/a'), ('/r', '/', '/'),
])
def test_prefix_namespace_follows_launch_ros(base, namespace, expected):
    assert prefix_namespace(base, namespace) == expected


@settings(max_examples=100, deadline=None)
@given(st.lists(st.from_regex(r'[a-z_][a-z0-9_]{0,5}', fullmatch=True), min_size=1, max_size=4))
def test_pushed_namespaces_compose(tokens):
    ns = None
    for token in tokens:
        ns = prefix_namespace(ns, token)
    assert ns == '/' + '/'.join(tokens)


def test_include_passes_arguments_and_its_settings_stay_as_in_ros(tmp_path):
    write(tmp_path, 'child.launch.yaml', f"""\
        launch:
        - arg: {{name: side, description: which side}}
        - let: {{name: from_child, value: set_in_child}}
        {node('$(var side)_arm', namespace='arms')}
        """)
    plan = plan_of(tmp_path, f"""\
        launch:
        - include:
            file: $(dirname)/child.launch.yaml
            arg: [{{name: side, value: left}}]
        - include:
            file: $(dirname)/child.launch.yaml
            let: [{{name: side, value: right}}]
        {node('after', namespace='$(var from_child)')}
        """)
    # An include is not scoped in ROS 2: what the child sets is visible after it.
    assert [n.full_name for n in plan.nodes] == ['/arms/left_arm', '/arms/right_arm', '/set_in_child/after']
    assert plan.nodes[0].file.endswith('child.launch.yaml') and plan.nodes[2].file.endswith('main.launch.yaml')


def test_include_errors(tmp_path):
    write(tmp_path, 'needs.launch.yaml', """\
        launch:
        - arg: {name: side}
        """)
    with pytest.raises(LaunchError) as info:
        plan_of(tmp_path, """\
            launch:
            - include: {file: $(dirname)/needs.launch.yaml}
            """)
    assert info.value.path.endswith('needs.launch.yaml') and info.value.line == 2
    assert "'side' has no default and was not given; pass it from the include at" in str(info.value)
    with pytest.raises(LaunchError, match=r'main.launch.yaml:2: included launch file not found: nope.yaml'):
        plan_of(tmp_path, """\
            launch:
            - include: nope.yaml
            """)


def test_include_cycles_are_reported(tmp_path):
    write(tmp_path, 'a.launch.yaml', 'launch:\n- include: $(dirname)/b.launch.yaml\n')
    write(tmp_path, 'b.launch.yaml', 'launch:\n- include: $(dirname)/a.launch.yaml\n')
    with pytest.raises(LaunchError, match=r'include cycle: .*a.launch.yaml -> .*b.launch.yaml -> .*a.launch.yaml'):
        evaluate_launch(tmp_path / 'a.launch.yaml', environ={})


def test_arguments_required_choices_and_unknown_names(tmp_path):
    text = """\
        launch:
        - arg: {name: port, description: serial port URL}
        - arg: {name: mode, default: sim, choices: [sim, real]}
        """
    with pytest.raises(LaunchError, match=r"main.launch.yaml:2: launch argument 'port' is required .* port:=VALUE"):
        plan_of(tmp_path, text)
    assert plan_of(tmp_path, text, {'port': 'loop://'}).values['port'] == 'loop://'
    with pytest.raises(LaunchError, match=r"main.launch.yaml:3: launch argument 'mode' is 'rael' \(from the command "
                                          r"line\), not one of: sim, real"):
        plan_of(tmp_path, text, {'port': 'x', 'mode': 'rael'})
    with pytest.raises(LaunchError, match=r"unknown launch argument 'prot' \(did you mean 'port'\?\); this launch "
                                          r'file declares: port, mode'):
        plan_of(tmp_path, text, {'prot': 'x'})


def test_arguments_of_untaken_branches_and_includes_are_known(tmp_path):
    write(tmp_path, 'child.launch.yaml', "launch:\n- arg: {name: child_arg, default: '1'}\n")
    text = """\
        launch:
        - arg: {name: enabled, default: 'false'}
        - group:
            if: $(var enabled)
            children:
            - arg: {name: hidden, default: x}
        - include: {file: $(dirname)/child.launch.yaml, if: $(var enabled)}
        """
    declared, unresolved = collect_arguments(write(tmp_path, 'main.launch.yaml', text), environ={})
    assert [a.name for a in declared] == ['enabled', 'hidden', 'child_arg'] and unresolved == []
    plan = plan_of(tmp_path, text, {'hidden': 'y', 'child_arg': '2'})  # accepted although not visited
    assert plan.nodes == []


def test_show_args_lists_an_include_it_cannot_resolve(tmp_path):
    path = write(tmp_path, 'main.launch.yaml', 'launch:\n- include: $(env WHERE)/x.launch.yaml\n')
    declared, unresolved = collect_arguments(path, environ={})
    assert declared == [] and [w.line for w in unresolved] == [2]


@pytest.mark.parametrize(('value', 'type_', 'expected'), [
    ("'text'", None, 'text'), ("'42'", None, '42'), ('42', None, 42), ('0.5', None, 0.5), ('true', None, True),
    ('$(var n)', None, 7), ('$(var f)', None, 2.5), ('$(var s)', None, 'hello'), ('$(var b)', None, False),
    ("'[1, 2]'", None, '[1, 2]'), ('$(var lst)', None, (1, 2)), ('[1, 2.5]', None, (1.0, 2.5)),
    ('[a, b]', None, ('a', 'b')), ('[$(var n), 8]', None, (7, 8)), ('[true, false]', None, (True, False)),
    ('$(var n)', 'str', '7'), ("'7'", 'int', 7), ('$(var n)', 'float', 7.0), ('3', 'float', 3.0),
    ('$(var b)', 'bool', False), ('$(var lst)', 'list_of_float', (1.0, 2.0)), ('[1, 2]', 'list_of_str', None),
    ("'x'", 'yaml', 'x'), ('$(var n)', 'yaml', 7), ("''", None, ''), ('.nan', None, 'nan'),
])
def test_parameter_values_follow_launch_ros(tmp_path, value, type_, expected):
    typed = f', type: {type_}' if type_ else ''
    text = f"""\
        launch:
        - let: {{name: n, value: '7'}}
        - let: {{name: f, value: '2.5'}}
        - let: {{name: s, value: hello}}
        - let: {{name: b, value: 'false'}}
        - let: {{name: lst, value: '[1, 2]'}}
        - node:
            pkg: p
            exec: e
            param:
            - {{name: p, value: {value}{typed}}}
        """
    if expected is None:
        with pytest.raises(LaunchError, match=r"main.launch.yaml:11: param 'p' has type list_of_str"):
            plan_of(tmp_path, text)
        return
    got = plan_of(tmp_path, text).nodes[0].params[0].value
    if expected == 'nan':
        assert got != got
    else:
        assert got == expected and type(got) is type(expected)


@pytest.mark.parametrize(('param', 'fragment'), [
    ('{name: p, value: []}', "param 'p' is an empty list"),
    ('{name: p, value: [1, a]}', 'the items of a list must share one type'),
    ('{name: p, value: [true, 1]}', 'the items of a list must share one type'),
    ('{name: p, value: $(var m)}', "param 'p' is a dict after substitution"),
    ("{name: p, value: '$(var m)', type: int}", "param 'p' has type int but the value is dict"),
    ("{name: p, value: 'x', type: int}", "param 'p' has type int but the value is str 'x'"),
    ('{name: p, value: [1, 2], type: int}', "has type int but its value is a list; use type list_of_int"),
    ('{name: p, value: 1.5, type: int}', "has type int but the value is float 1.5"),
    ("{name: 'a..b', value: 1}", "invalid parameter name 'a..b'"),
    ('{from: $(dirname)/missing.yaml}', 'parameter file not found:'),
])
def test_bad_parameter_values_are_clear_errors_at_their_line(tmp_path, param, fragment):
    with pytest.raises(LaunchError) as info:
        plan_of(tmp_path, f"""\
            launch:
            - let: {{name: m, value: 'a: 1'}}
            - node:
                pkg: p
                exec: e
                param:
                - {param}
            """)
    assert info.value.line == 7 and fragment in str(info.value), str(info.value)


def test_node_names_namespaces_remaps_and_arguments_are_checked(tmp_path):
    cases = [
        (node('1bad'), "invalid node name '1bad'"),
        (node('ok', namespace="'a b'"), "invalid namespace '/a b'"),
        (node('ok', remap='[{from: frame, to: "bad topic"}]'), "remap 'to' 'bad topic' is not a valid ROS name"),
        (node('ok', args="'\"unclosed'"), "'args' of 'node' is not a valid argument list"),
        (node('ok') + '\n' + node('ok'), 'two nodes named /ok (the other at'),
        ("- node: {pkg: '$(optenv NOPE)', exec: e}", "'pkg' and 'exec' of 'node' must not be empty"),
    ]
    for element, fragment in cases:
        with pytest.raises(LaunchError) as info:
            plan_of(tmp_path, f'launch:\n{element}\n')
        assert fragment in str(info.value), str(info.value)
        assert info.value.line in (2, 3)


def test_cli_args_of_a_node_spec():
    spec = NodeSpec('social_touch', 'fake', 'n', '/ns', (ParamValue('a', 1), ParamFile(Path('/p.yaml'))),
                    (('x', '/y'),), 'f.yaml', 3, args=('--verbose',), ros_args=('--log-level', 'debug'))
    assert spec.cli_args() == ['--verbose', '--ros-args', '-r', '__node:=n', '-r', '__ns:=/ns', '-r', 'x:=/y',
                               '--params-file', '/p.yaml', '--log-level', 'debug']
    bare = NodeSpec('social_touch', 'fake', None, None, (), (), 'f.yaml', 3)
    assert bare.cli_args() == [] and bare.full_name is None
    assert 'social_touch/fake' in bare.describe()


def test_args_and_ros_args_are_split_like_a_shell(tmp_path):
    plan = plan_of(tmp_path, """\
        launch:
        - node: {pkg: p, exec: e, args: "--scene 'two words' -v", ros_args: '--log-level debug'}
        """)
    assert plan.nodes[0].args == ('--scene', 'two words', '-v')
    assert plan.nodes[0].cli_args()[-3:] == ['--ros-args', '--log-level', 'debug']


def test_find_pkg_share_and_env_resolve_through_the_given_lookups(tmp_path):
    (tmp_path / 'share' / 'config').mkdir(parents=True)
    (tmp_path / 'share' / 'config' / 'p.yaml').write_text('/**:\n  ros__parameters: {a: 1}\n')
    plan = plan_of(tmp_path, """\
        launch:
        - node:
            pkg: social_touch
            exec: e
            name: $(env NAME default_name)
            param: [{from: $(find-pkg-share social_touch)/config/p.yaml}]
        """, find_package_share=lambda pkg: tmp_path / 'share')
    assert plan.nodes[0].name == 'default_name'
    assert plan.nodes[0].parameter_files() == [(tmp_path / 'share' / 'config' / 'p.yaml').resolve()]


def test_describe_names_everything_needed_to_check_a_scene():
    text = evaluate_launch(FILES / 'scene.launch.yaml', environ={}).describe()
    for fragment in ('nodes (3):', '/teddy/bear/driver  (social_touch/bear_driver)', 'scene.launch.yaml:20]',
                     "param port = 'bearsim://'", 'remap frame -> /touch/bear_frame', "rate = '25.0'"):
        assert fragment in text
