"""Parsing YAML launch files: the ROS 2 element set, and one clear error (file:line) for each mistake."""

import textwrap
from pathlib import Path

import pytest

from touch_graph.errors import ConfigError, LaunchError
from touch_graph.launch.parser import (
    ArgAction,
    GroupAction,
    IncludeAction,
    LetAction,
    NodeAction,
    PushNamespaceAction,
    Str,
    parse_launch_file,
)
from touch_graph.launch.substitutions import Text, literal_text

FILES = Path(__file__).parent / 'launch_files'


def write(tmp_path, text, name='scene.launch.yaml'):
    path = tmp_path / name
    path.write_text(textwrap.dedent(text))
    return path


def error_of(tmp_path, text, name='scene.launch.yaml'):
    path = write(tmp_path, text, name)
    with pytest.raises(LaunchError) as info:
        parse_launch_file(path)
    assert isinstance(info.value, ConfigError)
    assert info.value.path == str(path.resolve())
    return info.value


def test_the_scene_fixture_parses_into_typed_elements():
    launch = parse_launch_file(FILES / 'scene.launch.yaml')
    kinds = [type(a) for a in launch.actions]
    assert kinds == [ArgAction, ArgAction, ArgAction, LetAction, PushNamespaceAction, GroupAction, IncludeAction]
    robot = launch.actions[0]
    assert (robot.name, literal_text(robot.default), robot.description) == ('robot', 'teddy',
                                                                            'namespace of the whole robot')
    assert launch.actions[2].choices == ('true', 'false')
    group = launch.actions[5]
    assert group.scoped and group.forwarding
    driver = group.children[1]
    assert isinstance(driver, NodeAction) and driver.where.line == 20
    assert [p.where.line for p in driver.params] == [25, 26, 27, 28]
    assert driver.params[2].value == Str((Text('bearsim://'),))
    assert [c.value for c in driver.params[3].children] == [3, 1.5]
    assert launch.actions[6].condition.if_ is not None


def test_ros_spellings_are_accepted(tmp_path):
    path = write(tmp_path, """\
        launch:
        - arg: {name: mode, default: a, choice: [{value: a}, {value: b}]}
        - push-ros-namespace: {namespace: x}
        - push_ros_namespace: {namespace: y}
        - group: [{let: {name: k, value: v}}]
        - include: other.launch.yaml
        - node: {pkg: p, exec: e, output: log, args: '--flag 1', ros_args: '--log-level debug'}
        """)
    actions = parse_launch_file(path).actions
    assert actions[0].choices == ('a', 'b')
    assert isinstance(actions[3], GroupAction) and isinstance(actions[3].children[0], LetAction)
    assert isinstance(actions[4], IncludeAction) and actions[4].arguments == ()
    assert actions[5].output == 'log'


def test_an_empty_launch_list_is_fine(tmp_path):
    assert parse_launch_file(write(tmp_path, 'launch: []\n')).actions == ()
    assert parse_launch_file(write(tmp_path, 'launch:\n')).actions == ()


@pytest.mark.parametrize(('text', 'line', 'fragments'), [
    ("""\
        launch:
        - nod: {pkg: p, exec: e}
        """, 2, ["unknown element 'nod' (did you mean 'node'?)", 'supported: arg, let, include']),
    ("""\
        launch:
        - arg: {name: a}
        - timer: {period: 1}
        """, 3, ["ROS 2 launch element 'timer' is not supported by the in-process launcher"]),
    ("""\
        launch:
        - node:
            pkg: social_touch
            exec: bear_driver
            nmae: driver
        """, 5, ["unknown attribute 'nmae' of 'node' (did you mean 'name'?)", 'supported: pkg, exec, name']),
    ("""\
        launch:
        - node:
            pkg: social_touch
            exec: bear_driver
            launch-prefix: gdb -ex run --args
        """, 5, ["attribute 'launch-prefix' of 'node' is not supported", 'runs from its class']),
    ("""\
        launch:
        - node:
            pkg: social_touch
            exec: bear_driver
            respawn: [true]
        """, 5, ["'respawn' of 'node' must be a bool; got [True]"]),
    ("""\
        launch:
        - node:
          pkg: social_touch
          exec: bear_driver
        """, 2, ["each launch item is a mapping with one key", "'node', 'pkg', 'exec'", 'indent them']),
    ("""\
        launch:
        - node: {exec: bear_driver}
        """, 2, ["'node' needs 'pkg'"]),
    ("""\
        launch:
        - node: {pkg: p, exec: e, name: 12}
        """, 2, ["'name' of 'node' must be a string (quote it: '12'); got int 12"]),
    ("""\
        launch:
        - let:
            name: x
            value: $(var y
        """, 4, ["'value' of 'let'", "'$(var' is not closed"]),
    ("""\
        launch:
        - arg: {name: mode, choice: [{value: a}], choices: [a]}
        """, 2, ["has both 'choice' and 'choices'"]),
    ("""\
        launch:
        - arg:
            name: mode
            default: c
            choices: [a, b]
        """, 4, ["default 'c' of arg 'mode' is not one of its choices: a, b"]),
    ("""\
        launch:
        - arg: {name: n, choices: [1, 2]}
        """, 2, ["'choices' of 'arg' must be a non-empty list of strings (quote numbers"]),
    ("""\
        launch:
        - arg: {name: $(var x)}
        """, 2, ["'name' of 'arg' cannot use substitutions"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            param:
            - {name: a, value: 1, param: [{name: b, value: 2}]}
        """, 6, ["exactly one of 'value' or nested 'param'"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            param:
            - {name: a, value: 1, type: integer}
        """, 6, ["unknown param type 'integer' (did you mean 'int'?)"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            param:
            - name: a
              value: {b: 1}
        """, 7, ["a 'param' value cannot be a mapping", "gives 'group.x'"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            param:
            - {from: x.yaml, name: a}
        """, 6, ["a 'param' with 'from' (a parameter file) takes no other attributes; got name"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            param:
            - {value: 3}
        """, 6, ["'param' needs 'name'"]),
    ("""\
        launch:
        - node:
            pkg: p
            exec: e
            remap:
            - {from: a, too: b}
        """, 6, ["unknown attribute 'too' of 'remap' (did you mean 'to'?)"]),
    ("""\
        launch:
        - node: {pkg: p, exec: e, output: screeen}
        """, 2, ["'output' of 'node' must be one of screen, log, both"]),
    ("""\
        launch:
        - group: {scoped: 'yes', children: []}
        """, 2, ["'scoped' of 'group' must be true or false"]),
    ("""\
        launch:
        - group: {scoped: true}
        """, 2, ["'group' needs 'children'"]),
    ("""\
        launch:
        - include: {file: a.launch.yaml, arg: [{name: x}]}
        """, 2, ["'arg of include' needs attribute 'value'"]),
    ("""\
        launch:
        - node: {pkg: p, exec: e, if: true}
        """, 2, ["'if' of 'node' must be a string (quote it: 'True')"]),
    ("""\
        launch:
        - let: [a, b]
        """, 2, ["'let' must be a mapping of attributes (name, value, if, unless)"]),
    ("""\
        launch:
          node: {pkg: p, exec: e}
        """, 2, ["the elements of 'launch' must be a list"]),
    ("""\
        nodes: []
        """, 1, ["a launch file is a mapping with the single key 'launch' (launch: [...]); got 'nodes'"]),
    ("""\
        launch:
        - node: {pkg: p, exec: e
        """, 3, ['YAML syntax error']),
    ("""\
        launch:
        - node: {pkg: p, exec: e, pkg: q}
        """, 2, ["duplicate key 'pkg'"]),
])
def test_each_mistake_gives_one_clear_error_at_its_line(tmp_path, text, line, fragments):
    error = error_of(tmp_path, text)
    assert error.line == line, str(error)
    for fragment in fragments:
        assert fragment in error.bare_message, str(error)


def test_an_empty_file_and_a_missing_file(tmp_path):
    assert 'got an empty file' in str(error_of(tmp_path, ''))
    with pytest.raises(LaunchError, match='file not found'):
        parse_launch_file(tmp_path / 'missing.launch.yaml')


def test_python_and_xml_launch_files_are_refused_clearly(tmp_path):
    with pytest.raises(LaunchError, match=r'only YAML launch files .* need ros2 launch'):
        parse_launch_file(write(tmp_path, 'print(1)\n', name='demo.launch.py'))
