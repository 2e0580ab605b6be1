"""Evaluation of the bear recognisers on simulated people (synthetic), the CLI, the benchmark, the report."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

from touch_gestures.bear.symbolic import START, GestureLibrary, SymbolicEvent
from touch_lab.bear import cli
from touch_lab.bear.bench import bench_cycle
from touch_lab.bear.evaluate import EvalConfig, evaluate, score_subtypes, score_symbolic
from touch_lab.bear.report import alias_table, rates_md
from touch_sim.bear.people import BearScene, Contact, Label

TINY = dict(n_people=1, train_people=2, subtype_reps=1, gesture_reps=2, seed=3)


@pytest.fixture(scope='module')
def tiny_result() -> dict:
    """One simulated person on the virtual bear read by the bear_driver node (the robot's decoder and calibrator)."""
    return evaluate(EvalConfig(**TINY))


def test_evaluation_reports_every_figure(tiny_result: dict) -> None:
    r = tiny_result
    assert 'synthetic' in r['data']
    for key in ('subtype_accuracy', 'symbolic_accuracy', 'median_detection_latency_s', 'us_per_cycle'):
        assert isinstance(r[key], float), key
    assert 0 <= r['subtype_accuracy'] <= 1 and 0 <= r['symbolic_accuracy'] <= 1
    assert r['driver']['frames'] >= r['cycles'] and r['driver']['checksum_errors'] == 0
    for who in ('model', 'rule'):
        sub = r[who]['subtype']
        assert np.array(sub['confusion']).sum() == sub['interactions'] == 8
        assert np.array(sub['frame_confusion']).shape == (9, 9)
        sym = r[who]['symbolic']
        assert np.array(sym['confusion']).shape == (10, 10) and sym['labelled'] == 18
        assert set(sym['table_iii']) == {'head_pat', 'tickle', 'hug', 'foot_rub'}
        for row in sym['table_iii'].values():
            assert row['activated_first_try'] <= row['activated_with_explanation']
    json.dumps(r)                                              # JSON-ready


def test_the_rule_cannot_name_subtypes_it_does_not_know(tiny_result: dict) -> None:
    rule = tiny_result['rule']['subtype']
    predicted = np.array(rule['confusion']).sum(axis=0)
    labels = rule['labels']
    for name in ('pat', 'tap', 'shake', 'rub'):
        assert predicted[labels.index(name)] == 0


def test_trained_model_beats_the_rule_on_simulated_people() -> None:
    r = evaluate(EvalConfig(n_people=2, train_people=3, subtype_reps=2, gesture_reps=1, seed=0))
    assert r['subtype_accuracy'] > r['rule_subtype_accuracy'] + 0.2


def test_symbolic_scoring_rules() -> None:
    lib = GestureLibrary.default()
    labels = [Label(10.0, 14.0, 'symbolic', 'hug', ('back_upper',), 0, 1),
              Label(20.0, 24.0, 'symbolic', 'head_pat', ('head1',), 0, 1),
              Label(30.0, 34.0, 'subtype', 'pet', ('head2',), 0, 1)]
    scene = BearScene([Contact(1, 30.0, 34.0, 'pet', 1.0)], labels, 50.0)
    run = type('Run', (), {'times': np.arange(0, 50, 0.5), 'active': np.zeros((100, 64), dtype=bool)})()
    events = [SymbolicEvent('hug', START, 12.0, 10.0, 2.0, ()),          # detected, 2 s latency
              SymbolicEvent('tickle', START, 21.0, 19.0, 2.0, ()),       # head_pat confused with tickle
              SymbolicEvent('head_pat', START, 32.0, 30.0, 2.0, ()),     # during a subtype touch: counted apart
              SymbolicEvent('foot_rub', START, 45.0, 43.0, 2.0, ())]     # in a pause: a false alarm
    score = score_symbolic(scene, run, events, lib)
    assert score['accuracy'] == 0.5 and score['false_alarms'] == 1 and score['starts_during_subtype_touches'] == 1
    assert score['median_latency_s'] == 2.0
    conf, names = np.array(score['confusion']), score['labels']
    assert conf[names.index('head_pat'), names.index('tickle')] == 1
    assert conf[names.index('none'), names.index('foot_rub')] == 1
    assert score['per_class']['hug'] == {'precision': 1.0, 'recall': 1.0, 'support': 1}


def test_subtype_scoring_takes_the_dominant_label_and_first_hit_latency() -> None:
    from touch_driver.bear.body_map import BodyMap

    body = BodyMap.default()
    labels = [Label(1.0, 5.0, 'subtype', 'pet', ('head2',), 0, 1)]
    scene = BearScene([Contact(1, 1.0, 5.0, 'pet', 1.0)], labels, 8.0)
    times = np.arange(0, 8, 0.5)
    codes = np.zeros((16, 64), dtype=np.int8)
    codes[2:5, 1] = 2        # poke for 1.5 s
    codes[5:10, 1] = 1       # then pet for 2.5 s
    truth = np.zeros((16, 64), dtype=np.int8)
    truth[2:10, 1] = 1
    active = truth > 0
    run = type('Run', (), {'times': times, 'truth': truth, 'active': active})()
    score = score_subtypes(scene, run, codes, body.fitted_mask(), body, 2.0)
    assert score['accuracy'] == 1.0 and score['median_latency_s'] == 1.5
    assert score['reached_threshold']['pet'] == 1.0 and score['reached_threshold']['tap'] is None


def test_a_touch_the_scan_never_saw_over_the_threshold_is_not_reached():
    from touch_driver.bear.body_map import BodyMap

    body = BodyMap.default()
    labels = [Label(1.0, 1.2, 'subtype', 'tap', ('head2',), 0, 1), Label(3.0, 3.2, 'subtype', 'tap', ('head2',), 0, 2)]
    scene = BearScene([Contact(1, 1.0, 1.2, 'tap', 0.6), Contact(1, 3.0, 3.2, 'tap', 0.6)], labels, 5.0)
    times = np.arange(0, 5, 0.5)
    active = np.zeros((10, 64), dtype=bool)
    active[6, 1] = True      # the second tap was read over the threshold at 3.0 s; the first never was
    run = type('Run', (), {'times': times, 'truth': np.zeros((10, 64), dtype=np.int8), 'active': active})()
    score = score_subtypes(scene, run, np.zeros((10, 64), dtype=np.int8), body.fitted_mask(), body, 2.0)
    assert score['reached_threshold']['tap'] == 0.5
    assert score['per_class']['tap']['recall'] == 0.0


def test_cli_json_and_text(capsys) -> None:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    args = parser.parse_args(['--json', '--people', '1', '--train-people', '1', '--reps', '1', '--quiet', '--seed',
                              '2'])
    assert cli.run(args) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ('subtype_accuracy', 'symbolic_accuracy', 'median_detection_latency_s', 'us_per_cycle'):
        assert key in out
    assert 'synthetic' in out['data']
    text = cli.format_text(out)
    assert 'synthetic' in text and 'Table III' in text and 'trained model' in text


def test_cli_rejects_bad_numbers() -> None:
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    for bad in (['--rate', '0'], ['--rate', 'fast'], ['--buffer', '0'], ['--people', '-1']):
        with pytest.raises(SystemExit):
            parser.parse_args(bad)


def test_bench_returns_its_figures() -> None:
    out = bench_cycle(repeats=1, cycles=30)
    assert out['sensors'] == 56 and out['features'] == 12 and out['goal_us'] == 200.0
    assert out['us_per_cycle'] > 0 and out['us_features'] > 0


def test_aliasing_measured_through_the_driver_node_matches_sampling_theory() -> None:
    """A 3 Hz stroke scanned at 3.4 Hz appears at 0.4 Hz; at 25 Hz it is seen as it is."""
    rows = alias_table(rates=(3.4, 25.0), freqs=(3.0,), buffer_len=40)
    measured, predicted = rows[0]['measured'], rows[0]['predicted']
    assert predicted[3.4] == pytest.approx(0.4) and predicted[25.0] == pytest.approx(3.0)
    assert measured[3.4] == pytest.approx(0.4, abs=3.4 / 40)        # within one frequency bin
    assert measured[25.0] == pytest.approx(3.0, abs=25.0 / 40)
    text = rates_md([], rows, 'cmd')
    assert '3.4 Hz measured / predicted' in text and 'synthetic' in text
