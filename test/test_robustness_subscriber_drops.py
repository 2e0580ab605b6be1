"""Robustness: a subscriber that falls behind has its losses counted and reported (issue 12)."""

from __future__ import annotations

from test_bear_node import Graph, frame  # the bear_gestures test graph, synthetic frames

from touch_graph.subscriber_drops import dropped_by_topic


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
