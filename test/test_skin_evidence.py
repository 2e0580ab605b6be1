"""Rejection calibrated on the codebook: strokes and durations the nearest class never shows (synthetic)."""

from __future__ import annotations

import numpy as np
import pytest
from test_skin_multistroke import codebook

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.evidence import CodebookEvidence
from touch_gestures.skin.gesture import TouchGesture
from touch_lab.skin.recognisers import load_codebook, save_codebook
from touch_sim.skin.synthetic import random_touches

NAMES = ('X', 'H', 'T', 'Z')


def timed(gestures, rng, seconds=(0.6, 1.6)):
    """The gestures traced in a time in contact drawn from ``seconds`` (the codebook's pace), each
    stroke starting as the last one ends (no pause: the span is the time in contact)."""
    for g in gestures:
        g.duration_s = float(rng.uniform(*seconds))
        within = np.r_[0.0, (np.diff(g.stroke) == 0).astype(np.float64)]   # steps inside a stroke
        g.times = np.cumsum(within) * (g.duration_s / max(within.sum(), 1.0))
    return gestures


@pytest.fixture(scope='module')
def fitted():
    rng = np.random.default_rng(0)
    gestures, labels = codebook(rng, names=NAMES, per_class=30)
    return CloudRecogniser().fit(timed(gestures, rng), labels)


def scribbles():
    """Random 1-stroke touches of 10 mm or more (synthetic), 0.2-3 s each."""
    out = []
    for s in random_touches(60, seed=3):
        g = TouchGesture.from_trajectory(np.column_stack([s.x, s.y]), (s.t_ms - s.t_ms[0]) / 1000.0)
        if np.ptp(g.trajectory, axis=0).max() >= 10.0:
            out.append(g)
    return out


def test_random_touches_are_rejected_and_new_symbols_accepted(fitted):
    randoms = scribbles()
    fired = [m for m in map(fitted.predict, randoms) if m.label is not None]
    assert len(randoms) >= 30 and len(fired) <= 0.1 * len(randoms)
    # With no distance or margin rule the evidence alone turns them away: a 1-stroke touch is only ever
    # taken for Z, the one 1-stroke class, and only when it lasts as long as the codebook's Z's do.
    rng = np.random.default_rng(0)
    gestures, labels = codebook(rng, names=NAMES, per_class=30)
    lax = CloudRecogniser(max_distance=None, min_margin=0.0).fit(timed(gestures, rng), labels)
    matches = list(map(lax.predict, randoms))
    assert {m.label for m in matches} <= {None, 'Z'}
    assert {m.rejected for m in matches} >= {'strokes', 'duration'}
    lo, hi = lax.codebook_evidence_.contact_bounds_s[list(lax.classes_).index('Z')]
    assert all(lo <= g.contact_s <= hi for g, m in zip(randoms, matches, strict=True) if m.label == 'Z')
    rng = np.random.default_rng(9)
    held_out, labels = codebook(rng, names=NAMES, per_class=5)
    hits = [m.label == y for m, y in zip(map(fitted.predict, timed(held_out, rng)), labels, strict=True)]
    assert np.mean(hits) >= 0.9


def test_stroke_counts_and_durations_come_from_the_codebook_and_its_file(fitted, tmp_path):
    ev = fitted.codebook_evidence_
    assert ev.stroke_counts == [frozenset({3}), frozenset({2}), frozenset({2}), frozenset({1})]   # H, T, X, Z
    lo, hi = ev.contact_bounds_s.T
    assert (lo >= 0.6 / 1.5 - 1e-9).all() and (hi <= 1.6 * 1.5 + 1e-9).all()
    one_bar = TouchGesture.from_trajectory(np.array([[10.0, 10.0], [37.0, 37.0]]), np.array([0.0, 1.0]))
    assert fitted.predict(one_bar).rejected in ('strokes', 'distance', 'margin')
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', fitted, vocabulary='symbols'))
    assert loaded.codebook_evidence_.stroke_counts == ev.stroke_counts
    np.testing.assert_allclose(loaded.codebook_evidence_.contact_bounds_s, ev.contact_bounds_s)


def test_a_codebook_without_strokes_or_durations_checks_nothing_and_bad_settings_fail():
    ev = CodebookEvidence(np.array([0, 0, 1]), 2)
    assert ev.check(TouchGesture.from_trajectory(np.zeros((2, 2))), 1) is None
    few = CodebookEvidence(np.array([0, 0, 1]), 2, contact_s=np.array([1.0, 1.1, 1.0]))   # too few to bound
    assert few.check(TouchGesture.from_trajectory(np.zeros((2, 2)), np.array([0.0, 9.0])), 0) is None
    with pytest.raises(ValueError, match='slack'):
        CodebookEvidence(np.array([0]), 1, slack=0.5)


def test_contact_time_leaves_out_the_pauses_between_strokes():
    g = TouchGesture.from_trajectory(np.zeros((6, 2)), np.array([0.0, 0.5, 1.0, 9.0, 9.25, 9.5]))
    assert g.contact_s == g.duration_s == 9.5                  # one stroke: the span
    g.stroke = np.array([0, 0, 0, 1, 1, 1], dtype=np.int16)
    assert g.contact_s == 1.5                                  # 1.0 + 0.5, the 8 s lift left out
    g.stroke = np.array([0, 1, 2, 3, 4, 5], dtype=np.int16)
    assert g.contact_s == 0.0                                  # dabs: no time in contact between points
    empty = TouchGesture.from_trajectory(np.zeros((0, 2)))
    assert empty.contact_s == 0.0


def test_a_symbol_written_with_a_long_pause_is_not_turned_away_for_its_duration(fitted):
    """People pause between strokes from a fraction of a second to over ten: the pace is in the strokes."""
    rng = np.random.default_rng(4)
    held_out, labels = codebook(rng, names=NAMES, per_class=5)
    checked = 0
    for g, label in zip(timed(held_out, rng), labels, strict=True):
        if g.strokes < 2:
            continue
        late = g.stroke >= 1
        g.times = g.times + np.where(late, 8.0, 0.0)           # an 8 s pause before the second stroke
        g.duration_s = float(g.times[-1] - g.times[0])
        hi = fitted.codebook_evidence_.contact_bounds_s[list(fitted.classes_).index(label), 1]
        assert g.duration_s > hi                               # the span with the pause is out of the class's range
        assert fitted.codebook_evidence_.check(g, list(fitted.classes_).index(label)) is None
        checked += 1
    assert checked >= 10


def test_the_nearest_class_is_one_written_with_the_touchs_strokes(fitted):
    """A touch nearest to a class the evidence rules out is named for the nearest class it allows; with
    the ruled-out class nearer it is still ambiguous, so no command fires."""
    rng = np.random.default_rng(11)
    held_out, _ = codebook(rng, names=('X',), per_class=8)
    x = list(fitted.classes_).index('X')
    named = 0
    for g in timed(held_out, rng):
        if fitted.class_distances(g).argmin() != x or fitted.predict(g).label != 'X':
            continue
        # The second bar cut in two: the same ink (the cloud's distances do not change), three strokes,
        # which only the codebook's H shows.
        second = np.flatnonzero(g.stroke == 1)
        g.stroke = g.stroke.copy()
        g.stroke[second[len(second) // 2:]] = 2
        g.strokes = 3
        assert int(g.strokes) == 3 and fitted.class_distances(g).argmin() == x
        allowed = fitted.codebook_evidence_.allowed(g)
        assert allowed.tolist() == [c == 'H' for c in fitted.classes_]
        match = fitted.predict(g)
        assert match.nearest == 'H' and match.label is None and match.rejected in ('strokes', 'distance')
        assert match.margin < 0            # X, ruled out, is nearer than H
        named += 1
    assert named >= 4


def test_allowed_classes_follow_the_stroke_count_not_the_pace():
    ev = CodebookEvidence(np.repeat([0, 1, 2], 40), 3, strokes=np.repeat([1, 2, 1], 40),
                          contact_s=np.r_[np.full(40, 1.0), np.full(40, 1.0), np.full(40, 4.0)])
    one = TouchGesture.from_trajectory(np.zeros((3, 2)), np.array([0.0, 0.5, 1.0]))
    assert ev.allowed(one).tolist() == [True, False, True]
    one.times = np.array([0.0, 20.0, 40.0])                          # slower than every class: still named,
    assert ev.allowed(one).tolist() == [True, False, True]           # then its command rejected by check
    assert ev.check(one, 0) == ev.check(one, 2) == 'duration'
    one.strokes = 3
    assert not ev.allowed(one).any() and not ev.allowed(one).flags.writeable
    assert CodebookEvidence(np.array([0, 1]), 2, contact_s=np.array([1.0, 2.0])).allowed(one) is None
