"""Which gestures of a vocabulary the skin will confuse, forecast from its codebook (issue 26, item 4).

The gestures are synthetic (test/test_skin_codebook_people.py's one-stroke letters drawn with tremor by
several people); two of them are made nearly the same on purpose.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from test_skin_codebook_people import LETTERS, stroke

from touch_gestures.skin import make_recogniser, save_codebook
from touch_lab.cli.main import main
from touch_lab.skin.forecast import CONFUSED_SHARE, NEAR_RATIO, forecast
from touch_sim.skin.synthetic import DIGITS, SHAPES, VOCABULARIES, gesture_list
from touch_sim.skin.synthetic import LETTERS as LETTER_NAMES

#: Z, and a second Z whose corners are 1 mm off: no recogniser can tell them apart.
TWINS = {**LETTERS, 'Z2': [(x + 1.0, y) for x, y in LETTERS['Z']]}


def codebook(shapes, people=4, per_person=4, seed=5, name='trace'):
    rng = np.random.default_rng(seed)
    gestures, labels, who = [], [], []
    for p in range(people):
        for label, corners in shapes.items():
            for _ in range(per_person):
                gestures.append(stroke(corners, rng))
                labels.append(label)
                who.append(f'p{p}')
    return make_recogniser(name).fit(gestures, labels, who)


def test_distinct_letters_are_all_told_apart_leave_one_person_out():
    result = forecast(codebook(LETTERS))
    assert result.unit == 'person' and result.people == 4
    assert result.confusion.sum() == 4 * 4 * len(LETTERS)      # every template held out once
    assert np.all(result.right() == 1.0)
    assert all(p['apart'] for p in result.pairs())
    assert np.allclose(np.diag(result.ratios), 1.0)
    off = result.ratios[~np.eye(len(LETTERS), dtype=bool)]
    assert np.all(off >= NEAR_RATIO)


def test_two_gestures_drawn_alike_are_named_as_the_pair_to_fix():
    result = forecast(codebook(TWINS))
    first = result.pairs()[0]
    assert sorted(first['classes']) == ['Z', 'Z2']
    assert not first['apart']
    assert first['confused'] >= CONFUSED_SHARE or first['median_ratio'] < NEAR_RATIO
    # Every other pair is still told apart.
    assert all(p['apart'] for p in result.pairs()[1:])


def test_one_persons_codebook_is_read_in_folds():
    result = forecast(codebook(LETTERS, people=1, per_person=10))
    assert result.unit == 'fold'
    assert result.confusion.sum() == 10 * len(LETTERS)
    assert np.all(result.confusion.sum(axis=1) == 10)


def test_a_gesture_with_one_template_cannot_be_held_out():
    model = codebook({'Z': LETTERS['Z'], 'L': LETTERS['L']}, people=1, per_person=1)
    with pytest.raises(ValueError, match=r'two templates or more.*L, Z'):
        forecast(model)


def test_the_command_prints_the_pairs_and_fails_clearly_on_a_missing_file(tmp_path, capsys):
    path = save_codebook(tmp_path / 'twins.npz', codebook(TWINS, people=3, per_person=3))
    assert main(['codebook', 'forecast', str(path), '--json', '--top', '3']) == 0
    out = json.loads(capsys.readouterr().out)
    assert out['unit'] == 'person' and len(out['pairs']) == 3
    assert sorted(out['pairs'][0]['classes']) == ['Z', 'Z2']
    assert main(['codebook', 'forecast', str(path)]) == 0
    text = capsys.readouterr().out
    assert 'hard to tell apart' in text and 'cannot reliably tell apart' in text
    assert main(['codebook', 'forecast', str(tmp_path / 'none.npz')]) == 2
    assert 'error' in capsys.readouterr().err


def test_vocabulary_names_stand_for_their_gestures_and_every_letter_has_a_shape():
    assert gesture_list('digits') == list(DIGITS)
    assert gesture_list('letters') == list(LETTER_NAMES) and len(LETTER_NAMES) == 26
    assert gesture_list(' line_right, digits ,A') == ['line_right', *DIGITS, 'A']
    assert gesture_list(' , ') == []
    assert set(VOCABULARIES) == {'digits', 'letters'}
    for name in LETTER_NAMES:
        points = np.asarray(SHAPES[name], dtype=np.float64)
        assert points.shape[1] == 2 and len(points) >= 2
        assert points.min() >= 0 and points.max() <= 1            # the unit box the performers scale
