"""``social-touch codebook record`` (touch_lab.skin.record_cli): simulated and live, undo, skip, resume.

SYNTHETIC data throughout: simulated performers and scripted strokes on the virtual skin. The
live tests run the recorder as its own process against a simulated-time graph in this
process, both in a DDS domain of the test's own, and advance the graph's time only when the
recorder is ready.
"""

import argparse
import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from touch_gestures.skin.codebook import CodebookRecorder, load_codebook
from touch_gestures.skin.errors import CodebookError
from touch_gestures.skin.gesture import TouchGesture, ideal_frame
from touch_graph.messages import get_message
from touch_lab.skin import record_cli
from touch_lab.skin.recording import load_recording, save_recording
from touch_sim.skin.device import forget_stimuli, register_stimulus
from touch_sim.skin.stimuli import LineStroke, Timeline
from touch_sim.virtual_port import forget_devices

REPO = Path(__file__).resolve().parent.parent
SkinFrame = get_message('social_touch_msgs/msg/SkinFrame')
Header = get_message('std_msgs/msg/Header')
Time = get_message('builtin_interfaces/msg/Time')


def parse(*argv):
    parser = argparse.ArgumentParser()
    record_cli.add_arguments(parser)
    return parser.parse_args(list(argv))


def line(start, end, n=40):
    return TouchGesture.from_trajectory(np.linspace(start, end, n))


# ----------------------------------------------------------------------------- simulated
def test_simulate_writes_a_loadable_synthetic_codebook_the_same_every_time(tmp_path, capsys):
    out = tmp_path / 'cb.npz'
    argv = ['--simulate', '2', '--seed', '5', '--gestures', 'line_right,line_left,one', '--repetitions', '3',
            '-o', str(out)]
    assert record_cli.run(parse(*argv)) == 0
    model = load_codebook(out)
    assert list(model.classes_) == ['line_left', 'line_right', 'one'] and model.name == 'trace'
    assert np.bincount(model.template_labels_).tolist() == [3, 3, 3]
    assert model.description_.startswith('SYNTHETIC: 2 simulated performers')
    assert sorted(set(model.template_people_)) == ['synthetic0', 'synthetic1']   # who drew each template
    assert f'wrote {out}: 9 templates of 3 gestures (trace)' in capsys.readouterr().err
    again = tmp_path / 'again.npz'
    assert record_cli.run(parse(*argv[:-1], str(again))) == 0
    np.testing.assert_array_equal(load_codebook(again).templates_, model.templates_)


def test_the_vocabulary_and_its_gap_go_into_the_file(tmp_path):
    out = tmp_path / 'cb.npz'
    assert record_cli.run(parse('--simulate', '1', '--gestures', 'line_right,one', '-m', '2', '--vocabulary',
                                'symbols', '--gap', '1.0', '-o', str(out))) == 0
    model = load_codebook(out)
    assert (model.vocabulary_, model.gap_s_) == ('symbols', 1.0)


def test_a_live_gap_joins_the_strokes_of_one_symbol():
    # Two strokes 0.5 s apart: two gestures at the single-stroke gap, one of two strokes with --gap 1.
    first = frames_of([np.array([10.0 + k, 20.0]) for k in range(20)], 0, lift_frames=75)
    second = frames_of([np.array([20.0, 10.0 + k]) for k in range(20)], 95 * 6_666_667, lift_frames=200)
    for gap, expected in ((None, [1, 1]), (1.0, [2])):
        stream = record_cli.live_stream(gap)
        got = [g for msg in (*first, *second) for g in stream.update(msg)]
        assert [g.strokes for g in got] == expected, gap


def test_simulate_records_for_another_recogniser_and_the_command_map_gestures(tmp_path):
    commands = tmp_path / 'commands.yaml'
    commands.write_text('format_version: 1\ncommands:\n  diagonal_down: next_task\n  line_up: resume\n')
    out = tmp_path / 'cb.npz'
    assert record_cli.run(parse('--simulate', '1', '--commands', str(commands), '-m', '2', '--recogniser',
                                'centroid', '-o', str(out))) == 0
    model = load_codebook(out, recogniser='centroid')
    assert list(model.classes_) == ['diagonal_down', 'line_up']


@pytest.mark.parametrize('argv, fragment', [
    (['--simulate', '1', '--gestures', 'line_rigth'], 'can trace only the synthetic shapes'),
    (['--simulate', '0', '--gestures', 'line_right'], 'argument --simulate: expected an integer in [1,'),
    (['--simulate', '1', '--gestures', 'line_right', '-m', '0'], 'argument --repetitions/-m: expected an integer'),
    (['--simulate', '1', '--recogniser', 'trac'], "unknown recogniser 'trac'"),
    (['--resume', 'nowhere.partial.npz'], 'recording file not found'),
    (['--simulate', '1', '--gestures', 'line_right', '--gap', '-1'], 'argument --gap: expected a number in [0,'),
    (['--simulate', '1', '--gestures', 'line_right', '--gap', 'nan'], 'argument --gap: expected a number in [0,'),
    (['--simulate', '1', '--gestures', 'line_right', '--vocabulary', ' '], '--vocabulary needs a name'),
])
def test_bad_arguments_are_clear_errors(tmp_path, capsys, argv, fragment):
    """Exit 2 with one message: from argparse (a number out of range) or from the command."""
    try:
        args = parse(*argv, '-o', str(tmp_path / 'x.npz'))
    except SystemExit as refused:
        code = refused.code
    else:
        code = record_cli.run(args)
    assert code == 2
    assert fragment in capsys.readouterr().err
    assert not (tmp_path / 'x.npz').exists()


# ----------------------------------------------------------------------------- recorder and session
def frames_of(points, t0_ns, lift_frames=40):
    """SkinFrame messages of a finger along ``points`` (mm), then an untouched skin."""
    out = []
    for i, p in enumerate([*points, *[None] * lift_frames]):
        sec, nanosec = divmod(t0_ns + i * 6_666_667, 1_000_000_000)
        out.append(SkinFrame(header=Header(stamp=Time(sec=sec, nanosec=nanosec)), contact=p is not None,
                             pressure=(ideal_frame(p) if p is not None else np.zeros((12, 12), np.float32)).ravel(),
                             contact_x=p[0] if p is not None else float('nan'),
                             contact_y=p[1] if p is not None else float('nan')))
    return out


def test_the_live_session_prompts_undoes_skips_and_stops():
    said = []
    session = record_cli.LiveSession(CodebookRecorder(['line_right', 'one', 'line_left'], repetitions=2),
                                     say=said.append)
    session.prompt()
    t = 10**18
    for msg in frames_of(np.linspace([6.0, 23.0], [41.0, 23.0], 80), t):
        session.on_frame(msg)
    for msg in frames_of([np.array([20.0, 20.0])] * 80, t + 10**9):   # a press: refused
        session.on_frame(msg)
    session.on_line('u\n')
    session.on_line('u\n')
    session.on_line('s\n')
    session.on_line('x\n')
    session.on_line('\n')
    assert said == ["trace 'line_right' (1/2)",
                    'kept line_right 1/2', "trace 'line_right' (2/2)",
                    'not kept: line_right: too small (0.0 mm across), trace it over at least 8 mm of the skin',
                    "trace 'line_right' (2/2)",
                    'undone: the last line_right', "trace 'line_right' (1/2)",
                    'nothing to undo', "trace 'line_right' (1/2)",
                    'skipped line_right: it will not be in the codebook', "trace 'one' (1/2)",
                    "unknown command 'x'; u + Enter: undo the last one, s + Enter: skip this gesture, q + Enter: "
                    'stop (Ctrl-C too)']
    assert not session.stopped
    session.on_line('q\n')
    assert session.stopped and session.recorder.skipped == ['line_right']


def test_skipped_gestures_are_left_out_and_the_rest_fits():
    rec = CodebookRecorder(['line_right', 'one', 'line_left'], repetitions=1)
    assert rec.add(line([6.0, 20.0], [41.0, 20.0])) == (True, 'line_right 1/1')
    assert rec.skip() == 'one' and rec.current == 'line_left'
    assert rec.add(line([41.0, 20.0], [6.0, 22.0]))[0] and rec.done and rec.skip() is None
    from touch_lab.skin.recognisers import make_recogniser
    assert list(rec.fit(make_recogniser('trace')).classes_) == ['line_left', 'line_right']
    everything_skipped = CodebookRecorder(['one'], repetitions=1)
    everything_skipped.skip()
    with pytest.raises(ValueError, match='every gesture was skipped'):
        everything_skipped.fit(make_recogniser('trace'))


def test_a_recording_saves_and_loads_whole(tmp_path):
    rec = CodebookRecorder(['line_right', 'one', 'line_left'], repetitions=2, min_extent_mm=5.0)
    g = line([6.0, 20.0], [41.0, 25.0])
    g.strokes, g.start_s, g.duration_s = 2, 1.5, 0.75
    rec.add(g)
    rec.skip()                                  # line_right is left out (and its sample dropped)
    rec.add(line([20.0, 5.0], [22.0, 40.0], n=7))
    path = save_recording(tmp_path / 'r.partial.npz', rec)
    back = load_recording(path)
    assert (back.gestures, back.repetitions, back.labels, back.skipped, back.min_extent_mm) == \
        (rec.gestures, 2, ['one'], ['line_right'], 5.0)
    (a,), (b,) = back.samples, rec.samples
    for name in ('binary_map', 'peak_map', 'trajectory', 'times', 'stroke'):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    assert (a.frames, a.strokes, a.start_s, a.duration_s) == (b.frames, b.strokes, b.start_s, b.duration_s)
    empty = load_recording(save_recording(tmp_path / 'empty', CodebookRecorder(['one'])))
    assert empty.samples == [] and empty.current == 'one'
    other = tmp_path / 'other.npz'
    np.savez(other, format=np.array('something else'))
    with pytest.raises(CodebookError, match='not a skin recording'):
        load_recording(other)
    damaged = dict(np.load(path))
    damaged['lengths'] = np.array([3])
    np.savez(tmp_path / 'damaged.npz', **damaged)
    with pytest.raises(CodebookError, match='a damaged recording'):
        load_recording(tmp_path / 'damaged.npz')


def test_resume_in_simulate_mode_completes_the_recording(tmp_path, capsys):
    rec = CodebookRecorder(['line_right', 'line_left'], repetitions=2)
    rec.add(line([6.0, 20.0], [41.0, 20.0]))
    partial = save_recording(tmp_path / 'cb.partial.npz', rec)
    out = tmp_path / 'cb.npz'
    assert record_cli.run(parse('--resume', str(partial), '--simulate', '1', '-o', str(out))) == 0
    model = load_codebook(out)
    assert np.bincount(model.template_labels_).tolist() == [2, 2]
    assert 'resuming' in capsys.readouterr().err


# ----------------------------------------------------------------------------- live, over DDS
class LiveGraph:
    """A simulated-time skin graph in this process and the recorder in a child process, over DDS."""

    def __init__(self, scene, argv, domain):
        from touch_graph.runtime import Context, SingleThreadedExecutor

        forget_devices()
        forget_stimuli()
        register_stimulus('skin-record-live', scene)
        self.ctx = Context('sim', network=True)
        self.ctx.init()
        self.executor = SingleThreadedExecutor(context=self.ctx)
        self.lines: list[str] = []
        env = {**os.environ, 'ROS_DOMAIN_ID': str(domain)}
        command = [sys.executable, '-m', 'touch_lab.cli.main', 'codebook', 'record', '--wait', '0.2', *argv]
        self.proc = subprocess.Popen(command, cwd=REPO, env=env, stdin=subprocess.PIPE, stderr=subprocess.PIPE,
                                     text=True)
        threading.Thread(target=self._read, daemon=True).start()
        self.driver = None

    def _read(self):
        for text in self.proc.stderr:
            self.lines.append(text.rstrip('\n'))

    def wait_for(self, fragment, timeout_s=30.0):
        deadline = time.monotonic() + timeout_s
        while not any(fragment in x for x in self.lines):
            if time.monotonic() > deadline or (self.proc.poll() is not None and not any(fragment in x
                                                                                         for x in self.lines)):
                time.sleep(0.2)
                raise AssertionError(f'no line with {fragment!r} from the recorder; it said: {self.lines}')
            time.sleep(0.02)

    def start_driver(self):
        """Once the recorder listens: the skin driver starts (and simulated time with it)."""
        from touch_driver.skin.node import SkinDriverNode
        from touch_graph.runtime import Parameter

        deadline = time.monotonic() + 30.0
        while time.monotonic() < deadline:  # the recorder's subscription is in the graph
            topic = self.ctx.transport.graph.view().topics.get('/skin/frame')
            if topic is not None and topic.subscriptions:
                break
            time.sleep(0.05)
        self.driver = SkinDriverNode(context=self.ctx, namespace='skin', cli_args=['--ros-args', '--log-level',
                                                                                   'error'],
                                     parameter_overrides=[Parameter('port', value='skinsim://live?scene='
                                                                    'skin-record-live&seed=2')])
        self.executor.add_node(self.driver)
        self.t0 = self.ctx.now_ns()

    def run_until(self, scene_s):
        """Spin to scene time ``scene_s`` at about 4x real time (frames go over DDS best effort, on this host)."""
        while (self.ctx.now_ns() - self.t0) / 1e9 < scene_s:
            self.executor.spin_for(0.02)
            time.sleep(0.005)

    def say(self, text):
        self.proc.stdin.write(text)
        self.proc.stdin.flush()

    def close(self):
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(10)
        if self.driver is not None:
            self.driver.destroy_node()
        self.ctx.try_shutdown()
        forget_stimuli()


def strokes(*ends, first_s=1.5, every_s=1.5, for_s=0.7):
    return Timeline([LineStroke(a, b, 1.5, at_s=first_s + i * every_s, for_s=for_s) for i, (a, b) in enumerate(ends)])


RIGHT, LEFT = ((6, 23), (41, 23)), ((41, 25), (6, 24))


def test_live_recording_with_an_undo_writes_the_codebook(tmp_path, dds_domain):
    out = tmp_path / 'live.npz'
    live = LiveGraph(strokes(RIGHT, RIGHT, RIGHT, LEFT, LEFT),
                     ['--gestures', 'line_right,line_left', '-m', '2', '-o', str(out), '--person', 'ana'],
                     dds_domain)
    try:
        live.wait_for("trace 'line_right' (1/2)")
        live.start_driver()
        live.run_until(4.2)                       # two strokes done, the third not begun
        live.wait_for('kept line_right 2/2')
        live.say('u\n')                           # the second was bad: trace it again
        live.wait_for('undone: the last line_right')
        live.run_until(9.0)
        assert live.proc.wait(30) == 0, live.lines
    finally:
        live.close()
    assert [x for x in live.lines if x.startswith('kept')] == ['kept line_right 1/2', 'kept line_right 2/2',
                                                               'kept line_right 2/2', 'kept line_left 1/2',
                                                               'kept line_left 2/2']
    model = load_codebook(out)
    assert list(model.classes_) == ['line_left', 'line_right'] and len(model.templates_) == 4
    assert model.description_.startswith('recorded on the skin (/skin/frame)')
    assert list(model.template_people_) == ['ana'] * 4


def test_live_recording_stopped_by_ctrl_c_saves_what_was_recorded(tmp_path, dds_domain):
    out = tmp_path / 'live.npz'
    live = LiveGraph(strokes(RIGHT), ['--gestures', 'line_right,line_left', '-m', '2', '-o', str(out)], dds_domain)
    try:
        live.wait_for("trace 'line_right' (1/2)")
        live.start_driver()
        live.run_until(3.0)
        live.wait_for('kept line_right 1/2')
        live.proc.send_signal(signal.SIGINT)
        assert live.proc.wait(30) == 1
    finally:
        live.close()
    partial = tmp_path / 'live.partial.npz'
    assert any(f'Resume with: social-touch codebook record --resume {partial} -o {out}' in x for x in live.lines)
    assert not out.exists()
    rec = load_recording(partial)
    assert rec.labels == ['line_right'] and rec.current == 'line_right' and rec.count('line_right') == 1
