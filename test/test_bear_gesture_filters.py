"""Bear gesture filters (issue 28): foot_rub and feeding need continuous contact (a rub on one foot or
both against a pet that lifts, a hand held at the mouth against a pat), the node's lift_s parameter, the
default lift of a library. Hand-made, synthetic frames and sensor sequences."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import test_bear_node
from test_bear_node import EPOCH_S, Graph, ch, frame

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.bear.pipeline import BearRecogniser
from touch_gestures.bear.symbolic import START, GestureLibrary, SymbolicRecogniser
from touch_graph.errors import ConfigError, ParameterError
from touch_graph.runtime import Context, Parameter

BODY = BodyMap.default()
graph = test_bear_node.graph      # the fixture: graphs of the node, closed after the test
ONE_PLAIN_GESTURE = 'format: 1\ngestures:\n  crown:\n    sensors: [head1]\n'


def _starts(g: Graph) -> list[tuple[str, float]]:
    return [(m.gesture, m.header.stamp.sec - EPOCH_S + m.header.stamp.nanosec * 1e-9)
            for m in g.got['symbolic'] if m.state == START]


def _pats_every_7_scans(g: Graph) -> None:
    """One touched scan in seven at 3.4 Hz: lifts of 2.06 s between touches (a slow patting hand)."""
    head1 = ch('head1')[0]
    g.update(frame(i, {head1: 1.0} if i >= 10 and (i - 10) % 7 == 0 else None) for i in range(40))


def test_the_lift_s_parameter_overrides_the_files_default_lift(graph, tmp_path: Path) -> None:
    gestures = tmp_path / 'g.yaml'
    gestures.write_text(ONE_PLAIN_GESTURE)
    as_filed = graph(subtype_classifier='rule', publish_subtypes=False, gestures=str(gestures))
    assert as_filed.node.recogniser.symbolic.library['crown'].lift_s == 1.5
    _pats_every_7_scans(as_filed)
    assert _starts(as_filed) == []                  # every 2.06 s lift restarts the 2 s dwell
    longer = graph(subtype_classifier='rule', publish_subtypes=False, gestures=str(gestures), lift_s=2.5)
    assert longer.node.recogniser.symbolic.library['crown'].lift_s == 2.5
    _pats_every_7_scans(longer)
    name, t = _starts(longer)[0]          # (once started, the 1.5 s gap_s ends it; the next dwell starts again)
    assert name == 'crown' and t == pytest.approx(17 / 3.4, abs=1e-6)   # the second touch, 2.06 s after the first


def test_the_lift_s_parameter_leaves_gestures_with_their_own_lift_and_brief_ones(graph) -> None:
    g = graph(subtype_classifier='rule', lift_s=0.5)
    library = g.node.recogniser.symbolic.library
    filed = GestureLibrary.default(BODY)
    assert library['head_pat'].lift_s == filed['head_pat'].lift_s == 2.5        # its own, in the file
    assert library['shoulder_tap'].lift_s == filed['shoulder_tap'].gap_s       # brief: its lift is its gap
    assert library['hug'].lift_s == 0.5 and filed['hug'].lift_s == 1.5
    assert graph(subtype_classifier='rule', lift_s=-1.0).node.recogniser.symbolic.library['hug'].lift_s == 1.5


@pytest.mark.parametrize('value, expected', [(math.nan, 'a number of seconds'), (math.inf, 'a number of seconds'),
                                             ('long', 'must be a double')])
def test_a_bad_lift_s_parameter_is_one_clear_error(value, expected) -> None:
    ctx = Context('sim')
    ctx.init()
    with pytest.raises(ParameterError) as err:
        BearGesturesNode(context=ctx, parameter_overrides=[Parameter('lift_s', value=value)])
    assert "'lift_s'" in str(err.value) and expected in str(err.value)
    ctx.shutdown()


def test_a_library_with_another_default_gap_moves_a_brief_gestures_lift_with_it() -> None:
    brief = GestureLibrary.loads('gestures:\n  tap:\n    sensors: [shoulder_left]\n    dwell_s: 0\n    max_s: 1\n',
                                 BODY)
    assert brief['tap'].lift_s == brief['tap'].gap_s == 1.5
    moved = brief.with_default_gap(0.7)['tap']
    assert moved.gap_s == moved.lift_s == 0.7
    assert brief.with_default_lift(3.0)['tap'].lift_s == 1.5


# --- foot_rub and feeding: continuous contact (lift_s 0), hand-made sequences at the real 3.4 Hz ---------------

LIB = GestureLibrary.default(BODY)
SCAN_S = 1 / 3.4


def _run(touched, seconds: float = 12.0, lib: GestureLibrary = LIB) -> list:
    """Events of the shipped gestures over scans ``i`` whose active sensors are ``touched(i)`` (names)."""
    rec = SymbolicRecogniser(lib, BODY)
    events = []
    for i in range(int(seconds / SCAN_S)):
        mask = np.zeros(64, dtype=bool)
        mask[[BODY.by_name(n).channel for n in touched(i)]] = True
        events += rec.update(i * SCAN_S, mask)
    return events


def _started(events: list, gesture: str) -> list[float]:
    return [round(e.t / SCAN_S) for e in events if e.gesture == gesture and e.state == START]


def _during(first: int, last: int, sensors: list[str], lifted=lambda i: False):
    return lambda i: sensors if first <= i <= last and not lifted(i) else []


@pytest.mark.parametrize('feet', [['foot_left_sole'], ['foot_right_sole'], ['foot_left_sole', 'foot_right_sole']])
def test_a_rub_on_one_foot_or_both_starts_foot_rub_after_the_dwell(feet) -> None:
    """A rub keeps contact: 20 scans (5.9 s) on one sole or both, START at the first scan 2 s after the onset."""
    assert LIB['foot_rub'].lift_s == 0.0 and LIB['foot_rub'].min_active == 1
    assert _started(_run(_during(5, 25, feet)), 'foot_rub') == [5 + 7]      # 7 scans = 2.06 s >= dwell_s


@pytest.mark.parametrize('every', [2, 3, 4])
def test_a_pet_or_pat_that_lifts_off_the_sole_is_no_foot_rub(every: int) -> None:
    """Strokes that leave the sole for one scan in ``every`` (a pet at 3.4 Hz / every): each lift restarts the
    dwell, so however long it goes on it is no foot rub (it was one with the default 1.5 s lift)."""
    petting = _during(5, 35, ['foot_left_sole'], lifted=lambda i: i % every == 0)
    assert _started(_run(petting), 'foot_rub') == []
    tolerant = GestureLibrary([replace(g, lift_s=1.5) if g.name == 'foot_rub' else g for g in LIB.gestures],
                              LIB.source, LIB.default_dwell_s, LIB.default_gap_s, LIB.default_lift_s)
    assert _started(_run(petting, lib=tolerant), 'foot_rub') != []


def test_a_hand_held_at_the_mouth_is_feeding_and_a_pat_on_it_is_not() -> None:
    holding = _during(5, 25, ['mouth', 'snout'])
    assert _started(_run(holding), 'feeding') == [12]
    patting = _during(5, 40, ['mouth'], lifted=lambda i: i % 3 == 0)       # a pat about every 0.9 s
    assert _started(_run(patting), 'feeding') == []


def test_one_scan_without_the_hand_restarts_the_feeding_dwell() -> None:
    """A held hand missing from one scan (scan 9): the dwell starts again at scan 10, START 2 s after it."""
    held = _during(5, 30, ['snout'], lifted=lambda i: i == 9)
    assert _started(_run(held), 'feeding') == [10 + 7]


def test_nan_and_empty_frames_through_the_pipeline_read_as_no_touch() -> None:
    """Levels NaN for one scan in a rub (counted, read as 0): the dwell restarts; empty frames START nothing."""
    rec = BearRecogniser(3.4, subtypes=False, classify=False)
    sole = BODY.by_name('foot_left_sole').channel
    starts = []
    for i in range(40):
        levels = np.zeros(64, dtype=np.float32)
        if 5 <= i <= 30:
            levels[sole] = math.nan if i == 8 else 0.9
        if i == 35:
            levels[:] = math.nan                                            # a garbage frame
        starts += [round(e.t / SCAN_S) for e in rec.update(i * SCAN_S, levels).symbolic_events
                   if e.state == START]
    assert starts == [9 + 7]
    assert rec.buffer.invalid_counts[sole] == 2 and rec.buffer.invalid_counts.sum() == 65
    assert not any(rec.update(i * SCAN_S, np.zeros(64, np.float32)).symbolic_events for i in range(40, 60))


@pytest.mark.parametrize('line, expected', [
    ('    lift: 0.0', "did you mean 'lift_s'"),
    ('    lift_s: -0.3', "'lift_s' in gesture 'foot_rub' must be a number of seconds >= 0"),
    ('    lift_s: .nan', "'lift_s' in gesture 'foot_rub' must be a number of seconds >= 0"),
    ('    lift_s: none', "'lift_s'"),
])
def test_a_typo_in_foot_rubs_lift_is_a_clear_error_with_the_line(line: str, expected: str) -> None:
    text = f'format: 1\ngestures:\n  foot_rub:\n    sensors: [foot_left_sole, foot_right_sole]\n{line}\n'
    with pytest.raises(ConfigError) as err:
        GestureLibrary.loads(text, BODY, source='g.yaml')
    assert expected in str(err.value) and 'g.yaml:5' in str(err.value)
