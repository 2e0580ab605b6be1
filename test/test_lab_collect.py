"""Recording sessions: the protocol, ``collect --simulate`` for every sensor, and the session bag's checks."""

from __future__ import annotations

import numpy as np
import pytest

from touch_graph.messages import get_message
from touch_lab.cli.main import main as cli_main
from touch_lab.collect.protocol import Protocol
from touch_lab.collect.session_bag import SessionError, SessionWriter, read_session

_NS = 1_000_000_000
BASE_NS = 1_700_000_000 * _NS


def test_protocol_shuffles_every_trial_once_and_repeats_with_its_seed():
    p = Protocol(('stroke', 'slap', 'push'), variants=('gentle', 'rough'), repetitions=3, seed=4)
    trials = p.trials()
    assert len(trials) == 18 and len(set(trials)) == 18
    assert trials == p.trials() and trials != Protocol(p.gestures, p.variants, 3, seed=5).trials()
    assert [t.gesture for t in trials] != sorted(t.gesture for t in trials)  # shuffled, not blocked
    with pytest.raises(ValueError, match='two different gestures'):
        Protocol(('stroke',))
    with pytest.raises(ValueError, match='repetitions'):
        Protocol(('stroke', 'slap'), repetitions=0)


@pytest.mark.parametrize(('sensor', 'gestures', 'topic'), [
    ('bear', 'poke,hold', '/bear/frame'),
    ('patch', 'stroke,slap', '/patch/frame'),
    ('skin', 'line_right,line_up', '/skin/frame'),
])
def test_collect_simulate_writes_one_labelled_bag_per_person(tmp_path, capsys, sensor, gestures, topic):
    out = tmp_path / sensor
    assert cli_main(['collect', sensor, '--simulate', '2', '--gestures', gestures, '--repetitions', '2',
                     '--variants', 'gentle,rough', '--pause-s', '2', '--out', str(out)]) == 0
    assert 'SYNTHETIC' in capsys.readouterr().err
    for name in ('p01', 'p02'):
        session = read_session(out / f'{sensor}_{name}', sensor)
        assert session.synthetic and session.people == [name]
        assert len(session.labels) == 8   # 2 gestures x 2 variants x 2 repetitions
        assert sorted({(lab.gesture, lab.variant) for lab in session.labels}) == sorted(
            (g, v) for g in gestures.split(',') for v in ('gentle', 'rough'))
        stamps = session.stamps_s[topic]
        assert len(stamps) > 10 and np.all(np.diff(stamps) > 0)
        for lab in session.labels:   # every label lies inside the recording, after the calibrator's lead-in
            assert 0.5 < lab.start_s < lab.end_s <= stamps[-1]
    with pytest.raises(SystemExit, match='exists already'):
        cli_main(['collect', sensor, '--simulate', '1', '--gestures', gestures, '--out', str(out)])


def test_collect_refuses_a_gesture_the_simulated_sensor_cannot_perform(tmp_path):
    with pytest.raises(SystemExit, match='unknown'):
        cli_main(['collect', 'patch', '--simulate', '1', '--gestures', 'stroke,hug', '--out', str(tmp_path / 'x')])


def test_collect_bear_symbolic_adds_the_gestures_labelled_apart_from_the_subtypes(tmp_path, capsys):
    out = tmp_path / 'bear'
    assert cli_main(['collect', 'bear', '--simulate', '1', '--gestures', 'tickle,hold', '--symbolic', 'tickle,hug',
                     '--repetitions', '1', '--pause-s', '2', '--out', str(out)]) == 0
    session = read_session(out / 'bear_p01', 'bear')
    assert sorted(lab.gesture for lab in session.labels) == ['hold', 'symbolic/hug', 'symbolic/tickle', 'tickle']
    hug = next(lab for lab in session.labels if lab.gesture == 'symbolic/hug')
    levels = np.array([m.level for m in session.frames['/bear/frame']])
    during = (session.stamps_s['/bear/frame'] >= hug.start_s) & (session.stamps_s['/bear/frame'] <= hug.end_s)
    assert ((levels[during] >= 0.3).sum(axis=1) >= 3).any()    # arms around the bear: several sensors at once
    with pytest.raises(SystemExit, match=r'unknown gestures hugg; the gestures touch can tell are: .*hug'):
        cli_main(['collect', 'bear', '--simulate', '1', '--symbolic', 'hugg', '--out', str(tmp_path / 'x')])
    with pytest.raises(SystemExit, match='--symbolic is for the bear'):
        cli_main(['collect', 'patch', '--simulate', '1', '--symbolic', '--out', str(tmp_path / 'y')])
    with pytest.raises(SystemExit, match='unknown'):   # a gesture touch cannot tell is not simulated
        cli_main(['collect', 'bear', '--simulate', '1', '--gestures', 'poke,symbolic/rocking',
                  '--out', str(tmp_path / 'z')])


# ----------------------------------------------------------------------------- bad session bags
def _bear_bag(path, labels=(), frames=20, rate_hz=3.4, with_label_topic=True):
    """A bear session bag of ``frames`` flat frames and ``labels`` (person, gesture, start_s, end_s)."""
    BearFrame = get_message('social_touch_msgs/msg/BearFrame')
    writer = SessionWriter(path, 'bear', synthetic=False, flush_period_s=None)
    with writer:
        for i in range(frames):
            ns = BASE_NS + round(i / rate_hz * _NS)
            msg = BearFrame(level=np.zeros(64, np.float32))
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, _NS)
            writer.write('/bear/frame', msg, ns)
        for person, gesture, start, end in labels:
            writer.label(person, gesture, '', BASE_NS + round(start * _NS), BASE_NS + round(end * _NS),
                         BASE_NS + round(end * _NS))
    if not with_label_topic:   # a plain recording: rewrite without the label topic
        import shutil
        shutil.rmtree(path)
        from touch_graph.bag import BagRecorder
        from touch_graph.messages import serialize
        with BagRecorder(path, flush_period_s=None) as bag:
            for i in range(frames):
                ns = BASE_NS + round(i / rate_hz * _NS)
                msg = BearFrame(level=np.zeros(64, np.float32))
                msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(ns, _NS)
                bag.write('/bear/frame', 'social_touch_msgs/msg/BearFrame', ns, serialize(msg))
    return path


def test_a_bag_without_labels_is_refused_naming_it(tmp_path):
    bag = _bear_bag(tmp_path / 'plain', with_label_topic=False)
    with pytest.raises(SessionError, match=r'plain has no labels \(/touch/label\)'):
        read_session(bag, 'bear')


def test_overlapping_labels_are_refused_naming_bag_and_time(tmp_path):
    bag = _bear_bag(tmp_path / 'overlap', [('p1', 'poke', 1.0, 3.0), ('p1', 'hold', 2.5, 4.0)])
    with pytest.raises(SessionError, match=r'overlap at 2\.50 s: .*overlaps'):
        read_session(bag, 'bear')


def test_a_label_outside_the_recording_is_refused(tmp_path):
    bag = _bear_bag(tmp_path / 'outside', [('p1', 'poke', 1.0, 3.0), ('p1', 'hold', 4.0, 60.0)])
    with pytest.raises(SessionError, match=r'outside at 4\.00 s: .*outside the recording'):
        read_session(bag, 'bear')


def test_a_bag_of_another_sensor_says_which_sensor_it_is(tmp_path):
    bag = _bear_bag(tmp_path / 'bearbag', [('p1', 'poke', 1.0, 3.0)])
    with pytest.raises(SessionError, match='it is a bear session'):
        read_session(bag, 'patch')
    with pytest.raises(SessionError, match='not found'):
        read_session(tmp_path / 'nothing', 'bear')
