"""The bear's first word: candidate counting (config/bear_candidates.yaml) and its scoring against time."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.symbolic import CANDIDATE, END, START, WITHDRAWN, GestureLibrary, SymbolicEvent
from touch_lab.bear.candidates import count_candidates
from touch_lab.bear.first_word import candidate_outcomes, score_first_word

LIB = GestureLibrary.default(BodyMap.default())


def event(gesture: str, state: int, t: float, evidence: int = 0, confidence: float = 1.0) -> SymbolicEvent:
    return SymbolicEvent(gesture, state, t, 0.0, t, ('x',), confidence=confidence, evidence=evidence)


def label(name: str, start: float, end: float):
    return SimpleNamespace(kind='symbolic', label=name, start_s=start, end_s=end)


def test_counting_keys_each_candidate_by_its_evidence_level_and_its_outcome() -> None:
    events = [event('hug', CANDIDATE, 0.0, evidence=0), event('hug', START, 2.0), event('hug', END, 5.0),
              event('hug', CANDIDATE, 9.0, evidence=2), event('hug', WITHDRAWN, 9.5),
              event('head_pat', CANDIDATE, 10.0, evidence=0), event('head_pat', START, 12.0),
              event('tickle', START, 20.0)]                 # a decision without a candidate counts nowhere
    table = count_candidates(events, LIB, data='test')
    assert table.counts['hug'] == [(1, 1), (0, 0), (0, 1)]
    assert table.counts['head_pat'] == [(1, 1), (0, 0), (0, 0)] and table.counts['tickle'] == [(0, 0)] * 3
    assert table.confidence('hug', 0) == pytest.approx(2 / 3) and table.confidence('hug', 5) == pytest.approx(1 / 3)
    assert candidate_outcomes(events)['hug'] == {'candidates': 2, 'confirmed': 1, 'withdrawn': 1}


def test_the_first_message_and_what_is_said_against_time() -> None:
    """A hug mistaken for a tickle for 0.3 s, then announced and confirmed; a head pat never said at all."""
    scene = SimpleNamespace(labels=[label('hug', 10.0, 15.0), label('head_pat', 30.0, 34.0)])
    events = [event('tickle', CANDIDATE, 10.2, confidence=0.5), event('tickle', WITHDRAWN, 10.5, confidence=0.0),
              event('hug', CANDIDATE, 10.5, confidence=0.9), event('hug', START, 12.5), event('hug', END, 15.5)]
    out = score_first_word(scene, events, LIB, taus_s=(0.0, 0.3, 0.5, 2.5, 6.0))
    assert out['median_first_message_s'] == pytest.approx(0.5) and out['first_message_rate'] == 0.5
    assert out['median_first_any_message_s'] == pytest.approx(0.2)
    assert out['said_accuracy'] == [0.0, 0.0, 0.5, 0.5, 0.5]       # tickle at 0.3 s; hug from 0.5 s on
    assert out['decided_accuracy'] == [0.0, 0.0, 0.0, 0.5, 0.5]    # the START at 2.5 s, kept after the END
