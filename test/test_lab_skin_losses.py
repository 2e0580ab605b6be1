"""Where each right command is lost (issue 26): the loss breakdown of the skin evaluation.

Synthetic only: hand-made matches, and a few synthetic performers through the virtual skin.
"""

from __future__ import annotations

import json

import pytest
from doctest_testing import check_doctests

import touch_lab.skin.evaluate
from touch_gestures.skin.base import Match
from touch_lab.cli.main import main as social_touch
from touch_lab.skin.datasets import write_traces
from touch_lab.skin.evaluate import LOSS_REASONS, format_losses, leave_one_subject_out, loss_reason
from touch_lab.skin.recognisers import make_recogniser
from touch_sim.skin.render import RenderSettings, render_samples
from touch_sim.skin.synthetic import synthetic_traces

SHAPES = ('line_right', 'line_left', 'diagonal_down')


@pytest.mark.parametrize(('match', 'cut', 'screened', 'reason'), [
    (Match('a', 0.1, 0.5, 'a', None), 1, False, None),
    (Match('a', 0.1, 0.5, 'a', None), 2, False, 'split'),
    (None, 0, False, 'no_gesture'),
    (Match('b', 0.1, 0.5, 'b', None), 1, False, 'named_wrong'),
    (Match(None, 0.9, 0.5, 'b', 'distance'), 1, False, 'named_wrong'),
    (Match(None, 0.1, -0.2, 'a', 'margin'), 1, False, 'disagreement'),
    (Match(None, 0.1, 0.001, 'a', 'margin'), 1, False, 'threshold'),
    (Match(None, 0.9, 0.5, 'a', 'distance'), 1, False, 'threshold'),
    (Match(None, 0.9, 0.5, 'a', 'score'), 1, False, 'threshold'),
    (Match(None, 0.1, 0.5, 'a', 'strokes'), 1, False, 'strokes'),
    (Match(None, 0.1, 0.5, 'a', 'duration'), 1, False, 'duration'),
    (Match(None, 0.1, 0.5, 'a', 'order'), 1, False, 'order'),
    (Match('a', 0.1, 0.5, 'a', None), 1, True, 'screened'),
    (Match(None, float('inf'), 0.0, None, 'unusable'), 1, False, 'unusable'),
    (Match(None, float('nan'), float('nan'), 'a', 'margin'), 1, False, 'threshold'),
])
def test_each_lost_gesture_gets_its_first_reason(match, cut, screened, reason):
    assert loss_reason('a', cut, match if cut == 1 else None, screened) == reason
    assert reason is None or reason in LOSS_REASONS


def test_format_losses_names_only_the_reasons_that_lost_something():
    assert format_losses(dict.fromkeys(LOSS_REASONS, 0), 10) == 'right commands lost: 0 of 10'
    assert format_losses({'split': 1, 'named_wrong': 0, 'strokes': 2}, 10) == \
        'right commands lost: 3 of 10 (split 1, strokes 2)'


@pytest.fixture(scope='module')
def rendered():
    return render_samples(synthetic_traces(SHAPES, performers=3, repetitions=3, seed=4),
                          RenderSettings(mode='sensor', placement='mm'))


def test_losses_add_up_to_the_gestures_without_a_right_command(rendered):
    # A segmenter that splits the first held-out sample of each fold and loses the second: both are counted
    # as segmentation, whatever the recogniser would have said.
    seen: dict[str, int] = {}

    def segment(sample, recogniser):
        k = seen[sample.subject] = seen.get(sample.subject, 0) + 1
        g = sample.gestures
        return (g * 2, []) if k == 1 else ([], []) if k == 2 else (g, [])

    results = leave_one_subject_out(rendered, {'trace': lambda: make_recogniser('trace')}, segment=segment)
    res = results['trace']
    subjects = len({r.subject for r in rendered})
    assert res.losses['split'] == subjects and res.losses['no_gesture'] == subjects
    assert sum(res.losses.values()) == res.samples - res.accepted_correct
    out = res.to_dict()
    assert set(out['losses']) == set(LOSS_REASONS) and sum(out['losses'].values()) == sum(res.losses.values())


def test_a_class_the_codebook_lacks_is_lost_by_naming(rendered):
    # line_left drawn by one subject alone: in that subject's fold the codebook has no line_left, so each of
    # them is named wrong (the reason comes before any rejection).
    only = rendered[0].subject
    kept = [r for r in rendered if r.label != 'line_left' or r.subject == only]
    res = leave_one_subject_out(kept, {'trace': lambda: make_recogniser('trace')})['trace']
    lacking = sum(r.label == 'line_left' for r in kept)
    assert lacking == 3
    assert res.losses['named_wrong'] >= lacking
    assert sum(res.losses.values()) == res.samples - res.accepted_correct


def test_doctests_of_the_evaluation():
    check_doctests(touch_lab.skin.evaluate)


def test_the_multistroke_report_tables_the_losses_of_each_recogniser(rendered):
    from touch_lab.skin.multistroke_report import _vocabulary_section

    res = leave_one_subject_out(rendered, {'trace': lambda: make_recogniser('trace')})['trace']
    res.losses['strokes'] = 2   # as if two were lost to the stroke check: shown, in its column
    r = {'vocabulary': 'v', 'traces': 'v.csv', 'samples': res.samples, 'gestures': list(SHAPES), 'subjects': ['a'],
         'multi_stroke_samples': 0, 'gap_s': 0.15, 'gestures_per_sample': {'1': res.samples}, 'data': 'synthetic',
         'recognisers': {'trace': res.to_dict()}, 'best': 'trace'}
    lines = _vocabulary_section(r)
    head = next(i for i, line in enumerate(lines) if line.startswith('| recogniser | lost |'))
    assert 'strokes' in lines[head].split(' | ') and 'split' not in lines[head]
    assert lines[head + 2].startswith(f"| trace | {sum(res.losses.values())} |")


def test_eval_skin_says_where_right_commands_are_lost_in_json_and_text(tmp_path, capsys):
    path = tmp_path / 'traces.csv.gz'
    write_traces(path, synthetic_traces(SHAPES, performers=2, repetitions=2, seed=6))
    argv = ['eval', 'skin', '--traces', str(path), '--recognisers', 'trace', '--no-cache', '--random-touches', '3']
    assert social_touch([*argv, '--json']) == 0
    r = json.loads(capsys.readouterr().out)['recognisers']['trace']
    assert set(r['losses']) == set(LOSS_REASONS)
    assert sum(r['losses'].values()) == r['samples'] - round(r['accuracy_with_rejection'] * r['samples'])
    assert social_touch(argv) == 0
    assert format_losses(r['losses'], r['samples']) in capsys.readouterr().out
