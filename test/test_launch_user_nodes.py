"""Users' own nodes in launch files (module paths, rclpy's constructor) and config files as launch arguments."""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from touch_graph import paths
from touch_graph.errors import LaunchError
from touch_graph.launch import LaunchRunner, evaluate_launch
from touch_graph.launch.preflight import check_config_files
from touch_graph.launch.runner import entry_point_registry, takes_node_arguments

USER_MODULE = '''
from touch_graph.compat import Node


class Greeter(Node):
    """rclpy's shape: no arguments, the name given to super().__init__."""

    def __init__(self):
        super().__init__('greeter')
        self.greeting = self.declare_parameter('greeting', 'hello').value
        self.inner = None


class Outer(Node):
    """Makes a helper node inside its constructor: only the outer node takes the launch's arguments."""

    def __init__(self):
        super().__init__('outer')
        self.helper = Node('helper', context=self.context)


class NotCallingSuper(Node):
    def __init__(self):
        pass
'''


@pytest.fixture
def user_module(tmp_path, monkeypatch):
    package = tmp_path / 'my_behaviours'
    package.mkdir()
    (package / '__init__.py').write_text('')
    (package / 'greeting.py').write_text(USER_MODULE)
    monkeypatch.syspath_prepend(str(tmp_path))
    yield 'my_behaviours.greeting'
    for name in [n for n in sys.modules if n.startswith('my_behaviours')]:
        del sys.modules[name]


def launch_file(tmp_path: Path, body: str) -> Path:
    path = tmp_path / 'user.launch.yaml'
    path.write_text('launch:\n' + textwrap.indent(textwrap.dedent(body), ''))
    return path


def run_plan(path: Path, arguments=None):
    plan = evaluate_launch(path, arguments or {})
    runner = LaunchRunner(plan.nodes, sim_time=True, network=False)
    runner.start()
    return runner


@pytest.mark.parametrize('entry', ['pkg: my_behaviours.greeting\n            exec: Greeter',
                                   'pkg: anything\n            exec: "my_behaviours.greeting:Greeter"'])
def test_an_rclpy_style_node_runs_from_a_module_path_with_the_launch_files_name_namespace_and_parameters(
        tmp_path, user_module, entry) -> None:
    path = launch_file(tmp_path, f'''\
        - node:
            {entry}
            name: hello
            namespace: robot
            param: [{{name: greeting, value: hi there}}]
        ''')
    runner = run_plan(path)
    try:
        (node,) = runner.nodes
        assert type(node).__name__ == 'Greeter' and node.get_fully_qualified_name() == '/robot/hello'
        assert node.greeting == 'hi there' and node.context is runner.context
        runner.spin(0.2)
    finally:
        runner.shutdown()


def test_only_the_outer_node_takes_the_launch_arguments(tmp_path, user_module) -> None:
    path = launch_file(tmp_path, '''\
        - node: {pkg: my_behaviours.greeting, exec: Outer, name: renamed}
        ''')
    runner = run_plan(path)
    try:
        (node,) = runner.nodes
        assert node.get_name() == 'renamed' and node.helper.get_name() == 'helper'
    finally:
        node.helper.destroy_node()
        runner.shutdown()


@pytest.mark.parametrize('entry, message', [
    ('{pkg: my_behaviours.greeting, exec: Greter}', "no class 'Greter' (did you mean 'Greeter'?)"),
    ('{pkg: my_behaviours.greeting, exec: NotCallingSuper}', 'made no node of this graph'),
    ('{pkg: x, exec: "my_behaviours.nothing:Greeter"}', 'cannot import my_behaviours.nothing'),
])
def test_user_node_mistakes_name_the_launch_line(tmp_path, user_module, entry, message) -> None:
    path = launch_file(tmp_path, f'- node: {entry}\n')
    with pytest.raises(LaunchError, match=re.escape(message)) as info:
        run_plan(path)
    assert f'{path}:2' in str(info.value)


def test_which_constructor_shape_a_class_has() -> None:
    class Plain:
        def __init__(self):
            pass

    class Keywords:
        def __init__(self, **kwargs):
            pass

    class Explicit:
        def __init__(self, *, context=None, cli_args=None, parameter_overrides=None):
            pass
    assert not takes_node_arguments(Plain)
    assert takes_node_arguments(Keywords) and takes_node_arguments(Explicit)


def test_every_shipped_node_is_found_by_its_package_name() -> None:
    registry = entry_point_registry()
    assert {('social_touch', 'touch_state'), ('social_touch', 'bear_sensor_frames')} <= set(registry)


# ---------------------------------------------------------------------- config files as launch arguments
DEMO = Path(__file__).resolve().parents[1] / 'launch' / 'demo.launch.yaml'


@pytest.mark.parametrize('argument', ['gestures', 'body_map', 'panels', 'commands', 'codebook'])
def test_every_config_file_is_a_launch_argument_of_the_demo(tmp_path, argument) -> None:
    suffix = '.npz' if argument == 'codebook' else '.yaml'
    path = tmp_path / f'mine{suffix}'
    path.write_text('x')
    plan = evaluate_launch(DEMO, {argument: str(path)})
    given = [(spec.full_name, p.name) for spec in plan.nodes for p in spec.parameter_values() if p.value == str(path)]
    assert given and all(name == argument for _, name in given)


def test_a_missing_or_broken_config_file_is_one_error_naming_file_and_line_before_any_node(tmp_path) -> None:
    missing = evaluate_launch(DEMO, {'gestures': str(tmp_path / 'nope.yaml')})
    with pytest.raises(LaunchError, match=r"bear\.launch\.yaml:\d+: parameter 'gestures' of /bear/bear_gestures: "
                                          'no such file'):
        check_config_files(missing.nodes)
    broken = tmp_path / 'broken.yaml'
    broken.write_text('gestures:\n  hug: {regions: [torso_front\n  tickle: {}\n')
    plan = evaluate_launch(DEMO, {'body_map': str(broken)})
    with pytest.raises(LaunchError, match=rf'{broken}:3: YAML syntax error'):
        check_config_files(plan.nodes)
    codebook = tmp_path / 'codebook.npz'
    codebook.write_text('not a zip')
    with pytest.raises(LaunchError, match=r"parameter 'codebook' .* cannot read .* as an \.npz archive"):
        check_config_files(evaluate_launch(DEMO, {'codebook': str(codebook)}).nodes)


def test_the_launch_command_stops_before_starting_anything_on_a_broken_config_file(tmp_path) -> None:
    broken = tmp_path / 'gestures.yaml'
    broken.write_text('a: [1,\n')
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', str(DEMO),
                             f'gestures:={broken}', '--sim-time', '--no-network', '--duration', '1'],
                            capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert result.returncode != 0
    errors = [line for line in result.stderr.splitlines() if 'error' in line]
    assert len(errors) == 1 and f'{broken}:2' in errors[0] and 'bear.launch.yaml' in errors[0]
    assert 'node(s) running' not in result.stderr


def test_the_demo_checks_its_config_arguments_too(tmp_path) -> None:
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'demo', '--fast', '--duration', '1',
                             f'commands:={tmp_path / "mine.yaml"}'], capture_output=True, text=True, timeout=120,
                            cwd=tmp_path)
    assert result.returncode != 0 and "parameter 'commands' of /skin/haptic_commands: no such file" in result.stderr
    assert 'nodes, 1 s of a simulated scene' not in result.stderr


def test_a_node_logs_the_config_files_it_loaded(tmp_path) -> None:
    gestures = tmp_path / 'my_gestures.yaml'
    gestures.write_text((Path(__file__).resolve().parents[1] / 'config' / 'bear_gestures.yaml').read_text())
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', str(DEMO),
                             f'gestures:={gestures}', 'use_patch:=false', 'use_skin:=false', '--sim-time',
                             '--no-network', '--duration', '0.5'], capture_output=True, text=True, timeout=180,
                            cwd=tmp_path)
    assert result.returncode == 0, result.stderr
    assert f'gestures {gestures}' in result.stderr and 'body map ' in result.stderr


# ---------------------------------------------------------------------- the checkout's config/
def fake_checkout(root: Path) -> Path:
    (root / 'config').mkdir(parents=True)
    (root / 'launch').mkdir()
    (root / 'package.xml').write_text('<package format="3"><name>social_touch</name></package>\n')
    return root


def no_checkout(monkeypatch) -> None:
    """Unset the checkout variable for the test and restore it after (also when the test sets it)."""
    monkeypatch.setenv(paths.CHECKOUT_ENV, '')
    monkeypatch.delenv(paths.CHECKOUT_ENV)


def test_inside_a_checkout_its_config_and_launch_replace_the_installed_ones(tmp_path, monkeypatch) -> None:
    no_checkout(monkeypatch)
    checkout = fake_checkout(tmp_path / 'st')
    (checkout / 'src').mkdir()
    assert paths.find_checkout(checkout / 'src') == checkout
    chosen, installed = paths.prefer_checkout(checkout / 'src')
    assert chosen == checkout and installed == paths.package_share()
    assert os.environ[paths.CHECKOUT_ENV] == str(checkout)
    assert paths.share_file('config', 'bear_gestures.yaml') == checkout / 'config' / 'bear_gestures.yaml'
    assert paths.launch_share('social_touch') == checkout
    assert paths.share_file('msg', 'SkinFrame.msg') == paths.package_share() / 'msg' / 'SkinFrame.msg'


def test_outside_a_checkout_or_in_the_installed_one_nothing_changes(tmp_path, monkeypatch) -> None:
    no_checkout(monkeypatch)
    assert paths.find_checkout(tmp_path) is None
    assert paths.prefer_checkout(tmp_path)[0] is None and paths.CHECKOUT_ENV not in os.environ
    assert paths.prefer_checkout(paths.package_share())[0] is None   # an editable install reads it already
    (tmp_path / 'package.xml').write_text('<package><name>other_pkg</name></package>')
    (tmp_path / 'config').mkdir()
    assert paths.find_checkout(tmp_path) is None


def test_the_launch_command_says_it_uses_the_checkout(tmp_path) -> None:
    checkout = fake_checkout(tmp_path / 'st')
    (checkout / 'launch' / 'one.launch.yaml').write_text(
        'launch:\n- node: {pkg: social_touch, exec: touch_state, name: from_checkout}\n')
    env = {k: v for k, v in os.environ.items() if k != paths.CHECKOUT_ENV}
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'launch', 'social_touch', 'one.launch.yaml',
                             '--print-description'], capture_output=True, text=True, timeout=120, cwd=checkout,
                            env=env)
    assert result.returncode == 0, result.stderr
    assert f'inside the checkout {checkout}: its config/ and launch/ are used' in result.stderr
    assert '/from_checkout' in result.stdout


def test_the_demo_reads_the_checkouts_launch_file_too(tmp_path) -> None:
    checkout = fake_checkout(tmp_path / 'st')
    shutil.copytree(paths.package_share() / 'config', checkout / 'config', dirs_exist_ok=True)
    (checkout / 'launch' / 'demo.launch.yaml').write_text(
        'launch:\n- node: {pkg: social_touch, exec: touch_state, name: from_checkout}\n')
    env = {k: v for k, v in os.environ.items() if k != paths.CHECKOUT_ENV}
    env['SOCIAL_TOUCH_GRAPH_DIR'] = str(tmp_path / 'graph')
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'demo', '--fast', '--duration', '1'],
                            capture_output=True, text=True, timeout=120, cwd=checkout, env=env)
    assert result.returncode == 0, result.stderr
    assert f'[demo] inside the checkout {checkout}: its config/ and launch/ are used' in result.stderr
    assert 'social_touch demo: 1 nodes' in result.stderr      # the checkout's one-node scene, not the package's
