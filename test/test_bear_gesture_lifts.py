"""Bear gestures as people do them (issue 28): a head pat whose hand lifts, a shoulder pat that is no tap,
per-gesture false starts. Hand-made, synthetic sensor sequences."""

from __future__ import annotations

import argparse
import json
import math
from dataclasses import replace

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.symbolic import CANDIDATE, START, GestureLibrary, SymbolicRecogniser
from touch_graph.errors import ConfigError
from touch_graph.paths import share_file
from touch_lab.bear import cli
from touch_lab.bear.false_starts import format_gesture_starts, gesture_starts, summarise

BODY = BodyMap.default()
LIB = GestureLibrary.default(BODY)
PAT_S = 0.2          # one pat's contact, s
RATE_HZ = 10.0

PATS = """gestures:
  head_pat:
    sensors: [head1, head2, head3]
    lift_s: 1.0
"""


def patting(lift_s: float, first_s: float = 1.0, until_s: float = 5.0, sensor: str = 'head2'):
    """Sensors active at ``t``: pats of PAT_S with lifts of ``lift_s`` from ``first_s`` to ``until_s``."""
    period = PAT_S + lift_s

    def active(t: float) -> list[str]:
        return [sensor] if first_s <= t < until_s and (t - first_s) % period < PAT_S - 1e-9 else []
    return active


def run(rec: SymbolicRecogniser, active_at, duration_s: float, rate_hz: float = RATE_HZ) -> list:
    events = []
    for i in range(int(duration_s * rate_hz)):
        t = i / rate_hz
        mask = np.zeros(64, dtype=bool)
        mask[[BODY.by_name(n).channel for n in active_at(t)]] = True
        events += rec.update(t, mask)
    return events


def starts(events: list, gesture: str) -> list:
    return [e for e in events if e.gesture == gesture and e.state == START]


@pytest.mark.parametrize('lift_s', [0.3, 0.8])
def test_a_head_pat_whose_hand_lifts_less_than_lift_s_starts_from_its_first_pat(lift_s: float) -> None:
    events = run(SymbolicRecogniser(GestureLibrary.loads(PATS, BODY), BODY), patting(lift_s), 6.0)
    first = starts(events, 'head_pat')
    assert len(first) == 1
    assert first[0].onset == pytest.approx(1.0) and first[0].t == pytest.approx(3.0)   # the 2 s dwell, unbroken


def test_a_lift_longer_than_lift_s_restarts_the_dwell() -> None:
    """Lifts of 1.5 s with lift_s 1 s: every pat begins a new dwell, none lasts 2 s, so no head pat."""
    events = run(SymbolicRecogniser(GestureLibrary.loads(PATS, BODY), BODY), patting(1.5), 8.0)
    assert starts(events, 'head_pat') == []
    wider = GestureLibrary.loads(PATS.replace('lift_s: 1.0', 'lift_s: 2.0'), BODY)
    assert len(starts(run(SymbolicRecogniser(wider, BODY), patting(1.5), 8.0), 'head_pat')) == 1


def test_once_started_gap_s_not_lift_s_ends_the_head_pat() -> None:
    """The shipped head_pat tolerates 2.5 s lifts in its dwell; once started, a 2 s lift (> gap_s) ends it."""
    assert LIB['head_pat'].lift_s > 2.0 > LIB['head_pat'].gap_s
    events = run(SymbolicRecogniser(LIB, BODY), lambda t: ['head1'] if 1.0 <= t < 3.5 or 5.5 <= t < 6.0 else [], 9.0)
    assert [(e.state_name, round(e.t, 1)) for e in events if e.gesture == 'head_pat'
            and e.state_name in ('START', 'END')][:2] == [('START', 3.0), ('END', 5.0)]


def test_a_single_shoulder_tap_starts_shoulder_tap() -> None:
    events = run(SymbolicRecogniser(LIB, BODY), lambda t: ['shoulder_left'] if 3.0 <= t < 3.2 else [], 7.0)
    tap = starts(events, 'shoulder_tap')
    assert len(tap) == 1 and tap[0].onset == pytest.approx(3.0)


@pytest.mark.parametrize('lift_s', [0.5, 1.0, 1.3])
def test_a_series_of_shoulder_pats_is_not_a_shoulder_tap(lift_s: float) -> None:
    """Pats with lifts up to gap_s (1.4 s) are one touch, too long for a tap."""
    events = run(SymbolicRecogniser(LIB, BODY), patting(lift_s, 1.0, 7.0, 'shoulder_left'), 12.0)
    assert starts(events, 'shoulder_tap') == []
    # No CANDIDATE either after the first pat: the later pats are not taps, and the bear does not say they may be.
    assert [e.t for e in events if e.state == CANDIDATE][:1] == [1.0]
    assert len([e for e in events if e.state == CANDIDATE]) == 1


def test_the_later_pats_of_a_slow_series_are_not_taps() -> None:
    """Lifts of 1.8 s (longer than gap_s): each pat is a touch of its own. Only the first is isolated (quiet_s
    before it) and it is released before the next pat comes, so it is a tap; without quiet_s every pat was."""
    slow = patting(1.8, 1.0, 9.0, 'shoulder_left')
    assert [e.onset for e in starts(run(SymbolicRecogniser(LIB, BODY), slow, 14.0), 'shoulder_tap')] == [1.0]
    loud = GestureLibrary([g if g.name != 'shoulder_tap' else replace(g, quiet_s=0.0) for g in LIB.gestures],
                          LIB.source)
    assert len(starts(run(SymbolicRecogniser(loud, BODY), slow, 14.0), 'shoulder_tap')) == 4


def test_a_tickle_reaching_the_shoulder_is_not_a_shoulder_tap() -> None:
    tickle = lambda t: ['side_left_upper', 'side_left_lower'] + (['shoulder_left'] if 2.0 <= t < 2.2 else [])  # noqa: E731
    events = run(SymbolicRecogniser(LIB, BODY), lambda t: tickle(t) if 1.0 <= t < 4.0 else [], 8.0)
    assert starts(events, 'shoulder_tap') == [] and len(starts(events, 'tickle')) == 1


def test_nan_and_empty_frames_between_pats_are_no_touch_and_raise_nothing() -> None:
    """Through the pipeline: NaN levels read as no touch (a lift), the pats around them still a head pat."""
    rec = BearRecogniser(RATE_HZ, symbolic=True, subtypes=False)
    head2 = BODY.by_name('head2').channel
    events = []
    for i in range(int(6.0 * RATE_HZ)):
        t = i / RATE_HZ
        levels = np.zeros(64)
        if patting(0.8)(t):
            levels[head2] = 0.9
        elif 1.0 < t < 4.0 and i % 3 == 0:
            levels[:] = math.nan                  # a garbage frame in a lift
        events += rec.update(t, levels).symbolic_events
    assert [e.gesture for e in events if e.state == START] == ['head_pat']
    with pytest.raises(ValueError, match='shape'):
        rec.update(6.0, np.zeros(0))              # an empty frame is a programming error, said clearly
    rec2 = SymbolicRecogniser(LIB, BODY)
    assert rec2.update(0.0, np.zeros(64, dtype=bool)) == []   # an untouched frame: nothing


@pytest.mark.parametrize('text, message', [
    ('gestures:\n  a:\n    sensors: [head1]\n    lift_sec: 1\n', "unknown key 'lift_sec'"),
    ('gestures:\n  a:\n    sensors: [head1]\n    lift_s: -1\n', "'lift_s' in gesture 'a' must be a number of seconds"),
    ('gestures:\n  a:\n    sensors: [head1]\n    lift_s: soon\n', 'lift_s'),
    ('gestures:\n  a:\n    sensors: [head1]\n    lift_s: .nan\n', 'seconds >= 0'),
    ('defaults:\n  lift: 1\ngestures:\n  a:\n    sensors: [head1]\n', "unknown key 'lift'"),
    ('gestures:\n  a:\n    sensors: [head1]\n    dwell_s: 0\n    max_s: 1\n    lift_s: 1\n', 'brief gesture'),
    ('gestures:\n  a:\n    sensors: [head1]\n    quiet_s: 1\n', 'quiet_s is for brief gestures'),
    ('gestures:\n  a:\n    sensors: [head1]\n    dwell_s: 0\n    max_s: 1\n    quiet_s: -2\n', 'seconds >= 0'),
])
def test_lift_and_quiet_typos_are_clear_errors(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message) as info:
        GestureLibrary.loads(text, BODY)
    assert info.value.line is not None


def test_a_typo_in_lift_s_suggests_the_key() -> None:
    with pytest.raises(ConfigError, match="did you mean 'lift_s'"):
        GestureLibrary.loads('gestures:\n  a:\n    sensors: [head1]\n    lfit_s: 1\n', BODY)


def test_false_starts_are_counted_per_gesture_with_the_touch_that_caused_them() -> None:
    trials = [(0.0, 5.0, 'symbolic', 'head_pat'), (10.0, 14.0, 'subtype', 'pat'), (20.0, 21.0, 'subtype', 'tap'),
              (30.0, 35.0, 'symbolic', 'hug'), (40.0, 42.0, 'symbolic', 'shoulder_tap')]
    found = [('head_pat', 2.5), ('shoulder_tap', 11.0), ('shoulder_tap', 20.5), ('shoulder_tap', 32.0),
             ('shoulder_tap', 50.0), ('hug', 33.0)]
    own = {'head_pat': 'pat', 'shoulder_tap': 'tap', 'hug': 'hold'}
    s = summarise(gesture_starts(trials, found, ['head_pat', 'hug', 'shoulder_tap'], own))
    tap = s['per_gesture']['shoulder_tap']
    assert (tap['trials'], tap['detected'], tap['false_starts']) == (1, 0, 3)   # the tap subtype trial is its own
    assert tap['false_starts_by_touch'] == {'none': 1, 'subtype/pat': 1, 'symbolic/hug': 1}
    assert tap['false_starts_by_cause'] == {'other_gesture': 1, 'subtype_trial': 1, 'outside_trials': 1}
    assert (s['trials'], s['detected'], s['false_starts']) == (3, 2, 3)
    assert s['per_gesture']['head_pat']['median_latency_s'] == 2.5
    assert set(s['statistics']) >= {'trials', 'detected', 'false_starts', 'false_starts_by_touch'}
    text = '\n'.join(format_gesture_starts(s))
    assert 'shoulder_tap    0 / 1     3  (none 1, subtype/pat 1, symbolic/hug 1)' in text


def _eval_bear(argv: list[str]):
    parser = argparse.ArgumentParser()
    cli.add_arguments(parser)
    return cli.run(parser.parse_args(argv))


def test_eval_bear_scores_a_given_gesture_library_per_gesture(tmp_path, capsys) -> None:
    """--gestures on simulated people: the JSON and text give trials, detected and false starts per gesture."""
    only = tmp_path / 'gestures.yaml'
    only.write_text('gestures:\n  head_pat:\n    sensors: [head1, head2, head3]\n    lift_s: 1.0\n')
    assert _eval_bear(['--json', '--quiet', '--people', '1', '--reps', '1', '--seed', '2', '--gestures', str(only),
                       '--model', str(share_file('config', 'bear_subtype_model.npz'))]) == 0
    out = json.loads(capsys.readouterr().out)
    scores = out['model']['symbolic']['gestures']
    assert list(scores['per_gesture']) == ['head_pat'] and scores['per_gesture']['head_pat']['trials'] == 1
    assert out['symbolic_false_starts'] == scores['false_starts']
    assert 'Per symbolic gesture: detected / trials, false starts' in cli.format_text(out)


def test_eval_bear_says_which_gesture_key_is_misspelt(tmp_path, capsys) -> None:
    typo = tmp_path / 'gestures.yaml'
    typo.write_text('gestures:\n  head_pat:\n    sensors: [head1]\n    lift_sec: 1\n')
    assert _eval_bear(['--quiet', '--gestures', str(typo)]) == 2          # before any training
    assert "did you mean 'lift_s'" in capsys.readouterr().err
