"""Scoring a shipped subtype model on sessions without retraining (touch_lab/bear/shipped.py, eval bear --model)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import pytest

from touch_gestures.bear.symbolic import GestureLibrary
from touch_lab.bear.shipped import score_symbolic_starts
from touch_lab.cli.main import main as cli_main
from touch_lab.collect.session_bag import LabelRow

LIB = GestureLibrary.default()


def run_of(*labels):
    rows = [LabelRow('p01', g, 'normal', a, b) for g, a, b in labels]
    return SimpleNamespace(labels=[r for r in rows if '/' not in r.gesture],
                           gestures=[r for r in rows if '/' in r.gesture])


def test_false_starts_are_counted_once_by_cause_and_a_gestures_own_subtype_is_not_false():
    run = run_of(('symbolic/head_pat', 10.0, 15.0), ('pat', 20.0, 24.0), ('pet', 30.0, 36.0),
                 ('symbolic/hug', 40.0, 46.0))
    starts = [('head_pat', 12.0),       # detected
              ('head_pat', 21.0),       # a pat on the crown: a head pat, not false
              ('shoulder_tap', 22.0),   # a pat on the shoulder: false (subtype trial)
              ('shoulder_tap', 33.0),   # a pet: false (subtype trial)
              ('tickle', 41.0),         # during a hug: false (other gesture)
              ('feeding', 60.0)]        # outside every trial
    out = score_symbolic_starts([run], [starts], LIB)
    assert out['head_pat']['trials'] == 1 and out['head_pat']['detected'] == 1
    assert out['head_pat']['latencies_s'] == [2.0] and out['head_pat']['false_starts'] == 0
    assert out['shoulder_tap']['false_starts_by_cause'] == {'other_gesture': 0, 'subtype_trial': 2, 'outside_trials': 0}
    assert out['tickle']['false_starts_by_cause']['other_gesture'] == 1
    assert out['feeding']['false_starts_by_cause']['outside_trials'] == 1
    assert out['hug']['trials'] == 1 and out['hug']['detected'] == 0


@pytest.fixture(scope='module')
def bags(tmp_path_factory):
    root = tmp_path_factory.mktemp('shipped')
    assert cli_main(['collect', 'bear', '--simulate', '2', '--gestures', 'poke,hold,pat', '--repetitions', '2',
                     '--symbolic', '--pause-s', '2', '--seed', '7', '--out', str(root / 'bear')]) == 0
    return sorted(str(p) for p in (root / 'bear').iterdir())


def test_eval_bear_model_scores_the_given_file_on_every_person(bags, capsys, tmp_path):
    capsys.readouterr()
    assert cli_main(['eval', 'bear', '--bags', *bags, '--model', 'config/bear_subtype_model.npz', '--json',
                     '--quiet']) == 0
    report = json.loads(capsys.readouterr().out)
    assert report['synthetic'] and report['people'] == ['p01', 'p02'] and 'not retrained' in report['method']
    assert report['model']['trials'] == 12 and report['rule']['trials'] == 12
    sym = report['symbolic']
    assert sym['trials'] == sum(g['trials'] for g in sym['per_gesture'].values()) > 0
    assert sym['false_starts'] == sum(g['false_starts'] for g in sym['per_gesture'].values())
    assert 'median over all detected trials' in report['statistics']['median_latency_s']
    # one person is enough to score a given model (leave-one-person-out needs two)
    assert cli_main(['eval', 'bear', '--bags', bags[0], '--model', 'config/bear_subtype_model.npz', '--quiet']) == 0
    # a model of another scan rate is refused, naming both rates
    assert cli_main(['eval', 'bear', '--bags', *bags, '--model', 'config/bear_subtype_model.npz', '--rate', '25',
                     '--quiet']) == 2
    assert 'trained at 3.4 Hz' in capsys.readouterr().err


def test_train_bear_out_is_a_deprecated_alias_of_output(bags, tmp_path, capsys):
    assert cli_main(['train', 'bear', '--bags', *bags, '--out', str(tmp_path / 'm.npz')]) == 0
    assert '--out is deprecated; use -o/--output' in capsys.readouterr().err and (tmp_path / 'm.npz').exists()


def test_the_report_section_names_each_family_and_the_shipped_model():
    from touch_gestures.bear.subtype_labels import SUBTYPES
    from touch_lab.bear.report import populations_md
    labels = list(SUBTYPES)
    confusion = [[0] * len(labels) for _ in labels]
    confusion[1][1] = 3
    one = {'subtype_accuracy': 0.5, 'lowest_class_recall': 0.0, 'recall': {'pet': 1.0},
           'reached_threshold': {'pet': 1.0, 'tap': 0.25}, 'median_subtype_latency_s': 0.9,
           'symbolic_detected': 0.75, 'symbolic_labelled': 4, 'symbolic_false_alarms': 2,
           'symbolic_false_alarms_by_gesture': {'head_pat': 0, 'shoulder_tap': 2},
           'symbolic_starts_during_subtype_touches': 1, 'median_symbolic_latency_s': 2.4,
           'symbolic_recall': {'head_pat': 1.0, 'shoulder_tap': 0.5},
           'symbolic_labelled_by_gesture': {'head_pat': 2, 'shoulder_tap': 2}, 'confusion': confusion, 'labels': labels}
    cross = {'families': ['script', 'hands'], 'scores': {'fit on script': {'script': one, 'hands': one},
                                                         'shipped model': {'script': one, 'hands': one}},
             'config': {'n_people': 6, 'train_people': 8, 'seed': 0}}
    text = '\n'.join(populations_md(cross, 'shipped model'))
    assert '### Shipped model on the `hands` family' in text and '### Shipped model on the `script` family' in text
    assert '| shoulder_tap | 2 | 0.50 | 2 |' in text and '| all | 4 | 0.75 | 2 |' in text
    assert '| shipped model | 0.50 | 0.00 | 0.75 | 2 | 0.50 | 0.00 | 0.75 | 2 |' in text
    assert 'no-touch gate can name' in text and 'pet 1.00, tap 0.25.' in text
