"""Robustness: a recogniser that falls behind has its losses counted and reported, and one that fails at run
time reports ERROR on /diagnostics with the reason (issue 12)."""

from __future__ import annotations

from test_bear_node import Graph, frame  # the bear_gestures test graph, synthetic frames

from touch_graph.messages import get_message
from touch_graph.subscriber_drops import dropped_by_topic

DiagnosticStatus = get_message('diagnostic_msgs/msg/DiagnosticStatus')


def test_frames_lost_by_a_node_that_falls_behind_are_counted_and_warned(capfd) -> None:
    g = Graph(subtype_classifier='rule')
    try:
        for i in range(30):                  # 30 frames arrive while the node's callback does not run
            g.pub.publish(frame(i))
        g.executor.spin_for(0.0)
        assert dropped_by_topic(g.node) == {'/bear/frame': 20}      # its queue keeps the last 10
        assert g.node.frames == 10 and g.node.drops.total == 20
        g.executor.spin_for(5.0)             # the reporter's period
        err = capfd.readouterr().err
        assert "'/bear/frame': 20 messages dropped in the last 5 s (20 since start)" in err
        g.executor.spin_for(5.0)             # nothing new: no second warning
        assert 'dropped' not in capfd.readouterr().err
    finally:
        g.close()


def diagnostics_of(g: Graph) -> list:
    got: list = []
    g.feeder.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                                 lambda m: got.extend(m.status), 100)
    return got


def test_dropped_frames_turn_the_nodes_diagnostics_to_warn() -> None:
    g = Graph(subtype_classifier='rule')
    try:
        got = diagnostics_of(g)
        for i in range(30):
            g.pub.publish(frame(i))
        g.executor.spin_for(5.0)
        mine = [s for s in got if s.name == 'social_touch: /bear/bear_gestures']
        assert mine[0].level == DiagnosticStatus.WARN and '20 messages dropped' in mine[0].message
        assert {kv.key: kv.value for kv in mine[0].values}['subscriber_drops'] == '20'
    finally:
        g.close()


def test_a_recogniser_failing_at_run_time_reports_error_with_the_reason(monkeypatch) -> None:
    g = Graph(subtype_classifier='rule')
    try:
        got = diagnostics_of(g)

        def diverge(*args, **kwargs):          # a stand-in for a run-time fault of the recogniser
            raise FloatingPointError('features diverged')
        monkeypatch.setattr(g.node.recogniser, 'update', diverge)
        g.update([frame(i) for i in range(3)])
        g.executor.spin_for(5.5)
        mine = [s for s in got if s.name == 'social_touch: /bear/bear_gestures']
        assert mine[0].level == DiagnosticStatus.ERROR and 'FloatingPointError: features diverged' in mine[0].message
        g.executor.spin_for(5.5)               # no new failure: back to OK
        mine = [s for s in got if s.name == 'social_touch: /bear/bear_gestures']
        assert len(mine) == 2 and mine[-1].level == DiagnosticStatus.OK
    finally:
        g.close()
