"""``social-touch train patch`` / ``eval patch``, through the ``social-touch`` CLI."""

import argparse
import json

import numpy as np
import pytest

from touch_gestures.patch.model_io import load_model
from touch_lab.cli.main import main as social_touch
from touch_lab.patch.cli import add_eval_arguments, add_train_arguments
from touch_sim.patch.people import simulate_people


def main(argv):
    """``social-touch train|eval patch ARGS``."""
    return social_touch([argv[0], 'patch', *argv[1:]])


def stand_in_activations(scene, seed: int) -> np.ndarray:
    """(T, 16, 16) activations at 20 Hz made straight from the scene's pressure (test data, no sensor)."""
    rng = np.random.default_rng(seed)
    frames = []
    for f in range(int(scene.duration_s * 20)):
        pressure = np.mean([scene.pressure((5 * f + s) / 100.0) for s in range(5)], axis=0)
        frames.append(np.clip(pressure / 4.0 + rng.normal(0.0, 0.01, pressure.shape), 0.08, 1.0))
    return np.asarray(frames, dtype=np.float32)


@pytest.fixture(scope='module')
def cost_csv(tmp_path_factory):
    """Simulated people written as a CoST-layout CSV: 8x8 (2x2 max-pooled), raw counts (SYNTHETIC test data:
    the scene's pressure averaged over 5 scans, scaled to full activation at 4 N/cm^2, with noise)."""
    path = tmp_path_factory.mktemp('csv') / 'people.csv'
    lines = ['subject,variant,gesture,frame,' + ','.join(f'ch{i + 1}' for i in range(64))]
    for i, (person, gesture, scene) in enumerate(simulate_people(3, 2, seed=9)):
        acts = stand_in_activations(scene, seed=i)
        pooled = acts.reshape(len(acts), 8, 2, 8, 2).max(axis=(2, 4))
        counts = np.rint(30 + 400 * (pooled - 0.08)).astype(int)
        for f, frame in enumerate(counts):
            lines.append(f'{person.name},normal,{gesture},{f},' + ','.join(map(str, frame.ravel())))
    path.write_text('\n'.join(lines) + '\n')
    return path


def test_train_and_eval_on_a_cost_csv(tmp_path, cost_csv, capsys):
    model_path = tmp_path / 'patch.npz'
    assert main(['train', '--csv', str(cost_csv), '--grid', '8x8', '--rate', '20', '--gain', str(1 / 400),
                 '--components', '2', '--dwell-s', '0.25', '-o', str(model_path)]) == 0
    model = load_model(model_path, grid=(8, 8))
    assert model.classes == ('push', 'slap', 'stroke', 'tickle')
    assert (model.window, model.dwell, model.rate_hz) == (60, 5, 20.0)
    assert 'wrote' in capsys.readouterr().err
    assert main(['eval', '--csv', str(cost_csv), '--grid', '8x8', '--rate', '20', '--gain', str(1 / 400),
                 '--components', '1,2', '--thresholds', '0.99', '--dwells-s', '0.4', '--json', '--quiet']) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ('event_correct', 'false_detections', 'misses', 'median_detection_latency_s', 'us_per_frame'):
        assert key in out
    assert out['synthetic'] is False  # the CSV does not say; the caller labels it
    assert len(out['grid']) == 2 and out['n_events'] > 0


def test_eval_simulated_people_json(capsys):
    assert main(['eval', '--simulate', '2', '--events', '1', '--components', '1',
                 '--thresholds', '0.99', '--dwells-s', '0.4', '--json', '--quiet']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['synthetic'] is True and out['source'].startswith('simulated people: 2')
    assert out['n_events'] == 8


def test_eval_text_report(capsys):
    assert main(['eval', '--simulate', '2', '--events', '1', '--components', '1',
                 '--thresholds', '0.99', '--dwells-s', '0.4']) == 0
    captured = capsys.readouterr()
    assert 'SYNTHETIC' in captured.out and 'event confusion' in captured.out and 'not recognised' in captured.out
    assert '[patch] simulating p1' in captured.err


def test_errors_are_clear(tmp_path, capsys):
    with pytest.raises(SystemExit, match='--grid ROWSxCOLS and --rate'):
        main(['eval', '--csv', 'x.csv'])
    bad = tmp_path / 'bad.csv'
    bad.write_text('subject,variant,gesture,frame,ch1\n')
    assert main(['train', '--csv', str(bad), '--grid', '2x2', '--rate', '20', '-o', str(tmp_path / 'm.npz')]) == 1
    assert 'social-touch train: error:' in (err := capsys.readouterr().err) and 'channel columns' in err
    with pytest.raises(SystemExit):
        main(['eval', '--simulate', '2', '--components', 'three'])
    with pytest.raises(SystemExit, match='at least 2 people'):
        main(['eval', '--simulate', '1'])


def test_parsers_can_be_mounted_elsewhere():
    parser = argparse.ArgumentParser()
    add_train_arguments(parser)
    args = parser.parse_args(['--simulate', '3', '-o', 'm.npz'])
    assert args.components == 5 and args.threshold == 0.99 and args.window_s == 3.0
    parser = argparse.ArgumentParser()
    add_eval_arguments(parser)
    args = parser.parse_args(['--bags', 'm.yaml', '--components', '3,5'])
    assert args.components == [3, 5] and args.thresholds == [0.9, 0.99, 0.999]


@pytest.mark.parametrize('add, old, new, dest, value', [
    (add_train_arguments, '--hold-s', '--dwell-s', 'dwell_s', 0.25),
    (add_eval_arguments, '--holds-s', '--dwells-s', 'dwells_s', [0.25]),
])
def test_old_dwell_option_spelling_still_works_with_a_warning(add, old, new, dest, value, capsys):
    parser = argparse.ArgumentParser()
    add(parser)
    argv = ['--simulate', '2', '-o', 'unused.npz'] if add is add_train_arguments else ['--simulate', '2']
    assert getattr(parser.parse_args([*argv, new, '0.25']), dest) == value
    assert 'deprecated' not in capsys.readouterr().err
    assert getattr(parser.parse_args([*argv, old, '0.25']), dest) == value
    assert f'{old} is deprecated: use {new}' in capsys.readouterr().err
    assert old not in parser.format_help()
