"""Rejection calibrated on the codebook: strokes and durations the nearest class never shows (synthetic)."""

from __future__ import annotations

import numpy as np
import pytest
from test_skin_multistroke import codebook

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.codebook import load_codebook, save_codebook
from touch_gestures.skin.evidence import CodebookEvidence
from touch_gestures.skin.gesture import TouchGesture
from touch_sim.skin.synthetic import random_touches

NAMES = ('X', 'H', 'T', 'Z')


def timed(gestures, rng, seconds=(0.6, 1.6)):
    """The gestures traced over a duration drawn from ``seconds`` (the codebook's pace)."""
    for g in gestures:
        g.duration_s = float(rng.uniform(*seconds))
        g.times = np.linspace(0.0, g.duration_s, len(g.trajectory))
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
    lo, hi = lax.codebook_evidence_.duration_bounds_s[list(lax.classes_).index('Z')]
    assert all(lo <= g.duration_s <= hi for g, m in zip(randoms, matches, strict=True) if m.label == 'Z')
    rng = np.random.default_rng(9)
    held_out, labels = codebook(rng, names=NAMES, per_class=5)
    hits = [m.label == y for m, y in zip(map(fitted.predict, timed(held_out, rng)), labels, strict=True)]
    assert np.mean(hits) >= 0.9


def test_stroke_counts_and_durations_come_from_the_codebook_and_its_file(fitted, tmp_path):
    ev = fitted.codebook_evidence_
    assert ev.stroke_counts == [frozenset({3}), frozenset({2}), frozenset({2}), frozenset({1})]   # H, T, X, Z
    lo, hi = ev.duration_bounds_s.T
    assert (lo >= 0.6 / 1.5 - 1e-9).all() and (hi <= 1.6 * 1.5 + 1e-9).all()
    one_bar = TouchGesture.from_trajectory(np.array([[10.0, 10.0], [37.0, 37.0]]), np.array([0.0, 1.0]))
    assert fitted.predict(one_bar).rejected in ('strokes', 'distance', 'margin')
    loaded = load_codebook(save_codebook(tmp_path / 'c.npz', fitted, vocabulary='symbols'))
    assert loaded.codebook_evidence_.stroke_counts == ev.stroke_counts
    np.testing.assert_allclose(loaded.codebook_evidence_.duration_bounds_s, ev.duration_bounds_s)


def test_a_codebook_without_strokes_or_durations_checks_nothing_and_bad_settings_fail():
    ev = CodebookEvidence(np.array([0, 0, 1]), 2)
    assert ev.check(TouchGesture.from_trajectory(np.zeros((2, 2))), 1) is None
    few = CodebookEvidence(np.array([0, 0, 1]), 2, durations_s=np.array([1.0, 1.1, 1.0]))   # too few to bound
    assert few.check(TouchGesture.from_trajectory(np.zeros((2, 2)), np.array([0.0, 9.0])), 0) is None
    with pytest.raises(ValueError, match='slack'):
        CodebookEvidence(np.array([0]), 1, slack=0.5)
