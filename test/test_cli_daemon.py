"""The graph daemon (``social-touch daemon``): started on first use, answers from its graph, complete, replaced
when stale, stopped by each test that starts one (a domain of the test's own)."""

import importlib
import io
import os
import pickle
import socket
import subprocess
import sys
import textwrap

import pytest
from daemon_peer import daemon, domain_env, listed_of, load_node, node_list, start_node, stop
from doctest_testing import check_doctests

from touch_graph.daemon import client
from touch_graph.daemon.address import daemon_address


@pytest.fixture
def env(dds_domain, monkeypatch):
    """The test's domain with the daemon allowed; whatever daemon runs there is stopped afterwards."""
    monkeypatch.setenv('SOCIAL_TOUCH_DAEMON', '1')
    environ = domain_env(dds_domain)
    address = daemon_address(environ)
    try:
        yield environ
    finally:
        client.stop(address)
        assert client.wait_running(address, timeout_s=0.0) is None, 'the daemon outlived its test'


def cli(env, *argv):
    return subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', *argv], env=env, capture_output=True,
                          text=True, timeout=60)


def test_start_status_stop(env):
    assert cli(env, 'daemon', 'status').returncode == 1
    assert 'started' in daemon(env, 'start').stdout
    assert 'already running' in daemon(env, 'start').stdout
    status = cli(env, 'daemon', 'status')
    assert status.returncode == 0 and f"domain {env['ROS_DOMAIN_ID']}" in status.stdout, status.stdout
    before = client.request('status', daemon_address(env))['requests']
    listed = cli(env, 'topic', 'list')
    assert 'no ROS 2 graph is running' in listed.stderr and listed.returncode == 1
    assert client.request('status', daemon_address(env))['requests'] == before + 2  # its graph, then our status
    assert 'stopped' in daemon(env, 'stop').stdout
    assert cli(env, 'daemon', 'status').returncode == 1
    assert not daemon_address(env).socket_path.exists()
    assert 'no daemon running' in daemon(env, 'stop').stdout


def test_first_use_starts_the_daemon_and_answers_itself(env):
    first = cli(env, 'node', 'list')
    assert first.returncode == 0 or 'no ROS 2 graph' in first.stderr, first.stderr
    assert client.wait_running(daemon_address(env)) is not None, 'the first graph command started no daemon'


def test_no_daemon_starts_none(env):
    cli(env, 'service', 'list', '--no-daemon')
    env0 = {**env, 'SOCIAL_TOUCH_DAEMON': '0'}
    cli(env0, 'topic', 'list')
    assert client.wait_running(daemon_address(env), timeout_s=1.0) is None


def test_a_node_started_just_before_is_listed(env):
    """20 of 20: the daemon sees the domain already, and still waits for a participant not complete yet."""
    daemon(env, 'start')
    assert listed_of(20, env) == 20


def test_daemon_graph_holds_our_node_with_its_endpoints(env):
    daemon(env, 'start')
    proc = load_node('probe_talker', env)
    try:
        start_node(proc)
        assert '/probe_talker' in node_list(env)
        info = cli(env, 'node', 'info', '/probe_talker')
        assert '/late_chatter: std_msgs/msg/String' in info.stdout, info.stdout
        topics = cli(env, 'topic', 'list', '-t')
        assert '/late_chatter [std_msgs/msg/String]' in topics.stdout
        direct = cli(env, 'topic', 'list', '-t', '--no-daemon')
        assert direct.stdout == topics.stdout
        param = cli(env, 'param', 'get', '/probe_talker', 'use_sim_time')  # nodes from the daemon, calls direct
        assert param.stdout.strip() == 'Boolean value is: False', param.stderr
    finally:
        stop(proc)


OTHER_DAEMON = textwrap.dedent('''
    import sys
    from touch_graph.daemon import server
    server.code_version = lambda: sys.argv[2]
    sys.exit(server.serve(int(sys.argv[1])))
''')


def other_daemon(env, version):
    """A daemon that says it runs installation ``version``."""
    return subprocess.Popen([sys.executable, '-c', OTHER_DAEMON, env['ROS_DOMAIN_ID'], version], env=env,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)


def test_a_daemon_of_a_newer_installation_stays(env):
    address = daemon_address(env)
    newer = f'{10**30}-from-the-future'
    proc = other_daemon(env, newer)
    try:
        assert client.wait_running(address)['version'] == newer
        result = cli(env, 'topic', 'list')  # asks its own participant (which sees the daemon's)
        assert result.returncode in (0, 1) and 'Traceback' not in result.stderr, result.stderr
        assert proc.poll() is None and client.request('status', address)['version'] == newer
    finally:
        client.stop(address)
        proc.wait(10)


def test_a_daemon_of_an_older_installation_is_replaced(env):
    address = daemon_address(env)
    old = other_daemon(env, 'an older installation')
    try:
        status = client.wait_running(address)
        assert status is not None and status['version'] == 'an older installation'
        assert 'another installation' in cli(env, 'daemon', 'status').stdout
        cli(env, 'topic', 'list')  # answered without it; it leaves and ours starts
        assert old.wait(30) == 0
        status = client.wait_running(address, timeout_s=30.0)  # it waits for the old one to leave
        assert status is not None and status['version'] == client.code_version()
    finally:
        if old.poll() is None:
            old.kill()
            old.wait()


def test_a_dead_daemon_socket_falls_back_and_is_replaced(env):
    address = daemon_address(env)
    dead = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    dead.bind(str(address.socket_path))  # a socket file nobody listens on: what a killed daemon leaves
    dead.close()
    result = cli(env, 'topic', 'list')
    assert result.returncode in (0, 1) and 'Traceback' not in result.stderr, result.stderr
    assert client.wait_running(address) is not None


def test_an_answer_holding_anything_but_a_graph_is_refused():
    with pytest.raises(pickle.UnpicklingError, match='never holds'):
        client._GraphUnpickler(io.BytesIO(pickle.dumps(os.system))).load()


def test_a_query_through_the_daemon_loads_no_dds(env):
    """What keeps ``topic list`` fast: the client reads the daemon's answer without Cyclone or the runtime."""
    daemon(env, 'start')
    probe = ('import sys\nfrom touch_lab.cli.main import main\nmain(["topic", "list"])\n'
             'print(sorted(m for m in sys.modules if m.split(".")[0] == "cyclonedds"'
             ' or m.startswith("touch_graph.runtime") or m in ("numpy", "touch_graph.messages")))')
    out = subprocess.run([sys.executable, '-c', probe], env=env, capture_output=True, text=True, timeout=60)
    assert out.stdout.strip().splitlines()[-1] == '[]', out.stdout + out.stderr


@pytest.mark.parametrize('name', ['touch_graph.daemon.address', 'touch_graph.cli.topic'])
def test_doctests(name):
    check_doctests(importlib.import_module(name))


def test_bench_times_the_graph_queries_and_stops_its_daemon(monkeypatch):
    from touch_lab.bench.cli import bench_graph_queries
    stopped = []
    real_stop = client.stop
    monkeypatch.setattr(client, 'stop', lambda address, **kw: stopped.append(address) or real_stop(address, **kw))
    result = bench_graph_queries(1, settle_s=0.5)
    assert set(result) >= {'topic list, first call (s)', 'topic list, daemon settled (s)',
                           'node list, daemon settled (s)', 'topic list --no-daemon (s)'}
    assert all(v > 0 for k, v in result.items() if k.endswith('(s)'))
    assert stopped and client.wait_running(stopped[-1], timeout_s=0.0) is None, 'the bench left its daemon running'
