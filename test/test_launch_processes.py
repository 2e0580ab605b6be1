"""``social-touch launch`` with nodes in processes of their own: reported, restarted with back-off, all stopped."""

import os
import re
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest
from dds_testing import wait_until

from touch_graph.dds.tool import GraphTool
from touch_graph.launch import evaluate_launch
from touch_graph.launch.specs import ProcessOptions, spec_from_json, spec_to_json

REPO = Path(__file__).resolve().parent.parent
BEAR = f'bearsim://bear?scene={REPO}/config/scenes/bear_touches.yaml'


def launch_file(tmp_path, body):
    path = tmp_path / 'scene.launch.yaml'
    path.write_text('launch:\n' + body)
    return path


class Launch:
    """``social-touch launch`` in a process; its stderr read line by line in a thread."""

    def __init__(self, *argv, env=None):
        self.proc = subprocess.Popen([sys.executable, '-m', 'touch_lab.cli.main', 'launch', *map(str, argv)],
                                     cwd=REPO, env=env,
                                     stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
        self.lines = []
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self):
        for line in self.proc.stderr:
            self.lines.append(line.rstrip('\n'))

    def text(self):
        return '\n'.join(self.lines)

    def pids(self, label=None):
        """Pids of the processes the launch started (of one ``label``, e.g. ``flaky-1``)."""
        return [int(m.group(2)) for m in re.finditer(r'\[INFO\] \[([\w-]+)\]: process started with pid \[(\d+)\]',
                                                     self.text()) if label in (None, m.group(1))]

    def wait_for(self, pattern, timeout_s=30.0):
        wait_until(lambda: re.search(pattern, self.text()), timeout_s, f'{pattern!r} in the launch output')

    def stop(self, signum=signal.SIGINT, timeout_s=30):
        if self.proc.poll() is None:
            self.proc.send_signal(signum)
        try:
            self.proc.wait(timeout_s)
        finally:
            if self.proc.poll() is None:
                self.proc.kill()
                self.proc.wait(10)
            self._thread.join(5)
        return self.proc.returncode


def gone(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return True
    # a zombie (exited, not reaped yet by its dead parent's reaper) counts as gone
    status = Path(f'/proc/{pid}/status')
    return status.exists() and 'State:\tZ' in status.read_text()


def nodes_in_graph():
    with GraphTool('probe', discovery_timeout_s=1.0) as tool:
        return {n.name for n in tool.graph().nodes}


def test_every_node_in_its_own_process_and_ctrl_c_stops_them_all(dds_domain, tmp_path):
    path = launch_file(tmp_path, f'''\
- node: {{pkg: social_touch, exec: touch_monitor, name: monitor_a}}
- node: {{pkg: social_touch, exec: touch_monitor, name: monitor_b}}
- node:
    pkg: social_touch
    exec: bear_driver
    namespace: bear
    param: [{{name: port, value: "{BEAR}"}}]
''')
    launch = Launch('--processes', path)
    try:
        launch.wait_for(r'\[bear_driver-3\]: process started')
        wait_until(lambda: {'/monitor_a', '/monitor_b', '/bear/bear_driver'} <= nodes_in_graph(), 60,
                   'the three node processes in the graph')
        pids = launch.pids()
        assert len(pids) == 3 and os.getpid() not in pids
        # its output, prefixed with its name (the launcher forwards it from a pipe: it may come after the
        # node is visible in the graph)
        launch.wait_for(r'\[bear_driver-3\] \[INFO\]')
    finally:
        code = launch.stop(signal.SIGINT)
    assert code == 0, launch.text()
    for label in ('monitor_a-1', 'monitor_b-2', 'bear_driver-3'):
        assert re.search(rf'\[INFO\] \[{label}\]: process stopped \[pid \d+, exit code 0\]', launch.text())
    assert all(gone(pid) for pid in pids), 'a node process outlived its launch'
    assert launch.text().endswith('[launch] all nodes stopped')


def test_a_node_that_dies_is_reported_and_respawned(dds_domain, tmp_path):
    path = launch_file(tmp_path, '''\
- node: {pkg: social_touch, exec: touch_monitor, name: steady}
- node: {pkg: social_touch, exec: touch_monitor, name: phoenix, respawn: true, respawn_delay: 0.2}
''')
    launch = Launch(path)  # in one process by default, except the node with process attributes
    try:
        launch.wait_for(r'\[phoenix-1\]: process started')
        assert '[launch] 1 node(s) running in this process: /steady' in launch.text()
        wait_until(lambda: '/phoenix' in nodes_in_graph(), 60, 'the phoenix process in the graph')
        [first] = launch.pids('phoenix-1')
        os.kill(first, signal.SIGKILL)
        launch.wait_for(rf'\[ERROR\] \[phoenix-1\]: process has died \[pid {first}, exit code -9, cmd ')
        launch.wait_for(r'\[WARN\] \[phoenix-1\]: it died [\d.]+ s after starting \(1 time\(s\) in a row within '
                        r'10 s\); restarting in 0.5 s')
        wait_until(lambda: len(launch.pids('phoenix-1')) == 2, 30, 'the restart')
        wait_until(lambda: '/phoenix' in nodes_in_graph(), 60, 'the restarted phoenix in the graph')
        second = launch.pids('phoenix-1')[1]
    finally:
        code = launch.stop(signal.SIGTERM)
    assert code == 1  # a node process died during the launch
    assert gone(first) and gone(second)


def test_a_node_that_keeps_crashing_backs_off_and_gives_up(dds_domain, tmp_path):
    # a player without its bag cannot start: exit code 1, every time
    path = launch_file(tmp_path, '''\
- node: {pkg: social_touch, exec: player, name: flaky, respawn: true, respawn_max_retries: 3}
''')
    launch = Launch(path)
    try:
        launch.wait_for(r'not restarting it again: it was restarted 3 times', 90)
        launch.proc.wait(30)  # nothing is left to run: the launch ends by itself
    finally:
        code = launch.stop()
    text = launch.text()
    assert code == 1
    assert len(launch.pids('flaky-1')) == 4
    assert text.count("[ERROR] [flaky-1]: process has died") == 4
    assert "parameter 'bag' is required" in text  # the node's own error, prefixed with its name
    delays = [float(d) for d in re.findall(r'in a row within 10 s\); restarting in ([\d.]+) s', text)]
    assert delays == [0.5, 1.0, 2.0]  # doubling, not a busy loop
    assert '[launch] every node process has exited' in text


def test_node_processes_die_with_a_killed_launcher(dds_domain, tmp_path):
    path = launch_file(tmp_path, '- node: {pkg: social_touch, exec: touch_monitor, name: orphan}\n')
    launch = Launch('--processes', path)
    try:
        launch.wait_for(r'\[orphan-1\]: process started')
        wait_until(lambda: '/orphan' in nodes_in_graph(), 60, 'the node process in the graph')
        [pid] = launch.pids()
    finally:
        launch.stop(signal.SIGKILL)
    wait_until(lambda: gone(pid), 20, 'the node process to end after its launcher was killed')


def test_process_options_from_the_launch_file_and_refusals(tmp_path):
    path = launch_file(tmp_path, '''\
- arg: {name: again, default: 'true'}
- node: {pkg: social_touch, exec: touch_monitor, name: a}
- node:
    pkg: social_touch
    exec: touch_monitor
    name: b
    respawn: $(var again)
    respawn_delay: '2'
    sigterm_timeout: 1.5
''')
    plan = evaluate_launch(path)
    assert plan.nodes[0].process is None
    assert plan.nodes[1].process == ProcessOptions(respawn=True, respawn_delay=2.0, sigterm_timeout=1.5)
    assert spec_from_json(spec_to_json(plan.nodes[1])) == plan.nodes[1]
    assert 'own process, respawn after 2 s' in plan.describe()
    bad = launch_file(tmp_path, '- node: {pkg: social_touch, exec: touch_monitor, respawn_delay: -1}\n')
    with pytest.raises(Exception, match="'respawn_delay' of 'node' must be a number of seconds >= 0; got -1"):
        evaluate_launch(bad)
    from touch_graph.cli import main as cli_main
    assert cli_main.main(['launch', str(path), '--sim-time']) == 1  # a simulated clock is one process's


def test_spec_json_keeps_parameters_with_where_they_were_written(tmp_path):
    params = tmp_path / 'p.yaml'
    params.write_text('/**:\n  ros__parameters:\n    x: 1\n')
    path = launch_file(tmp_path, f'''\
- node:
    pkg: social_touch
    exec: touch_monitor
    name: m
    param: [{{name: show_subtypes, value: true}}, {{name: names, value: [a, b]}}, {{from: {params}}}]
    remap: [{{from: a, to: b}}]
    ros_args: --log-level debug
''')
    [spec] = evaluate_launch(path).nodes
    again = spec_from_json(spec_to_json(spec))
    assert again == spec and again.params[0].where == spec.params[0].where and again.cli_args() == spec.cli_args()
