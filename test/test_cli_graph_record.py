"""``social-touch record | play | bag`` against a graph running in another process, over DDS."""

import os
import signal
import subprocess
import sys

import pytest
from rosbags.rosbag2 import Reader
from test_cli_graph_commands import REPO, cli, graph_env, running_graph, wait_until

from touch_graph.bag import BagRecorder
from touch_graph.bag.reindex import scan_mcap
from touch_graph.errors import BagError
from touch_graph.messages import deserialize, get_message, serialize

String = get_message('std_msgs/msg/String')


@pytest.fixture(scope='module')
def graph():
    """A node process publishing /chatter (50 Hz), /patch/frame; echoing /cmd on /cmd_echo."""
    yield from running_graph()


def flushed(mcap):
    """Messages of an MCAP file being written that are on disk (0 before its header is)."""
    try:
        return scan_mcap(mcap).message_count
    except (BagError, FileNotFoundError):
        return 0


def start_cli(graph_dir, *argv, **kwargs):
    return subprocess.Popen([sys.executable, str(graph_dir / 'cli.py'), *argv], cwd=REPO, text=True,
                            env=graph_env(os.environ['ROS_DOMAIN_ID']), **kwargs)


def chatter_numbers(bag):
    with Reader(bag) as reader:
        conns = [c for c in reader.connections if c.topic == '/chatter']
        return [int(deserialize(d, c.msgtype).data.split()[1]) for c, _, d in reader.messages(conns)]


def test_ctrl_c_closes_the_bag(graph, tmp_path):
    bag = tmp_path / 'interrupted'
    proc = start_cli(graph, 'record', '/chatter', '/patch/frame', '-o', str(bag), stderr=subprocess.PIPE)
    try:
        wait_until(lambda: flushed(bag / 'interrupted.mcap') > 20, what='a flushed recording')
        proc.send_signal(signal.SIGINT)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, err
    assert 'wrote' in err and '/chatter' in err
    with Reader(bag) as reader:
        assert {t: i.msgtype for t, i in reader.topics.items()} == {
            '/chatter': 'std_msgs/msg/String', '/patch/frame': 'social_touch_msgs/msg/PatchFrame'}
        assert reader.topics['/patch/frame'].msgcount >= 1
    numbers = chatter_numbers(bag)
    assert len(numbers) > 20 and numbers == list(range(numbers[0], numbers[0] + len(numbers)))


def test_killed_recorder_is_recovered_by_bag_reindex(graph, tmp_path, capsys):
    bag = tmp_path / 'killed'
    proc = start_cli(graph, 'record', '/chatter', '-o', str(bag), '--quiet', stderr=subprocess.DEVNULL)
    try:
        wait_until(lambda: flushed(bag / 'killed.mcap') > 20, what='a flushed recording')
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(10)
    code, _, err = cli(capsys, 'bag', 'info', str(bag))
    assert code == 1 and f'social-touch bag reindex {bag}' in err
    code, out, _ = cli(capsys, 'bag', 'reindex', str(bag))
    assert code == 0 and 'repaired killed.mcap' in out
    numbers = chatter_numbers(bag)
    assert len(numbers) > 20 and numbers == list(range(numbers[0], numbers[0] + len(numbers)))
    code, out, _ = cli(capsys, 'bag', 'info', str(bag))
    assert code == 0 and f'Messages:          {len(numbers)}' in out


def test_record_all_for_a_duration_then_bag_info(graph, tmp_path, capsys):
    bag = tmp_path / 'all'
    code, _, err = cli(capsys, 'record', '-a', '-o', str(bag), '--duration', '1.5')
    assert code == 0, err
    code, out, _ = cli(capsys, 'bag', 'info', str(bag))
    assert code == 0 and 'Storage id:        mcap' in out
    topics = {line.split('Topic: ')[1].split(' |')[0] for line in out.splitlines() if 'Topic: ' in line}
    # every published topic, /rosout and /parameter_events too (as ros2 bag record -a); /cmd has no publisher
    assert topics == {'/chatter', '/patch/frame', '/cmd_echo', '/parameter_events', '/rosout'}
    code, _, err = cli(capsys, 'record', '-o', str(tmp_path / 'x'))
    assert code == 1 and '-a/--all' in err


def test_play_republishes_into_another_process(graph, tmp_path, capsys):
    bag = tmp_path / 'commands'
    with BagRecorder(bag, flush_period_s=None) as rec:
        for i in range(3):
            rec.write('/cmd', 'std_msgs/msg/String', 1_000_000_000 + 100_000_000 * i, serialize(String(data=f'c{i}')))
    echo = start_cli(graph, 'topic', 'echo', '/cmd_echo', '-n', '3', '--timeout', '30',
                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        from touch_graph.dds.tool import GraphTool

        def echo_ready():
            with GraphTool('probe', discovery_timeout_s=1.0) as tool:
                topic = tool.graph().topics.get('/cmd_echo')
                return topic is not None and topic.subscriptions
        wait_until(echo_ready, what='the echo process to subscribe')
        code, _, err = cli(capsys, 'play', str(bag), '--rate', '2')
        assert code == 0 and 'published 3 messages' in err
        out, err = echo.communicate(timeout=30)
    finally:
        if echo.poll() is None:
            echo.kill()
            echo.communicate()
    assert out == ''.join(f'data: echo c{i}\n---\n' for i in range(3)), err


@pytest.mark.parametrize('argv, message', [
    (['play', '/nonexistent/bag'], 'does not exist'),
    (['play', '{bag}', '--topics', '/cmdd'], "no topic '/cmdd' (did you mean '/cmd'?)"),
    (['bag', 'reindex', '/nonexistent/bag'], 'not a bag directory'),
])
def test_clear_errors(graph, tmp_path, capsys, argv, message):
    bag = tmp_path / 'small'
    with BagRecorder(bag, flush_period_s=None) as rec:
        rec.write('/cmd', 'std_msgs/msg/String', 1, serialize(String(data='x')))
    code, _, err = cli(capsys, *[a.format(bag=bag) for a in argv])
    assert code == 1 and message in err
