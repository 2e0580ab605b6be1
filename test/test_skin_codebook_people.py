"""Codebooks say who drew each template, and ``auto`` chooses leave-one-person-out with it (issue 26, item 1).

The gestures are synthetic: single-stroke letters drawn as polylines with a little tremor, each person
drawing every letter the same way each time (a template's nearest neighbour is then that person's own
repetition, which is what misleads a choice made template by template).
"""

from __future__ import annotations

import re

import numpy as np
import pytest

from touch_gestures.skin import CodebookRecorder, TouchGesture, load_codebook, make_recogniser, save_codebook
from touch_lab.skin.recognisers.auto import AutoRecogniser, person_out_accuracy
from touch_lab.skin.recording import load_recording, save_recording

RATE_HZ = 150.0
#: One-stroke letters as corners (x, y) in mm on the skin.
LETTERS = {'Z': [(10, 10), (37, 10), (10, 37), (37, 37)], 'L': [(10, 8), (10, 39), (37, 39)],
           'V': [(8, 10), (23.5, 39), (39, 10)], 'N': [(10, 39), (10, 8), (37, 39), (37, 8)],
           'U': [(10, 8), (10, 39), (37, 39), (37, 8)]}


def stroke(corners, rng: np.random.Generator) -> TouchGesture:
    """One traced stroke along ``corners``: 28-56 points, 0.6 mm of tremor."""
    c = np.asarray(corners, dtype=np.float64)
    cum = np.r_[0, np.cumsum(np.hypot(*np.diff(c, axis=0).T))]
    s = np.linspace(0, cum[-1], int(40 * rng.uniform(0.7, 1.4)))
    pts = np.column_stack([np.interp(s, cum, c[:, 0]), np.interp(s, cum, c[:, 1])]) + rng.normal(0, 0.6, (len(s), 2))
    return TouchGesture.from_trajectory(pts, np.arange(len(pts)) / RATE_HZ)


def drawn(rng, people=3, per_person=6, backwards=('p0',), letters=tuple(LETTERS)):
    """Every person draws every letter ``per_person`` times; those in ``backwards`` from the other end."""
    gestures, labels, who = [], [], []
    for person in (f'p{i}' for i in range(people)):
        for name in letters:
            corners = LETTERS[name][::-1] if person in backwards else LETTERS[name]
            for _ in range(per_person):
                gestures.append(stroke(corners, rng))
                labels.append(name)
                who.append(person)
    return gestures, labels, who


def test_a_person_who_draws_backwards_is_seen_only_leave_one_person_out():
    gestures, labels, people = drawn(np.random.default_rng(1))
    by_template = AutoRecogniser().fit(gestures, labels)
    # Each template's nearest is the same person's repetition: both read everything, the cheaper one wins.
    assert (by_template.method_, by_template.choice_) == ('leave-one-template-out', 'trace')
    by_person = AutoRecogniser().fit(gestures, labels, people)
    assert by_person.method_ == 'leave-one-person-out' and by_person.choice_ == 'fused', by_person.reason_
    # The trace never reads the backwards person from the other two: 2 of 3 people per letter.
    assert all(v == pytest.approx(2 / 3) for v in by_person.evidence_['trace'].values())
    assert min(by_person.evidence_['fused'].values()) > 2 / 3
    assert list(by_person.template_people_[by_person.template_labels_ == 0]) == ['p0'] * 6 + ['p1'] * 6 + ['p2'] * 6


def test_direction_that_means_something_keeps_the_trace_leave_one_person_out():
    rng = np.random.default_rng(2)
    lines = {'right': [(5, 20), (42, 20)], 'left': [(42, 20), (5, 20)], 'down': [(20, 5), (20, 42)],
             'up': [(20, 42), (20, 5)]}
    gestures = [stroke(c, rng) for _ in range(3) for c in lines.values() for _ in range(5)]
    labels = [name for _ in range(3) for name in lines for _ in range(5)]
    people = [f'p{i}' for i in range(3) for _ in range(20)]
    auto = AutoRecogniser().fit(gestures, labels, people)
    assert auto.method_ == 'leave-one-person-out' and auto.choice_ == 'trace', auto.reason_
    assert min(auto.evidence_['trace'].values()) == 1.0 > max(auto.evidence_['fused'].values())


def test_one_person_or_unknown_people_falls_back_to_the_templates():
    gestures, labels, _ = drawn(np.random.default_rng(3), people=2, per_person=3, backwards=())
    for people in (None, ['p0'] * len(labels), ['p0', ''] * (len(labels) // 2)):
        assert AutoRecogniser().fit(gestures, labels, people).method_ == 'leave-one-template-out'


def test_person_out_accuracy_counts_right_wrong_and_classes_one_person_drew():
    gestures, labels, people = drawn(np.random.default_rng(4), people=2, per_person=2, backwards=())
    line = stroke([(5, 20), (42, 20)], np.random.default_rng(5))
    gestures, labels, people = [*gestures, line], [*labels, 'only_p1'], [*people, 'p1']
    classes, accuracy, wrong = person_out_accuracy(lambda: make_recogniser('trace'), gestures, labels, people)
    assert list(classes) == sorted(set(labels))
    assert np.isnan(accuracy[list(classes).index('only_p1')])       # nobody else drew it: nothing to hold out
    others = np.delete(accuracy, list(classes).index('only_p1'))
    assert np.all(others == 1.0) and wrong == 0.0


def test_the_codebook_file_keeps_who_drew_each_template(tmp_path):
    gestures, labels, people = drawn(np.random.default_rng(6), people=2, per_person=2, backwards=())
    model = make_recogniser('trace').fit(gestures, labels, people)
    back = load_codebook(save_codebook(tmp_path / 'book', model))
    assert list(back.template_people_) == list(model.template_people_)
    assert sorted(back.template_people_) == sorted(people)
    unknown = load_codebook(save_codebook(tmp_path / 'old', make_recogniser('trace').fit(gestures, labels)))
    assert unknown.template_people_ is None
    with np.load(tmp_path / 'old.npz', allow_pickle=False) as z:
        assert 'template_people' not in z.files


def test_people_must_pair_with_the_gestures():
    gestures, labels, people = drawn(np.random.default_rng(7), people=1, per_person=2, backwards=())
    with pytest.raises(ValueError, match=re.escape('one label (and person, if given) per gesture')):
        make_recogniser('trace').fit(gestures, labels, people[:-1])


def test_the_recorder_keeps_the_person_through_undo_skip_and_a_saved_recording(tmp_path):
    rng = np.random.default_rng(8)
    rec = CodebookRecorder(['Z', 'L', 'V'], repetitions=2)
    rec.person = 'ana'
    assert rec.add(stroke(LETTERS['Z'], rng))[0]
    rec.person = 'bo'
    assert rec.add(stroke(LETTERS['Z'], rng))[0] and rec.add(stroke(LETTERS['L'], rng))[0]
    assert rec.undo() == 'L' and rec.people == ['ana', 'bo']
    assert rec.add(stroke(LETTERS['L'], rng))[0]
    assert rec.skip() == 'L' and rec.people == ['ana', 'bo']
    back = load_recording(save_recording(tmp_path / 'rec.partial.npz', rec))
    assert back.people == ['ana', 'bo'] and back.labels == ['Z', 'Z']
    back.person = 'cy'
    back.add(stroke(LETTERS['V'], rng))
    model = back.add(stroke(LETTERS['V'], rng)) and back.fit(make_recogniser('trace'))
    assert sorted(model.template_people_) == ['ana', 'bo', 'cy', 'cy']


def test_a_recording_of_before_people_were_kept_still_loads(tmp_path):
    rec = CodebookRecorder(['Z'], repetitions=2)
    rec.add(stroke(LETTERS['Z'], np.random.default_rng(9)))
    path = save_recording(tmp_path / 'old.partial.npz', rec)
    with np.load(path, allow_pickle=False) as z:
        data = {k: z[k] for k in z.files if k != 'people'}
    np.savez_compressed(path, **data)
    assert load_recording(path).people == ['']
