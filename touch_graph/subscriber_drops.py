"""Messages a node's subscriptions dropped from a full queue (``Subscription.dropped``), brought to where a user
looks: a warning in the node's log (:class:`DropReporter`) and diagnostics (:func:`dropped_by_topic`).
Under real rclpy the counters do not exist and both report nothing.
"""

from __future__ import annotations

from typing import Any

__all__ = ['DropReporter', 'dropped_by_topic']


def dropped_by_topic(node: Any) -> dict[str, int]:
    """``topic -> messages dropped`` over the node's subscriptions, since they were made."""
    out: dict[str, int] = {}
    for sub in getattr(node, 'subscriptions', ()):
        dropped = getattr(sub, 'dropped', None)
        if isinstance(dropped, int):
            out[sub.topic_name] = out.get(sub.topic_name, 0) + dropped
    return out


class DropReporter:
    """Every ``period_s``, warn once per topic whose subscription dropped messages since the last check.

    >>> class Sub:
    ...     topic_name, dropped = '/skin/frame', 0
    >>> class Logger:
    ...     def warning(self, text): print(text[:60])
    >>> class FakeNode:
    ...     subscriptions = [Sub()]
    ...     def create_timer(self, period, callback): pass
    ...     def get_logger(self): return Logger()
    >>> node = FakeNode(); reporter = DropReporter(node)
    >>> node.subscriptions[0].dropped = 7; reporter.check()
    '/skin/frame': 7 messages dropped in the last 5 s (7 since s
    >>> reporter.check(); reporter.total
    7
    """

    def __init__(self, node: Any, period_s: float = 5.0) -> None:
        if not period_s > 0:
            raise ValueError(f'period_s must be > 0, got {period_s}')
        self.node = node
        self.period_s = period_s
        self._seen: dict[str, int] = {}
        node.create_timer(period_s, self.check)

    @property
    def total(self) -> int:
        """Messages dropped over every subscription of the node since start."""
        return sum(dropped_by_topic(self.node).values())

    def check(self) -> None:
        for topic, dropped in dropped_by_topic(self.node).items():
            new = dropped - self._seen.get(topic, 0)
            if new > 0:
                self.node.get_logger().warning(
                    f"'{topic}': {new} messages dropped in the last {self.period_s:g} s ({dropped} since start): "
                    "the subscription's queue was full because its callback falls behind")
            self._seen[topic] = dropped
