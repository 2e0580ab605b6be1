"""Starting launch plans in-process: class lookup, rclpy-style construction, spinning, clean shutdown.

The nodes here are small synthetic test nodes on the real runtime (touch_graph.runtime).
"""

import importlib.metadata
import os
import signal
import textwrap
from pathlib import Path

import pytest

from touch_graph.errors import LaunchError
from touch_graph.launch import LaunchRunner, NodeSpec, ParamValue, evaluate_launch, resolve_node_class
from touch_graph.launch.runner import entry_point_registry, source_tree_nodes
from touch_graph.messages import get_message
from touch_graph.runtime import Node, Parameter

FILES = Path(__file__).parent / 'launch_files'
Frame = get_message('PatchFrame')


class Talker(Node):
    """Publishes a counter on 'frame' every 'period' seconds."""

    def __init__(self, **kwargs):
        super().__init__('talker', **kwargs)
        self.period = self.declare_parameter('period', 0.1).value
        self.label = self.declare_parameter('label', 'none').value
        self.k = self.declare_parameter('gains.k', 0).value
        self.pub = self.create_publisher(Frame, 'frame', 10)
        self.sent = 0
        self.create_timer(self.period, self.tick)

    def tick(self):
        self.sent += 1
        self.pub.publish(Frame(sequence=self.sent))


class Listener(Node):
    """Records the sequence numbers arriving on 'input'."""

    def __init__(self, **kwargs):
        super().__init__('listener', **kwargs)
        self.seen = []
        self.create_subscription(Frame, 'input', lambda m: self.seen.append(m.sequence), 10)


class Recorder(Node):
    """Keeps the keyword arguments it was built with."""

    def __init__(self, **kwargs):
        self.kwargs = kwargs
        super().__init__('recorder', **kwargs)


REGISTRY = {('social_touch', 'talker'): Talker, ('social_touch', 'listener'): Listener,
            ('social_touch', 'recorder'): Recorder}


def by_name(runner):
    return {node.get_fully_qualified_name(): node for node in runner.nodes}


def test_a_multi_node_graph_from_yaml_with_namespaces_remaps_and_parameter_overrides():
    plan = evaluate_launch(FILES / 'graph.launch.yaml', {'robot': 'r2'}, environ={})
    with LaunchRunner(plan.nodes, registry=REGISTRY, sim_time=True) as runner:
        nodes = by_name(runner)
        assert sorted(nodes) == ['/r2/bear/driver', '/r2/listener']
        driver, listener = nodes['/r2/bear/driver'], nodes['/r2/listener']
        # launch-file value beats the file's 5.0; the file's other values arrive, nested names dotted
        assert (driver.period, driver.label, driver.k) == (0.1, 'from_file', 3)
        runner.spin(1.0)
        assert listener.seen == list(range(1, 11))  # 1 s of simulated time at 10 Hz, through the remap
        assert driver.pub.topic_name == '/touch/frame'
    assert not runner.context.ok() and runner.nodes == []


def test_a_launch_argument_changes_the_running_graph():
    plan = evaluate_launch(FILES / 'graph.launch.yaml', {'period': '0.25'}, environ={})
    with LaunchRunner(plan.nodes, registry=REGISTRY, sim_time=True) as runner:
        runner.spin(1.0)
        assert by_name(runner)['/teddy/listener'].seen == [1, 2, 3, 4]


def test_nodes_are_built_the_way_rclpy_component_containers_build_them():
    spec = NodeSpec('social_touch', 'recorder', 'rec', '/a', (ParamValue('gains', (1, 2)), ParamValue('x', 'y')),
                    (('in', '/b'),), 'f.yaml', 4, ros_args=('--log-level', 'debug'))
    with LaunchRunner([spec], registry=REGISTRY, sim_time=True) as runner:
        node = runner.nodes[0]
        assert node.kwargs['context'] is runner.context
        assert node.kwargs['cli_args'] == ['--ros-args', '-r', '__node:=rec', '-r', '__ns:=/a', '-r', 'in:=/b',
                                           '--log-level', 'debug']
        assert node.kwargs['parameter_overrides'] == [Parameter('gains', value=[1, 2]), Parameter('x', value='y')]
        assert node.get_fully_qualified_name() == '/a/rec'


def test_a_node_that_rejects_its_parameters_names_the_launch_file_and_line(tmp_path):
    plan = evaluate_launch(FILES / 'graph.launch.yaml', {'params': str(FILES / 'params' / 'talker_bad.yaml')},
                           environ={})
    listener_first = [plan.nodes[1], plan.nodes[0]]  # a started node must be stopped when a later one fails
    runner = LaunchRunner(listener_first, registry=REGISTRY, sim_time=True)
    with pytest.raises(LaunchError) as info:
        runner.start()
    error = info.value
    assert error.path == str((FILES / 'graph.launch.yaml').resolve()) and error.line == 11
    assert 'node /teddy/bear/driver (social_touch/talker) failed to start' in str(error)
    assert "talker_bad.yaml:4: parameter 'gains.k' of /teddy/bear/driver must be a" in str(error)
    assert "got string 'fast'" in str(error)
    assert error.__cause__ is not None
    assert not runner.context.ok() and runner.nodes == []


def spec(pkg='social_touch', exec_='talker'):
    return NodeSpec(pkg, exec_, None, None, (), (), 'demo.launch.yaml', 9)


@pytest.mark.parametrize(('pkg', 'exec_', 'fragments'), [
    ('social_touch', 'taker', ["package 'social_touch' has no executable 'taker' (did you mean 'talker'?)",
                               'available: listener, recorder, talker']),
    ('social_touh', 'talker', ["unknown package 'social_touh' (did you mean 'social_touch'?)"]),
])
def test_unknown_packages_and_executables(pkg, exec_, fragments):
    with pytest.raises(LaunchError) as info:
        resolve_node_class(spec(pkg, exec_), REGISTRY, Node)
    assert str(info.value).startswith('demo.launch.yaml:9: ')
    for fragment in fragments:
        assert fragment in str(info.value)


def test_registry_problems_are_launch_errors():
    with pytest.raises(LaunchError, match=r"no node executables are registered .* pip install -e \."):
        resolve_node_class(spec(), {}, Node)
    broken = importlib.metadata.EntryPoint('talker', 'no_such_module_xyz:Talker', 'social_touch.nodes')
    with pytest.raises(LaunchError, match=r"cannot load social_touch/talker \(no_such_module_xyz:Talker\): "
                                          'ModuleNotFoundError'):
        resolve_node_class(spec(), {('social_touch', 'talker'): broken}, Node)
    with pytest.raises(LaunchError, match='not a Node subclass'):
        resolve_node_class(spec(), {('social_touch', 'talker'): dict}, Node)
    loads = importlib.metadata.EntryPoint('talker', f'{__name__}:Talker', 'social_touch.nodes')
    assert resolve_node_class(spec(), {('social_touch', 'talker'): loads}, Node) is Talker


def test_classes_are_all_resolved_before_anything_starts():
    runner = LaunchRunner([spec(), spec('social_touch', 'nope')], registry=REGISTRY, sim_time=True)
    with pytest.raises(LaunchError, match="no executable 'nope'"):
        runner.start()
    assert runner.context is None


def test_source_tree_nodes_reads_the_node_group_of_pyproject(tmp_path):
    pyproject = tmp_path / 'pyproject.toml'
    pyproject.write_text(textwrap.dedent("""\
        [project.entry-points."social_touch.nodes"]
        talker = "test_launch_runner:Talker"
        odd = 3
        """))
    nodes = source_tree_nodes(pyproject)
    assert list(nodes) == [('social_touch', 'talker')]
    assert nodes[('social_touch', 'talker')].value == 'test_launch_runner:Talker'
    assert source_tree_nodes(tmp_path / 'missing.toml') == {}
    pyproject.write_text('[project\n')
    assert source_tree_nodes(pyproject) == {}
    assert isinstance(entry_point_registry(), dict)


def test_sigint_while_spinning_stops_cleanly_and_restores_the_handler():
    class Interrupter(Node):
        def __init__(self, **kwargs):
            super().__init__('interrupter', **kwargs)
            self.ticks = 0
            self.create_timer(0.5, self.tick)

        def tick(self):
            self.ticks += 1
            if self.ticks == 3:
                os.kill(os.getpid(), signal.SIGINT)

    before = signal.getsignal(signal.SIGINT)
    registry = {('social_touch', 'interrupter'): Interrupter}
    runner = LaunchRunner([spec('social_touch', 'interrupter')], registry=registry, sim_time=True)
    runner.start()
    node = runner.nodes[0]
    runner.spin()  # no duration: returns because of the signal
    assert node.ticks == 3
    assert signal.getsignal(signal.SIGINT) is before
    runner.shutdown()
    runner.shutdown()  # safe twice
    assert not runner.context.ok()


def test_a_second_signal_interrupts_at_once():
    class Stubborn(Node):
        def __init__(self, **kwargs):
            super().__init__('stubborn', **kwargs)
            self.create_timer(0.1, self.tick)

        def tick(self):
            os.kill(os.getpid(), signal.SIGTERM)
            os.kill(os.getpid(), signal.SIGTERM)

    before = signal.getsignal(signal.SIGTERM)
    runner = LaunchRunner([spec('social_touch', 'stubborn')], registry={('social_touch', 'stubborn'): Stubborn},
                          sim_time=True)
    with runner, pytest.raises(KeyboardInterrupt):
        runner.spin()
    assert signal.getsignal(signal.SIGTERM) is before
    assert not runner.context.ok()


def test_a_node_shutting_the_context_down_ends_the_spin():
    class Quitter(Node):
        def __init__(self, **kwargs):
            super().__init__('quitter', **kwargs)
            self.create_timer(0.2, self.context.shutdown)

    with LaunchRunner([spec('social_touch', 'quitter')], registry={('social_touch', 'quitter'): Quitter},
                      sim_time=True) as runner:
        runner.spin()
        assert not runner.context.ok()


def test_runner_arguments_are_checked():
    with pytest.raises(ValueError, match='rate applies to simulated time only'):
        LaunchRunner([], rate=2.0)
    with pytest.raises(ValueError, match='rate must be > 0'):
        LaunchRunner([], sim_time=True, rate=float('nan'))
    runner = LaunchRunner([], registry=REGISTRY, sim_time=True)
    with pytest.raises(LaunchError, match='spin\\(\\) before start\\(\\)'):
        runner.spin(1.0)
    with runner, pytest.raises(ValueError, match='duration must be >= 0'):
        runner.spin(-1.0)


def test_a_misspelt_launch_parameter_is_a_warning_with_file_and_line_or_an_error_when_strict(tmp_path, capsys):
    launch = tmp_path / 'typo.launch.yaml'
    launch.write_text("""launch:
- node:
    pkg: social_touch
    exec: bear_gestures
    name: bear_gestures
    namespace: bear
    param:
    - {name: treshold, value: 0.4}
""")
    plan = evaluate_launch(str(launch), {})
    runner = LaunchRunner(plan.nodes, sim_time=True)
    try:
        runner.start()
    finally:
        runner.shutdown()
    err = capsys.readouterr().err
    assert f'{launch}:8' in err and "'treshold'" in err and 'did you mean' in err
    strict = LaunchRunner(evaluate_launch(str(launch), {}).nodes, sim_time=True, strict_params=True)
    with pytest.raises(LaunchError, match='treshold'):
        strict.start()
