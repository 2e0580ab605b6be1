"""The stroke check as a plausibility bound with a stated tolerance, and its edge cases (issue 26; synthetic)."""

from __future__ import annotations

import numpy as np
import pytest

from touch_gestures.skin.evidence import CodebookEvidence
from touch_gestures.skin.gesture import TouchGesture

# Two classes of 40 templates: class 0 written with 2 strokes, class 1 with 1 or 3.
LABELS = np.repeat([0, 1], 40)
STROKES = np.r_[np.full(40, 2), np.tile([1, 3], 20)]
CONTACT_S = np.r_[np.linspace(1.0, 2.0, 40), np.linspace(0.5, 1.0, 40)]


def touch(strokes: int, seconds: float = 1.5, points: int = 30) -> TouchGesture:
    """A straight touch of ``strokes`` strokes traced in ``seconds`` with no pause (the span is the time in
    contact)."""
    g = TouchGesture.from_trajectory(np.column_stack([np.linspace(0, 20, points), np.zeros(points)]),
                                     np.linspace(0.0, seconds, points))
    g.stroke = np.minimum(np.arange(points) * strokes // points, strokes - 1).astype(np.int16)
    g.strokes = strokes
    return g


@pytest.mark.parametrize(('tolerance', 'strokes', 'label', 'reason'), [
    (0, 2, 0, None), (0, 1, 0, 'strokes'), (0, 3, 0, 'strokes'),
    (1, 1, 0, None), (1, 3, 0, None), (1, 4, 0, 'strokes'),
    (0, 2, 1, 'strokes'), (1, 2, 1, None), (1, 4, 1, None), (1, 5, 1, 'strokes'),
])
def test_a_count_within_the_tolerance_of_one_the_class_shows_passes_the_check(tolerance, strokes, label, reason):
    ev = CodebookEvidence(LABELS, 2, STROKES, stroke_tolerance=tolerance)
    seconds = 1.5 if label == 0 else 0.8
    assert ev.check(touch(strokes, seconds), label) == reason


def test_the_tolerance_leaves_the_classes_that_name_the_touch_as_they_are():
    exact = CodebookEvidence(LABELS, 2, STROKES, stroke_tolerance=0)
    wide = CodebookEvidence(LABELS, 2, STROKES, stroke_tolerance=1)
    for k in range(1, 5):
        assert np.array_equal(exact.allowed(touch(k)), wide.allowed(touch(k)))
    assert wide.plausible_strokes == [frozenset({1, 2, 3}), frozenset({1, 2, 3, 4})]   # never below one stroke


@pytest.mark.parametrize('bad', [-1, 0.5, True, '1'])
def test_a_tolerance_that_is_no_whole_number_of_strokes_is_refused(bad):
    with pytest.raises(ValueError, match='stroke_tolerance'):
        CodebookEvidence(LABELS, 2, STROKES, stroke_tolerance=bad)


def test_a_nan_time_is_no_plausible_duration():
    ev = CodebookEvidence(LABELS, 2, STROKES, CONTACT_S, stroke_tolerance=1)
    for strokes, label in ((1, 1), (2, 0)):
        g = touch(strokes)
        g.times = np.full(len(g.times), np.nan)
        assert ev.check(g, label) == 'duration'


def test_a_zero_length_stroke_counts_as_a_stroke_and_a_zero_time_is_too_short():
    ev = CodebookEvidence(LABELS, 2, STROKES, CONTACT_S, stroke_tolerance=1)
    g = touch(2)
    g.times = np.zeros(len(g.times))            # every point at one time: no time in contact
    assert g.contact_s == 0.0
    assert ev.check(g, 0) == 'duration'
    one = touch(1, seconds=1.5, points=1)       # a single point: one stroke of no length
    assert one.strokes == 1 and ev.check(one, 0) == 'duration'
    assert CodebookEvidence(LABELS, 2, STROKES, stroke_tolerance=1).check(one, 0) is None


def test_the_duration_bound_is_the_class_range_widened_by_the_slack():
    ev = CodebookEvidence(LABELS, 2, STROKES, CONTACT_S, slack=2.0)   # class 0 traced in 1.0-2.0 s
    lo, hi = ev.contact_bounds_s[0]
    q_lo, q_hi = np.quantile(CONTACT_S[:40], [0.01, 0.99])
    assert (lo, hi) == pytest.approx((q_lo / 2, q_hi * 2))   # down to half the fastest, up to twice the slowest
    # (the touch's time in contact is its span less the one step between its strokes)
    assert ev.check(touch(2, 0.55), 0) is None and ev.check(touch(2, 3.9), 0) is None
    assert ev.check(touch(2, 0.45), 0) == 'duration' and ev.check(touch(2, 4.5), 0) == 'duration'
