"""Codebook files (npz, no pickle, checked at load) and the recorder."""

from __future__ import annotations

import json

import numpy as np
import pytest

from touch_gestures.skin import CodebookRecorder, TouchGesture, load_codebook, make_recogniser, save_codebook
from touch_gestures.skin.errors import CodebookError
from touch_sim.skin.synthetic import PAPER_CENTROID_SET, synthetic_traces


def gestures(seed=0, performers=2):
    traces = synthetic_traces(PAPER_CENTROID_SET, performers=performers, repetitions=2, seed=seed, rate_hz=150.0)
    return ([TouchGesture.from_trajectory(np.column_stack([s.x, s.y]), s.t_ms / 1000) for s in traces],
            [s.gesture for s in traces])


@pytest.mark.parametrize('name', ['trace', 'centroid', 'map', 'static'])
def test_round_trip_gives_the_same_answers(tmp_path, name):
    train, labels = gestures()
    model = make_recogniser(name, auto_scale=2.5).fit(train, labels)
    path = save_codebook(tmp_path / 'book', model)
    assert path.suffix == '.npz'
    with np.load(path, allow_pickle=False) as z:  # nothing in it needs pickle
        assert str(z['recogniser']) == name and int(z['format_version']) == 2
    back = load_codebook(path)
    assert type(back) is type(model) and back.get_params() == model.get_params()
    queries, _ = gestures(seed=1, performers=1)
    for q in queries:
        assert back.predict(q) == model.predict(q)
    np.testing.assert_array_equal(back.class_thresholds_, model.class_thresholds_)


def _tamper(tmp_path, **changes):
    train, labels = gestures()
    path = save_codebook(tmp_path / 'book.npz', make_recogniser('trace').fit(train, labels))
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files}
    data.update(changes)
    np.savez(path, **data)
    return path


@pytest.mark.parametrize('changes, message', [
    ({'format_version': np.array(3)}, 'format_version 3 is not supported'),
    ({'gap_s': np.array(-1.0)}, 'gap_s must be >= 0'),
    ({'format': np.array('something.else')}, "expected 'social_touch.skin_codebook'"),
    ({'recogniser': np.array('trase')}, "did you mean 'trace'"),
    ({'params': np.array(json.dumps({'n_points': 16}))}, 'templates have 64 features but trace'),
    ({'params': np.array(json.dumps({'n_pionts': 32}))}, "did you mean 'n_points'"),
    ({'class_thresholds': np.ones(2)}, 'do not fit together'),
    ({'template_labels': np.full(20, 9)}, 'do not fit together'),
])
def test_a_bad_codebook_is_refused_with_a_reason(tmp_path, changes, message):
    path = _tamper(tmp_path, **changes)
    with pytest.raises(CodebookError, match=message) as info:
        load_codebook(path)
    assert str(path) in str(info.value)


@pytest.mark.parametrize('name', ['refereed', 'fused_oriented', 'ndollar', 'cloud', 'dollar1'])
def test_a_codebook_of_a_lab_recogniser_loads_in_the_lab_and_not_on_the_robot(tmp_path, name):
    from touch_lab.skin import recognisers as lab
    train, labels = gestures()
    model = lab.make_recogniser(name).fit(train, labels)
    with pytest.raises(ValueError, match='not in the registry'):
        save_codebook(tmp_path / 'runtime.npz', model)   # the runtime's registry does not name it
    path = lab.save_codebook(tmp_path / 'lab.npz', model)
    assert lab.load_codebook(path).predict(train[0]) == model.predict(train[0])
    with pytest.raises(CodebookError) as info:
        load_codebook(path)
    message = str(info.value)   # what, why, how to fix
    assert f"made with recogniser '{name}', which the robot does not run" in message
    assert 'touch_lab.skin.recognisers' in message
    assert '--recogniser trace' in message and '--recogniser fused' in message and str(path) in message


def test_auto_saves_the_recogniser_it_chose_which_the_robot_loads(tmp_path):
    from touch_lab.skin import recognisers as lab
    train, labels = gestures()
    auto = lab.make_recogniser('auto').fit(train, labels)
    back = load_codebook(lab.save_codebook(tmp_path / 'auto.npz', auto))
    assert back.name == auto.choice_ in ('trace', 'fused')
    assert back.predict(train[1]) == auto.predict(train[1])


def test_vocabulary_and_gap_round_trip_and_version_1_still_reads(tmp_path):
    train, labels = gestures()
    model = make_recogniser('trace').fit(train, labels)
    assert model.max_strokes_ == 1
    back = load_codebook(save_codebook(tmp_path / 'symbols', model, vocabulary='symbols', gap_s=1.5))
    assert (back.vocabulary_, back.gap_s_, back.max_strokes_) == ('symbols', 1.5, 1)
    default = load_codebook(save_codebook(tmp_path / 'commands', model))
    assert (default.vocabulary_, default.gap_s_) == ('commands', 0.15)
    # A version 1 file (no vocabulary arrays): the single-stroke commands, as the skin shipped them.
    path = tmp_path / 'commands.npz'
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files if k not in ('vocabulary', 'gap_s', 'max_strokes')}
    np.savez(tmp_path / 'v1.npz', **{**data, 'format_version': np.array(1)})
    old = load_codebook(tmp_path / 'v1.npz')
    assert (old.vocabulary_, old.gap_s_, old.max_strokes_) == ('commands', 0.15, 1)
    np.savez(tmp_path / 'v2bad.npz', **data)
    with pytest.raises(CodebookError, match='needs vocabulary, gap_s and max_strokes'):
        load_codebook(tmp_path / 'v2bad.npz')
    with pytest.raises(ValueError, match='vocabulary name and a gap'):
        save_codebook(tmp_path / 'x', model, gap_s=float('nan'))


def test_missing_wrong_kind_and_pickled_files(tmp_path):
    with pytest.raises(CodebookError, match='not found'):
        load_codebook(tmp_path / 'none.npz')
    path = _tamper(tmp_path)
    with pytest.raises(CodebookError, match="made for recogniser 'trace', not 'centroid'"):
        load_codebook(path, recogniser='centroid')
    evil = tmp_path / 'evil.npz'
    np.savez(evil, format=np.array([{'a': 1}], dtype=object))
    with pytest.raises(CodebookError, match='not a readable codebook'):
        load_codebook(evil)
    with pytest.raises(ValueError, match='no codebook yet'):
        save_codebook(tmp_path / 'x.npz', make_recogniser('trace'))


def test_recorder_collects_m_repetitions_and_refuses_bad_touches():
    train, labels = gestures()
    rec = CodebookRecorder(['line_right', 'one'], repetitions=2)
    line = train[labels.index('line_right')]
    two_fingers = TouchGesture.from_trajectory(line.trajectory)
    two_fingers.multi_contact = True
    resting = TouchGesture.from_trajectory(line.trajectory)
    resting.truncated = True
    assert rec.add(two_fingers)[0] is False and 'two fingers' in rec.add(two_fingers)[1]
    assert rec.add(resting)[0] is False
    assert rec.add(line) == (True, 'line_right 1/2')
    assert rec.undo() == 'line_right'
    rec.add(line)
    rec.add(line)
    assert rec.current == 'one'
    with pytest.raises(ValueError, match='no repetition recorded yet for: one'):
        rec.fit(make_recogniser('trace'))
    rec.add(train[labels.index('one')])
    assert rec.add(train[labels.index('one')]) == (True, 'one 2/2') and rec.done and rec.current is None
    model = rec.fit(make_recogniser('trace'))
    assert list(model.classes_) == ['line_right', 'one']
    with pytest.raises(ValueError):
        CodebookRecorder(['a', 'a'])
