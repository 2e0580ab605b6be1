"""train and eval from session bags (``collect --simulate``): every sensor, jittering rates, bad input."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest

from touch_lab.cli.main import main as cli_main
from touch_lab.collect.session_bag import read_session

GESTURES = {'bear': 'poke,hold,pet', 'patch': 'stroke,slap', 'skin': 'line_right,line_up'}


@pytest.fixture(scope='module')
def sessions(tmp_path_factory):
    """Three simulated people per sensor, two repetitions of each class (SYNTHETIC)."""
    root = tmp_path_factory.mktemp('sessions')
    out = {}
    for sensor, gestures in GESTURES.items():
        assert cli_main(['collect', sensor, '--simulate', '3', '--gestures', gestures, '--repetitions', '2',
                         '--pause-s', '2', '--seed', '3', '--out', str(root / sensor)]) == 0
        out[sensor] = sorted(str(p) for p in (root / sensor).iterdir())
    return out


def test_patch_trains_and_evaluates_from_session_bags(sessions, tmp_path, capsys):
    from touch_gestures.patch.model_io import load_model
    model = tmp_path / 'patch.npz'
    assert cli_main(['train', 'patch', '--bags', *sessions['patch'], '-o', str(model), '--components', '2']) == 0
    loaded = load_model(model)
    assert list(loaded.classes) == ['slap', 'stroke'] and loaded.rate_hz == pytest.approx(20.0, rel=1e-3)
    capsys.readouterr()
    assert cli_main(['eval', 'patch', '--bags', *sessions['patch'], '--components', '2', '--thresholds', '0.99',
                     '--dwells-s', '0.25', '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['synthetic'] and len(report['subjects']) == 3
    assert report['n_events'] == 12   # 3 people x 2 classes x 2 repetitions, one event per trial
    assert report['event_correct'] > report['n_events'] / 2 and report['median_detection_latency_s'] is not None


def test_patch_accepts_rates_that_jitter_as_real_drivers_do(sessions):
    from touch_lab.patch.evaluate import leave_one_subject_out
    from touch_lab.patch.session_bags import trial_sessions
    recordings = [read_session(p, 'patch') for p in sessions['patch']]
    recordings[0].stamps_s['/patch/frame'] = recordings[0].stamps_s['/patch/frame'] / 1.0008   # 0.08 % faster
    trials = trial_sessions(recordings)
    assert len({round(s.rate_hz, 6) for s in trials}) == 2
    result = leave_one_subject_out(trials, n_components=(2,), thresholds=(0.99,), dwells_s=(0.25,))
    assert result.as_dict()['n_events'] == 12
    recordings[0].stamps_s['/patch/frame'] = recordings[0].stamps_s['/patch/frame'] / 1.5
    with pytest.raises(ValueError, match=r'frame rates differ by more than 2 %: .*patch_p01'):
        leave_one_subject_out(trial_sessions(recordings), n_components=(2,))


def test_bear_trains_the_subtype_model_and_evaluates_from_session_bags(sessions, tmp_path, capsys):
    from touch_lab.bear.subtype_training import SubtypeClassifier
    model = tmp_path / 'bear.npz'
    assert cli_main(['train', 'bear', '--bags', *sessions['bear'], '--out', str(model)]) == 0
    loaded = SubtypeClassifier.load(model)
    assert {'poke', 'hold', 'pet'} <= set(loaded.classes_) and loaded.trained_rate_hz_ == pytest.approx(3.4)
    capsys.readouterr()
    assert cli_main(['eval', 'bear', '--bags', *sessions['bear'], '--json', '--quiet']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['synthetic'] and report['people'] == ['p01', 'p02', 'p03']
    assert report['model']['trials'] == 18 and report['model']['accuracy'] > 1 / 3   # above chance of 3 classes
    assert report['model']['median_latency_s'] > 0


def test_skin_builds_extends_and_evaluates_a_codebook_from_session_bags(sessions, tmp_path, capsys):
    from touch_gestures.skin.codebook import load_codebook
    first = tmp_path / 'first.npz'
    assert cli_main(['train', 'skin', '--bags', *sessions['skin'][:2], '-o', str(first)]) == 0
    book = load_codebook(first)
    assert list(book.classes_) == ['line_right', 'line_up'] and 'SYNTHETIC' in book.description_
    grown = tmp_path / 'grown.npz'
    assert cli_main(['train', 'skin', '--bags', sessions['skin'][2], '--extend', str(first), '-o', str(grown)]) == 0
    assert len(load_codebook(grown).templates_) == len(book.templates_) + 4
    capsys.readouterr()
    assert cli_main(['eval', 'skin', '--bags', *sessions['skin'], '--json']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['trials'] == 12 and report['right'] + report['wrong'] + report['rejected'] + report['missed'] == 12
    assert report['right'] > 6


def test_bad_sessions_give_one_clear_line_not_a_traceback(sessions, tmp_path, capsys):
    # a bag of another sensor
    assert cli_main(['train', 'patch', '--bags', sessions['bear'][0], '-o', str(tmp_path / 'x.npz')]) == 1
    assert re.search(r'error: .*bear_p01 has no /patch/frame .*it is a bear session', capsys.readouterr().err)
    # one person cannot be left out
    assert cli_main(['eval', 'bear', '--bags', sessions['bear'][0], '--quiet']) == 2
    assert 'at least two people' in capsys.readouterr().err
    assert cli_main(['eval', 'skin', '--bags', sessions['skin'][0]]) == 2
    assert 'at least two people' in capsys.readouterr().err
    # a class with too few examples says which class and what to do
    from touch_lab.bear.sessions import bear_trials, fit_model
    from touch_lab.collect.session_bag import SessionError
    run = bear_trials(read_session(sessions['bear'][0], 'bear'), 3.4, 20)
    run.truth[run.truth == 2] = 0   # poke (code 2): no sensor-cycle left ...
    run.truth[:5, np.flatnonzero(run.fitted)[0]] = 2   # ... but five
    with pytest.raises(SessionError, match=r"class 'poke' has 5 sensor-cycle\(s\) to learn from .*record more"):
        fit_model([run])
    # the patch's mixtures: a class with fewer frames than components
    with pytest.raises(SystemExit, match=r'train patch: .*slap'):
        cli_main(['train', 'patch', '--bags', *sessions['patch'], '-o', str(tmp_path / 'x.npz'), '--components',
                  '5000'])
