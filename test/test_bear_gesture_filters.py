"""Bear gesture filters (issue 28): the node's lift_s parameter, and the default lift of a library.
Hand-made, synthetic frames and sensor sequences."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import test_bear_node
from test_bear_node import EPOCH_S, Graph, ch, frame

from touch_driver.bear.body_map import BodyMap
from touch_gestures.bear.node import BearGesturesNode
from touch_gestures.bear.symbolic import START, GestureLibrary
from touch_graph.errors import ParameterError
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
