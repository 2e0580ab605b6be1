"""Strokes that make a whole gesture and also begin a longer one (issue 26, item 3; synthetic).

An asterisk is an X and a bar: after the X's two strokes, the whole X is nearer than the asterisk's prefix,
so with no margin the lift of the short gap ends an X. A margin makes them wait for the bar up to the bound.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_skin_multistroke import RATE, SYMBOLS, codebook, feed, polyline, symbol

from touch_gestures.skin.clouds import CloudRecogniser
from touch_gestures.skin.ending import ENDING_MARGIN, GestureEnd
from touch_gestures.skin.segmentation import GestureSegmenter, Verdict

GAP, WAIT = 0.5, 3.0
BAR = [(23.5, 6), (23.5, 41)]


@pytest.fixture(scope='module')
def recogniser():
    SYMBOLS['asterisk'] = [*SYMBOLS['X'], BAR]   # for the codebook only: other modules iterate over SYMBOLS
    try:
        gestures, labels = codebook(np.random.default_rng(0), names=('X', 'asterisk', 'Z'), per_class=10,
                                    shuffle=False)
    finally:
        del SYMBOLS['asterisk']
    return CloudRecogniser().fit(gestures, labels)


def lift(seg, seconds, t):
    return feed(seg, [None] * round(seconds * RATE), t, contact=False)


def trace_asterisk(seg, pause_s, rng):
    """The X's two strokes, a lift of ``pause_s``, the bar, then a lift past the bound and the end of the
    stream (a lone bar is no whole gesture and would wait until the limit): the gestures cut."""
    out, t = feed(seg, polyline(SYMBOLS['X'][0], 50, rng), 0.0)
    more, t = lift(seg, 0.3, t)
    out += more
    more, t = feed(seg, polyline(SYMBOLS['X'][1], 50, rng), t)
    out += more
    more, t = lift(seg, pause_s, t)
    out += more
    more, t = feed(seg, polyline(BAR, 40, rng), t)
    out += more
    return out + lift(seg, WAIT + 0.1, t)[0] + seg.flush()


def test_with_no_margin_the_x_of_an_asterisk_ends_at_the_short_gap(recogniser):
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=GestureEnd(recogniser, margin=0.0))
    cut = trace_asterisk(seg, 1.5, np.random.default_rng(3))
    assert [g.strokes for g in cut] == [2, 1]


def test_with_a_margin_the_x_waits_for_the_bar_within_the_bound(recogniser):
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=GestureEnd(recogniser, margin=1.0))
    cut = trace_asterisk(seg, 1.5, np.random.default_rng(3))
    assert [g.strokes for g in cut] == [3]
    assert seg.stats.waited_continued >= 1


def test_with_a_margin_a_lone_x_still_ends_at_the_bound(recogniser):
    # The wait is bounded: an X that is not followed by a bar ends at the bound, not later.
    end = GestureEnd(recogniser, margin=1.0)
    seg = GestureSegmenter(gap_s=GAP, wait_s=WAIT, is_complete=end)
    rng = np.random.default_rng(5)
    _, t = feed(seg, polyline(SYMBOLS['X'][0], 50, rng), 0.0)
    _, t = lift(seg, 0.3, t)
    _, t = feed(seg, polyline(SYMBOLS['X'][1], 50, rng), t)
    early, t = lift(seg, WAIT - 0.2, t)
    assert early == []
    (x,), _ = lift(seg, 0.4, t)
    assert x.strokes == 2 and seg.stats.ended_at_bound == 1


@pytest.mark.parametrize(('margin', 'verdict'), [(0.0, Verdict.WHOLE), (1.0, Verdict.PREFIX)])
def test_the_margin_decides_between_whole_and_prefix(recogniser, margin, verdict):
    rng = np.random.default_rng(9)
    x = symbol('X', rng, shuffle=False)
    assert GestureEnd(recogniser, margin=margin).verdict(x) is verdict


def test_the_default_rule_waits_for_a_longer_gesture_nearly_as_near(recogniser):
    # A whole X must be ENDING_MARGIN nearer than the asterisk's beginning to end at the short gap.
    end = GestureEnd(recogniser)
    assert end.margin == ENDING_MARGIN > 0
    rng = np.random.default_rng(11)
    verdicts = {end.verdict(symbol('X', rng, shuffle=False)) for _ in range(10)}
    assert Verdict.PREFIX in verdicts
