"""``social-touch topic`` and ``node`` against a graph running in another process, over DDS."""

import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import pytest
from dds_testing import allocate_domain

from touch_graph.cli import main as cli_main
from touch_graph.dds.tool import GraphTool

REPO = Path(__file__).resolve().parent.parent
# The lines these commands take in touch_graph/cli/main.py's COMMANDS table.
GRAPH_COMMANDS = {
    'topic': ('touch_graph.cli.topic', 'topics of the running graph: list, echo, hz, info, pub'),
    'node': ('touch_graph.cli.node', 'nodes of the running graph: list, info'),
    'record': ('touch_graph.cli.record', 'record topics of the running graph to a rosbag2 (MCAP)'),
    'play': ('touch_graph.cli.play', 'replay a rosbag2 into the running graph with its recorded timing'),
    'bag': ('touch_graph.cli.bag', 'bag info, bag reindex (recover a bag whose recorder died)'),
}
CLI = f'import sys\nfrom touch_graph.cli import main\nmain.COMMANDS.update({GRAPH_COMMANDS!r})\nsys.exit(main.main())\n'

GRAPH = textwrap.dedent('''
    import sys
    import numpy as np
    from touch_graph.compat import Node, get_message
    from touch_graph.node_main import run_node
    String = get_message('std_msgs/msg/String')
    PatchFrame = get_message('PatchFrame')

    class Demo(Node):
        """Hello at 50 Hz on /chatter, a patch frame at 5 Hz, and an echo of /cmd on /cmd_echo."""

        def __init__(self, **kwargs):
            super().__init__('demo_talker', **kwargs)
            self.pub = self.create_publisher(String, '/chatter', 10)
            self.patch = self.create_publisher(PatchFrame, '/patch/frame', 10)
            self.echo = self.create_publisher(String, '/cmd_echo', 10)
            self.create_subscription(String, '/cmd', lambda m: self.echo.publish(String(data='echo ' + m.data)), 10)
            self.n = 0
            self.create_timer(0.02, self.tick)
            self.create_timer(0.2, lambda: self.patch.publish(PatchFrame(activation=np.full(256, 0.5, np.float32))))

        def tick(self):
            self.pub.publish(String(data=f'hello {self.n}'))
            self.n += 1

    sys.exit(run_node(Demo, sys.argv[1:]))
''')


def wait_until(predicate, timeout_s=20.0, what='condition'):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.05)
    raise AssertionError(f'timed out after {timeout_s} s waiting for {what}')


def graph_env(domain):
    """The environment of the test's graph: its own DDS domain, discovery on this host only."""
    env = {k: v for k, v in os.environ.items() if k not in ('SOCIAL_TOUCH_NETWORK', 'ROS_STATIC_PEERS',
                                                             'CYCLONEDDS_URI', 'ROS_DISTRO')}
    return {**env, 'ROS_DOMAIN_ID': str(domain), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST'}


def running_graph(script=GRAPH, commands=GRAPH_COMMANDS, ready=lambda graph: '/patch/frame' in graph.topics):
    """A node process (run_node of ``script``) in a DDS domain of its own, the CLI's ``commands`` registered
    for the test, until ``ready(graph view)``; yields a directory for scripts."""
    path = Path(tempfile.mkdtemp(prefix='stc', dir='/tmp'))
    (path / 'graph.py').write_text(script)
    (path / 'cli.py').write_text(CLI)
    with allocate_domain() as domain:
        env = graph_env(domain)
        patch = pytest.MonkeyPatch()
        for key in ('ROS_DOMAIN_ID', 'ROS_AUTOMATIC_DISCOVERY_RANGE'):
            patch.setenv(key, env[key])
        for key in ('ROS_STATIC_PEERS', 'CYCLONEDDS_URI', 'ROS_DISTRO'):
            patch.delenv(key, raising=False)
        patch.setattr(cli_main, 'COMMANDS', {**cli_main.COMMANDS, **commands})
        proc = subprocess.Popen([sys.executable, str(path / 'graph.py')], cwd=REPO, stderr=subprocess.DEVNULL,
                                env=env)
        try:
            def is_ready():
                with GraphTool('probe', discovery_timeout_s=1.0) as tool:
                    return ready(tool.graph())
            wait_until(is_ready, what='the graph process')
            yield path
        finally:
            proc.send_signal(signal.SIGTERM)
            proc.wait(10)
            patch.undo()
            shutil.rmtree(path, ignore_errors=True)


@pytest.fixture(scope='module')
def graph():
    """The graph process, shared by the tests of a module."""
    yield from running_graph()


def cli(capsys, *argv):
    code = cli_main.main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def test_no_graph_is_a_clear_error(capsys, monkeypatch, dds_domain):
    monkeypatch.setattr(cli_main, 'COMMANDS', {**cli_main.COMMANDS, **GRAPH_COMMANDS})
    for argv in (['topic', 'list'], ['node', 'list'], ['topic', 'echo', '/x'], ['topic', 'hz', '/x']):
        code, out, err = cli(capsys, *argv)
        assert code == 1 and out == ''
        assert f'no ROS 2 graph is running in DDS domain {dds_domain}' in err and 'social-touch launch' in err


def test_topic_list_and_info(graph, capsys):
    code, out, _ = cli(capsys, 'topic', 'list')
    # as ros2 topic list shows them: every node publishes /parameter_events and /rosout
    assert code == 0 and out.split() == ['/chatter', '/cmd', '/cmd_echo', '/parameter_events', '/patch/frame',
                                         '/rosout']
    _, out, _ = cli(capsys, 'topic', 'list', '-t')
    assert '/patch/frame [social_touch_msgs/msg/PatchFrame]' in out.splitlines()
    _, out, _ = cli(capsys, 'topic', 'list', '-c')
    assert out.strip() == '6'
    _, out, _ = cli(capsys, 'topic', 'info', '/chatter')
    assert out.splitlines() == ['Type: std_msgs/msg/String', 'Publisher count: 1', 'Subscription count: 0']
    _, out, _ = cli(capsys, 'topic', 'info', '/cmd', '-v')
    lines = out.splitlines()
    assert lines[:4] == ['Type: std_msgs/msg/String', '', 'Publisher count: 0', '']
    assert 'Node name: demo_talker' in lines and 'Node namespace: /' in lines and 'Endpoint type: SUBSCRIPTION' in lines
    assert 'Topic type hash: RIHS01_df668c740482bbd48fb39d76a70dfd4bd59db1288021743503259e948f6b1a18' in lines
    assert '  Reliability: RELIABLE' in lines and '  History (Depth): KEEP_LAST (10)' in lines
    assert any(line.startswith('Queue: ') and 'dropped (queue full)' in line for line in lines)
    _, out, _ = cli(capsys, 'topic', 'list', '--include-hidden-topics')
    assert '/_social_touch/subscription_stats' in out.split()


def test_node_list_and_info(graph, capsys):
    _, out, _ = cli(capsys, 'node', 'list')
    assert out.split() == ['/demo_talker']
    _, out, _ = cli(capsys, 'node', 'list', '-a')
    assert any(name.startswith('/_social_touch_node_list_') for name in out.split())  # the command's own node
    _, out, _ = cli(capsys, 'node', 'info', '/demo_talker')
    parameter_services = [f'    /demo_talker/{name}: rcl_interfaces/srv/{srv}' for name, srv in (
        ('describe_parameters', 'DescribeParameters'), ('get_parameter_types', 'GetParameterTypes'),
        ('get_parameters', 'GetParameters'), ('list_parameters', 'ListParameters'),
        ('set_parameters', 'SetParameters'), ('set_parameters_atomically', 'SetParametersAtomically'))]
    parameter_services.insert(3, '    /demo_talker/get_type_description: '
                                 'type_description_interfaces/srv/GetTypeDescription')
    assert out.splitlines() == [
        '/demo_talker', '  Subscribers:', '    /cmd: std_msgs/msg/String', '  Publishers:',
        '    /chatter: std_msgs/msg/String', '    /cmd_echo: std_msgs/msg/String',
        '    /parameter_events: rcl_interfaces/msg/ParameterEvent',
        '    /patch/frame: social_touch_msgs/msg/PatchFrame',
        '    /rosout: rcl_interfaces/msg/Log', '  Service Servers:', *parameter_services, '  Service Clients:', '',
        '  Action Servers:', '', '  Action Clients:', '']  # as ros2 node info prints empty sections
    code, _, err = cli(capsys, 'node', 'info', '/demo_talkr')
    assert code == 1 and "did you mean '/demo_talker'" in err


def test_topic_echo(graph, capsys):
    code, out, _ = cli(capsys, 'topic', 'echo', '/chatter', '-n', '3')
    docs = out.split('---\n')
    assert code == 0 and len(docs) == 4 and docs[-1] == ''
    numbers = [int(re.fullmatch(r"data: hello (\d+)\n", d).group(1)) for d in docs[:3]]
    assert numbers == list(range(numbers[0], numbers[0] + 3))
    _, out, _ = cli(capsys, 'topic', 'echo', '/patch/frame', '--once', '--no-arr')
    assert "activation: '<array type: float32[256]>'" in out and 'frame_id:' in out  # as ros2 prints it
    _, out, _ = cli(capsys, 'topic', 'echo', '/patch/frame', '--once', '--field', 'header.frame_id')
    assert out.startswith("''")
    code, _, err = cli(capsys, 'topic', 'echo', '/patch/frame', '--field', 'header.frame')
    assert code == 1 and "no field 'frame' (did you mean 'frame_id'?)" in err
    code, _, err = cli(capsys, 'topic', 'echo', '/chater')
    assert code == 1 and "unknown topic '/chater' (did you mean '/chatter'?)" in err


def test_topic_hz(graph, capsys):
    code, out, _ = cli(capsys, 'topic', 'hz', '/chatter', '--duration', '2.5')
    rates = [float(r) for r in re.findall(r'average rate: ([\d.]+)', out)]
    assert code == 0 and rates
    assert 25 < rates[-1] < 75  # 50 Hz in the talker's ROS time (wide: a loaded machine skips periods)
    assert re.search(r'min: [\d.]+s max: [\d.]+s std dev: [\d.]+s window: \d+', out)


def test_topic_pub_reaches_the_other_process(graph, capsys):
    echo = subprocess.Popen([sys.executable, str(graph / 'cli.py'), 'topic', 'echo', '/cmd_echo', '--once',
                             '--timeout', '30'], cwd=REPO, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=graph_env(os.environ['ROS_DOMAIN_ID']))
    try:
        # The echo process is in the graph once the talker's /cmd_echo has a subscription.
        def echo_ready():
            with GraphTool('probe', discovery_timeout_s=1.0) as tool:
                topic = tool.graph().topics.get('/cmd_echo')
                return topic is not None and topic.subscriptions
        wait_until(echo_ready, what='the echo process to subscribe')
        code, out, _ = cli(capsys, 'topic', 'pub', '/cmd', 'std_msgs/msg/String', '{data: ping}', '--once')
        assert code == 0 and "publishing #1: {'data': 'ping'}" in out
        out, err = echo.communicate(timeout=30)
        assert echo.returncode == 0, err
        assert out == 'data: echo ping\n---\n'
    finally:
        if echo.poll() is None:
            echo.kill()
            echo.communicate()
    code, _, err = cli(capsys, 'topic', 'pub', '/cmd', 'std_msgs/msg/String', '{dta: x}', '--once')
    assert code == 1 and "no field 'dta' (did you mean 'data'?)" in err
