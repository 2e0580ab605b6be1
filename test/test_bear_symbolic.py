"""Symbolic gestures (knight2009 V.E, Table I): YAML filters, dwell, priority logic, START/END events."""

from __future__ import annotations

import numpy as np
import pytest

from touch_driver.bear.body_map import BodyMap, BodySensor
from touch_gestures.bear.candidates import CandidateConfidence
from touch_gestures.bear.subtype_labels import subtype_index
from touch_gestures.bear.symbolic import DECISIONS, END, START, GestureLibrary, SymbolicRecogniser
from touch_graph.errors import ConfigError
from touch_graph.paths import share_file

BODY = BodyMap.default()
LIB = GestureLibrary.default(BODY)


def drive(rec: SymbolicRecogniser, active_at, duration_s: float, rate_hz: float = 10.0, subtype_at=None,
          decisions_only: bool = True):
    """Run ``rec`` with the sensors named by ``active_at(t)`` active; return its decisions (START, END), or all
    events (CANDIDATE and WITHDRAWN too) unless ``decisions_only``."""
    events = []
    for i in range(int(duration_s * rate_hz)):
        t = i / rate_hz
        mask = np.zeros(64, dtype=bool)
        mask[[BODY.by_name(n).channel for n in active_at(t)]] = True
        codes = None
        if subtype_at is not None:
            codes = np.zeros(64, dtype=np.int8)
            for name, sub in subtype_at(t).items():
                codes[BODY.by_name(name).channel] = subtype_index(sub)
        events += rec.update(t, mask, codes)
    return [e for e in events if e.state in DECISIONS] if decisions_only else events


def summary(events):
    return [(e.gesture, e.state_name, round(e.t, 2)) for e in events]


def test_default_library_lists_table_i_and_the_papers_four() -> None:
    assert {g.name for g in LIB.gestures if g.paper} == {'head_pat', 'hug', 'tickle', 'foot_rub'}
    table_i = ' '.join(g.table_i for g in LIB.gestures).lower()
    for name in ('tickle', 'footrub', 'handshake', 'head-pat', 'shoulder-tap', 'belly-tickle', 'side-tickle',
                 'foot-tickle', 'go-to-sleep', 'wakeup', 'feeding', 'rocking', 'dance'):
        assert name in table_i, name
    undetectable = {g.name for g in LIB.gestures if not g.detectable}
    assert undetectable == {'go_to_sleep', 'wake_up', 'rocking', 'dance'}
    assert all(g.note for g in LIB.gestures if not g.detectable)
    hug, tickle = LIB['hug'], LIB['tickle']
    assert (hug.min_active, len(hug.channels), hug.both_sides) == (4, 10, True)       # "four of ten", both sides
    assert (tickle.min_active, len(tickle.channels)) == (2, 4)                       # "two of four"
    assert (LIB['head_pat'].min_active, len(LIB['head_pat'].channels)) == (1, 3)     # "one of the three"
    assert (LIB['foot_rub'].min_active, len(LIB['foot_rub'].channels)) == (1, 2)     # "one of two"
    assert 'tickle' in hug.supersedes and LIB['hug'].dwell_s == 2.0
    names = [g.name for g in LIB.detectable]
    assert names.index('hug') < names.index('tickle')                              # priority order


def test_dwell_of_two_seconds_then_start_and_end_with_onset() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    events = drive(rec, lambda t: ['head2'] if 1.0 <= t < 4.0 else [], 8.0)
    assert summary(events) == [('head_pat', 'START', 3.0), ('head_pat', 'END', 5.5)]   # END after the 1.5 s gap
    start, end = events
    assert start.onset == pytest.approx(1.0) and start.sensors == ('head2',) and start.state == START
    assert end.state == END and end.reason == 'released' and end.duration_s == pytest.approx(4.5)


def test_shorter_than_dwell_never_starts() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    assert drive(rec, lambda t: ['head2'] if 1.0 <= t < 2.9 else [], 8.0) == []


def test_gaps_shorter_than_gap_s_do_not_restart_the_dwell() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    pats = lambda t: ['head1'] if (t % 1.0) < 0.3 else []      # noqa: E731  (a pat a second, hand lifted)
    events = drive(rec, lambda t: pats(t) if t < 6 else [], 10.0)
    assert summary(events)[0] == ('head_pat', 'START', 2.0)
    assert events[0].onset == 0.0


def test_hug_supersedes_tickle() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    sides = ['side_left_upper', 'side_right_upper']
    hug = [*sides, 'back_upper', 'back_middle', 'chest_left']

    def active(t):
        if t < 4:
            return sides                 # a tickle on both sides
        if t < 9:
            return hug                   # the arms close around the bear
        return []

    events = drive(rec, active, 12.0)
    assert summary(events)[:3] == [('tickle', 'START', 2.0), ('tickle', 'END', 4.0), ('hug', 'START', 6.0)]
    assert events[1].reason == 'superseded by hug'
    assert not any(e.gesture == 'tickle' and e.state == START and e.t > 4 for e in events)


def test_two_gestures_at_once() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    events = drive(rec, lambda t: ['head3', 'foot_left_sole'] if t < 5 else [], 8.0)
    assert sorted(summary(events)) == [('foot_rub', 'END', 6.5), ('foot_rub', 'START', 2.0),
                                       ('head_pat', 'END', 6.5), ('head_pat', 'START', 2.0)]
    assert rec.active_gestures() == {}


def test_hug_needs_both_sides() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    left_only = ['side_left_upper', 'side_left_lower', 'chest_left', 'back_upper', 'back_middle']
    assert not any(e.gesture == 'hug' for e in drive(rec, lambda t: left_only, 5.0))


def test_required_subtype() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    belly = lambda t: ['belly_middle']                               # noqa: E731
    assert [e.gesture for e in drive(rec, belly, 4.0, subtype_at=lambda t: {'belly_middle': 'pet'})] == []
    rec.reset()
    events = drive(rec, belly, 4.0, subtype_at=lambda t: {'belly_middle': 'tickle'})
    assert summary(events) == [('belly_tickle', 'START', 2.0)]
    rec.reset()
    everything = drive(rec, lambda t: [s.name for s in BODY.sensors], 4.0)   # no subtypes known:
    assert {e.gesture for e in everything}.isdisjoint({'belly_tickle', 'foot_tickle'})   # such gestures never match


def test_foot_tickle_supersedes_foot_rub() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    events = drive(rec, lambda t: ['foot_right_sole'], 4.0, subtype_at=lambda t: {'foot_right_sole': 'tickle'})
    assert summary(events) == [('foot_tickle', 'START', 2.0)]


def write(tmp_path, text: str):
    path = tmp_path / 'gestures.yaml'
    path.write_text(text)
    return path


def test_a_user_adds_a_gesture_in_yaml(tmp_path) -> None:
    path = write(tmp_path, 'gestures:\n  ear_rub:\n    sensors: [ear_left, ear_right]\n    min_active: 2\n'
                           '    dwell_s: 0.5\n')
    rec = SymbolicRecogniser(GestureLibrary.load(path, BODY), BODY)
    events = drive(rec, lambda t: ['ear_left', 'ear_right'], 2.0)
    assert summary(events) == [('ear_rub', 'START', 0.5)]


@pytest.mark.parametrize('body, message, line', [
    ('    sensors: [head1, hed2]\n', "unknown sensor 'hed2' (did you mean 'head2'?)", 3),
    ('    sensors: [head]\n', "'head' is a region: list it under 'regions'", 3),
    ('    regions: [left_fot]\n', "unknown region 'left_fot' (did you mean 'left_foot'?)", 3),
    ('    sensors: [head1]\n    min_active: 2\n', 'min_active must be 1..1', 4),
    ('    sensors: [head1]\n    minactive: 1\n', "unknown key 'minactive'", 4),
    ('    sensors: [head1]\n    dwell_s: -1\n', 'seconds >= 0', 4),
    ('    sensors: [head1, head2]\n    both_sides: true\n', 'both_sides needs filter sensors on the left', 4),
    ('    sensors: [head1]\n    subtype: tickel\n', "unknown subtype 'tickel' (did you mean 'tickle'?)", 4),
    ('    sensors: [head1]\n    supersedes: [hugg]\n', "supersedes unknown gesture 'hugg'", 4),
    ('    sensors: [head1]\n    supersedes: [a]\n', 'cannot supersede itself', 4),
    ('    detectable: false\n', "add a 'note'", 3),
    ('    min_active: 1\n', 'needs a locational filter', 3),
])
def test_config_errors_name_file_and_line(tmp_path, body: str, message: str, line: int) -> None:
    path = write(tmp_path, 'gestures:\n  a:\n' + body)
    with pytest.raises(ConfigError) as info:
        GestureLibrary.load(path, BODY)
    assert message in str(info.value)
    assert info.value.path == str(path) and info.value.line == line


def test_supersedes_cycle_is_an_error(tmp_path) -> None:
    path = write(tmp_path, 'gestures:\n  a:\n    sensors: [head1]\n    supersedes: [b]\n'
                           '  b:\n    sensors: [head2]\n    supersedes: [a]\n')
    with pytest.raises(ConfigError, match='cycle'):
        GestureLibrary.load(path, BODY)


def test_body_map_without_a_configured_sensor() -> None:
    """The shipped gestures on a bear whose body map lacks head1: the error names the file, line and sensor."""
    smaller = BodyMap([s for s in BODY.sensors if s.name != 'head1'] +
                      [BodySensor(13, 'head_top', 'top of head', 'head', 'center', 'small')], source='small.yaml')
    with pytest.raises(ConfigError) as info:
        GestureLibrary.default(smaller)
    assert "unknown sensor 'head1'" in str(info.value)
    assert info.value.path == str(share_file('config', 'bear_gestures.yaml')) and info.value.line is not None


def test_with_default_gap_changes_only_default_gaps() -> None:
    wider = LIB.with_default_gap(3.0)
    assert wider['head_pat'].gap_s == 3.0 and wider['shoulder_tap'].gap_s == LIB['shoulder_tap'].gap_s


def test_a_tap_on_the_shoulder_starts_at_its_release_and_a_pat_there_never_does() -> None:
    tap = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['shoulder_left'] if 1.0 <= t < 1.3 else [], 4.0)
    gap = LIB['shoulder_tap'].gap_s
    assert [(g, s) for g, s, _ in summary(tap)] == [('shoulder_tap', 'START'), ('shoulder_tap', 'END')]
    assert tap[0].t == tap[1].t and tap[0].onset == 1.0 and 1.2 + gap < tap[0].t <= 1.2 + gap + 0.1 + 1e-9
    # Pats at 1.5 Hz, the hand lifting for 0.4 s between them: one long touch, not a tap.
    pats = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['shoulder_left'] if 1.0 <= t < 5.0 and (t * 1.5) % 1 < 0.4
                 else [], 8.0)
    assert [e for e in pats if e.gesture == 'shoulder_tap'] == []


def test_max_s_below_dwell_is_a_config_error(tmp_path) -> None:
    path = tmp_path / 'g.yaml'
    path.write_text('gestures:\n  poke_head:\n    sensors: [head1]\n    dwell_s: 1.0\n    max_s: 0.5\n')
    with pytest.raises(ConfigError, match=r'max_s \(0.5 s\) must be at least dwell_s'):
        GestureLibrary.load(path, BODY)


def states(events):
    return [(e.gesture, e.state_name, round(e.t, 2), e.reason) for e in events]


def test_a_candidate_on_the_first_match_then_start_confirms_it() -> None:
    events = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['head2'] if 1.0 <= t < 4.0 else [], 8.0,
                   decisions_only=False)
    assert states(events) == [('head_pat', 'CANDIDATE', 1.0, ''), ('head_pat', 'START', 3.0, ''),
                              ('head_pat', 'END', 5.5, 'released')]
    assert events[0].onset == events[1].onset == 1.0 and events[0].duration_s == 0.0
    assert 0.0 < events[0].confidence < 1.0 and events[1].confidence == 1.0


def test_a_candidate_released_before_its_dwell_is_withdrawn_and_no_decision_follows() -> None:
    rec = SymbolicRecogniser(LIB, BODY)
    events = drive(rec, lambda t: ['head2'] if 1.0 <= t < 2.5 else [], 6.0, decisions_only=False)
    # WITHDRAWN head_pat's lift_s (2.5 s) after the last match (2.4 s): before START a lift that long is a pause
    assert LIB['head_pat'].lift_s == 2.5
    assert states(events) == [('head_pat', 'CANDIDATE', 1.0, ''), ('head_pat', 'WITHDRAWN', 5.0, 'released')]
    assert events[1].onset == 1.0 and events[1].confidence == 0.0 and rec.announced_gestures() == {}


def test_a_touched_filter_is_announced_and_a_superseded_candidate_withdrawn() -> None:
    hug = ['chest_left', 'chest_right', 'back_upper', 'side_left_upper', 'side_right_upper']
    events = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['side_left_upper', 'side_right_upper'] if t < 1.0
                   else hug, 4.0, decisions_only=False)
    # Both are announced on the first touch of the side sensors (hug's filter has them too): hug as touched only.
    assert states(events) == [('hug', 'CANDIDATE', 0.0, ''), ('tickle', 'CANDIDATE', 0.0, ''),
                              ('tickle', 'WITHDRAWN', 1.0, 'superseded by hug'), ('hug', 'START', 3.0, '')]
    assert [e.evidence for e in events if e.state_name == 'CANDIDATE'] == [0, 1]


def test_a_brief_gesture_is_announced_then_confirmed_at_release_or_withdrawn_when_held() -> None:
    tap = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['shoulder_left'] if 1.0 <= t < 1.3 else [], 4.0,
                decisions_only=False)
    assert [(g, s) for g, s, _, _ in states(tap)] == [('shoulder_tap', 'CANDIDATE'), ('shoulder_tap', 'START'),
                                                      ('shoulder_tap', 'END')]
    held = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['shoulder_left'] if 1.0 <= t < 4.0 else [], 8.0,
                 decisions_only=False)
    assert states(held) == [('shoulder_tap', 'CANDIDATE', 1.0, ''),
                            ('shoulder_tap', 'WITHDRAWN', 2.1, 'longer than max_s')]   # once, not again


def test_a_lifting_hand_does_not_withdraw_a_tap_still_in_its_bounds() -> None:
    """A tap, 0.3 s of lift and another tap: the candidate waits for the release (gap_s), not for max_s of time."""
    touch = lambda t: ['shoulder_left'] if 1.0 <= t < 1.2 or 1.5 <= t < 1.7 else []   # noqa: E731
    events = drive(SymbolicRecogniser(LIB, BODY), touch, 5.0, decisions_only=False)
    assert [s for _, s, _, _ in states(events)] == ['CANDIDATE', 'START', 'END']


def test_a_gesture_decided_on_its_first_match_sends_no_candidate(tmp_path) -> None:
    path = write(tmp_path, 'gestures:\n  now:\n    sensors: [head1]\n    dwell_s: 0\n')
    events = drive(SymbolicRecogniser(GestureLibrary.load(path, BODY), BODY), lambda t: ['head1'] if t < 1 else [],
                   4.0, decisions_only=False)
    assert [e.state_name for e in events] == ['START', 'END']


def test_the_candidate_confidence_is_the_tables_rule_of_succession(tmp_path) -> None:
    table = CandidateConfidence.loads('gestures:\n  head_pat: [[0, 0], [5, 8], [9, 9]]\n'
                                      '  hug: [[1, 8], [0, 0], [0, 0]]\n')
    rec = SymbolicRecogniser(LIB, BODY, confidence=table)
    one = drive(rec, lambda t: ['head2'] if t < 0.5 else [], 3.0, decisions_only=False)
    rec.reset()
    three = drive(rec, lambda t: ['head1', 'head2', 'head3'] if t < 0.5 else [], 3.0, decisions_only=False)
    rec.reset()
    chest = drive(rec, lambda t: ['chest_left'] if t < 0.5 else [], 3.0, decisions_only=False)
    assert [(e.evidence, e.confidence) for e in (one[0], three[0], chest[0])] == [
        (1, pytest.approx(6 / 10)), (2, pytest.approx(10 / 11)), (0, pytest.approx(2 / 10))]
    assert chest[0].sensors == ('chest_left',) and table.confidence('tickle', 1) == 0.5   # nothing counted: 0.5


def test_the_shipped_candidate_table_covers_every_detectable_gesture() -> None:
    table = CandidateConfidence.default()
    assert set(table.counts) == {g.name for g in LIB.detectable} and 'synthetic' in table.data
    assert CandidateConfidence.loads(table.dumps()).counts == table.counts


@pytest.mark.parametrize('text, message', [
    ('gestures:\n  hug: [[1, 2]]\n', '3 pairs'),
    ('gestures:\n  hug: [[3, 2], [0, 0], [0, 0]]\n', '0 <= confirmed <= candidates'),
    ('gestures:\n  hug: [[1, 2], [0, 0], [0, 0]]\nformat: 2\n', 'format 2'),
    ('gestures:\n  hug: [[1, 2], [0, 0], [0, 0]]\ndat: x\n', "unknown key 'dat'"),
])
def test_candidate_table_errors(text: str, message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        CandidateConfidence.loads(text)


def test_a_patting_hand_that_lifts_through_the_end_of_the_dwell_is_a_head_pat() -> None:
    """At the real 3.4 Hz scan a pat may be seen on two scans 1.5 s apart and on none at the end of the dwell."""
    rate = 3.4
    seen = {4, 9}                                        # the scans that saw the hand (simulated people do this)
    events = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['head2'] if round(t * rate) in seen else [], 6.0,
                   rate_hz=rate)
    assert [(e.gesture, e.state_name) for e in events][:1] == [('head_pat', 'START')]
    assert events[0].t == pytest.approx(11 / rate) and events[0].onset == pytest.approx(4 / rate)   # in the lift


@pytest.mark.parametrize('seen', [{4}, {4, 5, 6}, {4, 6}], ids=['one scan', 'one touch', 'pats within a third'])
def test_a_single_touch_or_pats_spanning_under_half_the_dwell_do_not_start_in_a_lift(seen) -> None:
    rate = 3.4
    events = drive(SymbolicRecogniser(LIB, BODY), lambda t: ['head2'] if round(t * rate) in seen else [], 6.0,
                   rate_hz=rate)
    assert events == []
