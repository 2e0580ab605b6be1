"""The live ``collect`` session against a real graph over DDS: a patch driver on its virtual device in a process
of its own (``social-touch launch``), the operator's keys as a script, redo, drop, quit, the prompt topic."""

from __future__ import annotations

import os
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from touch_lab.cli.main import main as cli_main
from touch_lab.collect.live import PROMPT_TOPIC, TerminalLines, live_session
from touch_lab.collect.protocol import Protocol
from touch_lab.collect.session_bag import read_session

REPO = Path(__file__).resolve().parents[1]


def _social_touch() -> str:
    return shutil.which('social-touch') or str(Path(sys.executable).parent / 'social-touch')


@pytest.fixture
def patch_graph(dds_domain):
    """The patch driver on patchsim:// in another process, joined to the test's DDS domain (wall clock)."""
    proc = subprocess.Popen([_social_touch(), 'launch', str(REPO / 'launch' / 'patch_driver.launch.yaml')],
                            cwd=REPO, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        yield proc
    finally:
        proc.send_signal(signal.SIGINT)
        try:
            proc.wait(15)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)


class _Operator:
    """The operator's keys, one line per call, ``pause_s`` apart (a trial lasts that long); EOFError after the last."""

    def __init__(self, keys: list[str], pause_s: float = 0.3) -> None:
        self.keys = list(keys)
        self.pause_s = pause_s

    def __call__(self, _prompt: str) -> str:
        if not self.keys:
            raise EOFError
        time.sleep(self.pause_s)
        return self.keys.pop(0)


class _PromptWatcher:
    """Subscribes to the prompt topic (latched) in a context of its own, in a thread; keeps what it hears."""

    def __init__(self) -> None:
        self.heard: list[str] = []
        self.done = threading.Event()
        self.ready = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        # Two contexts set up at once in one process can trip cyclonedds' topic creation: one after the other.
        assert self.ready.wait(20), 'the prompt watcher did not start'

    def _run(self) -> None:
        from touch_graph.dds.tool import GraphTool
        from touch_graph.messages import get_message
        from touch_graph.runtime.qos import DurabilityPolicy, QoSProfile
        with GraphTool('prompt_probe', discovery_timeout_s=0.5) as tool:
            tool.node.create_subscription(get_message('std_msgs/msg/String'), PROMPT_TOPIC,
                                          lambda msg: self.heard.append(msg.data),
                                          QoSProfile(depth=10, durability=DurabilityPolicy.TRANSIENT_LOCAL))
            self.ready.set()
            tool.spin_until(self.done.is_set, 60.0)


def test_live_session_records_frames_and_labels_with_redo_drop_and_quit(tmp_path, patch_graph):
    protocol = Protocol(('stroke', 'slap'), repetitions=2, seed=0)   # stroke, slap, slap, stroke
    trials = protocol.trials()
    keys = ['', '',      # trial 1 performed and kept
            'r',         # ... redone: asked again, its first label never written
            '', '',      # trial 1 again
            '', '',      # trial 2
            'd',         # ... dropped: not asked again
            '', '',      # trial 3 (the protocol's third)
            'q']         # end early: the fourth is never asked
    watcher = _PromptWatcher()
    said: list[str] = []
    bag = tmp_path / 'patch_ada'
    try:
        result = live_session('patch', protocol, 'ada', bag, read_line=_Operator(keys), say=said.append, wait_s=20.0,
                              synthetic=True)   # the graph plays the virtual patch
    finally:
        time.sleep(0.5)
        watcher.done.set()
        watcher.thread.join(10)
    assert result['kept'] == 2 and result['trials'] == 3 and result['frames'] > 10, (result, said)
    session = read_session(bag, 'patch')
    assert session.synthetic and session.people == ['ada']
    assert [(lab.gesture, lab.variant) for lab in session.labels] == [
        (t.gesture, t.variant) for t in (trials[0], trials[2])]
    stamps = session.stamps_s['/patch/frame']
    assert np.all(np.diff(stamps) >= 0) and stamps[-1] > 1.0
    for lab in session.labels:   # each trial lasted about the operator's pause, and holds frames
        assert 0.1 < lab.end_s - lab.start_s < 5.0
        assert np.count_nonzero((stamps >= lab.start_s) & (stamps <= lab.end_s)) >= 2
    assert any('redo' in s for s in said) and any('dropped' in s for s in said)
    assert f'trial 1/4: {trials[0].prompt}: press Enter' in watcher.heard[0] or any(
        f'trial 1/4: {trials[0].prompt}' in h for h in watcher.heard), watcher.heard
    assert any(h.startswith(f'trial 2/3: {trials[2].prompt}') for h in watcher.heard), watcher.heard
    assert watcher.heard[-1] == ''   # the session ended: the view hides its panel
    # train reads the live bag as it reads simulated sessions (a tiny model: two short trials)
    model = tmp_path / 'patch.npz'
    assert cli_main(['train', 'patch', '--bags', str(bag), '--components', '1', '-o', str(model)]) == 0
    assert model.exists()


def test_live_session_cli_refuses_an_existing_bag_a_missing_person_and_a_missing_scene(tmp_path, dds_domain):
    with pytest.raises(SystemExit, match='--person'):
        cli_main(['collect', 'patch', '--out', str(tmp_path / 'x')])
    (tmp_path / 'taken').mkdir()
    with pytest.raises(SystemExit, match=r'exists already.*--overwrite'):
        cli_main(['collect', 'patch', '--person', 'ada', '--out', str(tmp_path / 'taken')])
    with pytest.raises(SystemExit, match='not a bag'):
        cli_main(['collect', 'patch', '--person', 'ada', '--overwrite', '--out', str(tmp_path / 'taken')])
    no_scene = rf'nobody publishes /patch/frame in DDS domain {dds_domain}.*social-touch launch'
    with pytest.raises(SystemExit, match=no_scene):
        cli_main(['collect', 'patch', '--person', 'ada', '--wait', '1', '--out', str(tmp_path / 'new')])
    assert not (tmp_path / 'new').exists()


def test_ctrl_c_ends_the_live_session_with_the_kept_trials_in_a_closed_bag(tmp_path, patch_graph):
    protocol = Protocol(('stroke', 'slap'), repetitions=2, seed=3)
    operator = _Operator(['', ''])

    def keys_then_ctrl_c(prompt: str) -> str:
        if operator.keys:
            return operator(prompt)
        time.sleep(0.5)
        os.kill(os.getpid(), signal.SIGINT)   # the operator's Ctrl-C, during the second trial's prompt
        time.sleep(30)
        raise EOFError
    bag = tmp_path / 'patch_bob'
    result = live_session('patch', protocol, 'bob', bag, read_line=keys_then_ctrl_c, say=lambda _t: None, wait_s=20.0)
    assert result['kept'] == 1
    session = read_session(bag, 'patch')   # closed properly: metadata.yaml and the MCAP summary are there
    assert not session.synthetic   # not marked: live sessions record people unless told otherwise
    assert [lab.gesture for lab in session.labels] == [protocol.trials()[0].gesture]
    assert len(session.frames['/patch/frame']) == result['frames']


def test_terminal_lines_reads_the_operators_lines_and_lets_go_when_told():
    stop = threading.Event()
    read, write = os.pipe()
    try:
        os.write(write, b'\nR\nq')
        os.close(write)
        lines = TerminalLines(stop, fd=read, poll_s=0.05)
        assert [lines(''), lines(''), lines('')] == ['', 'R', 'q']
        with pytest.raises(EOFError):
            lines('')
    finally:
        os.close(read)
    read, write = os.pipe()
    try:
        stop.set()   # the session ended: a reader waiting for a line gives up
        with pytest.raises(EOFError):
            TerminalLines(stop, fd=read, poll_s=0.05)('')
    finally:
        os.close(read)
        os.close(write)
