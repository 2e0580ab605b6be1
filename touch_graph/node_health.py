"""A recogniser node's health on ``/diagnostics``: callbacks that raised and messages its subscriptions dropped.

The runtime keeps a failing callback from stopping the graph (it logs it and counts it in
``node.callback_errors``); :class:`NodeHealth` also says so where monitors look: every ``period_s`` one
``diagnostic_msgs/DiagnosticStatus`` named ``social_touch: <node>``, ERROR with the last error when a
callback raised in the period, WARN when a subscription dropped messages (and a warning in the log,
through :class:`~touch_graph.subscriber_drops.DropReporter`), OK otherwise. A node with a
``health_counters()`` method (name -> int) adds its own counters to the status's values, so what
became of its inputs is visible where the monitors look (rqt_robot_monitor, `topic echo /diagnostics`).
"""

from __future__ import annotations

from typing import Any

from .compat import USING_ROS, get_message
from .subscriber_drops import DropReporter, dropped_by_topic

__all__ = ['NodeHealth']

_OK, _WARN, _ERROR = 0, 1, 2


class NodeHealth:
    """Publish ``node``'s health on ``/diagnostics`` every ``period_s`` seconds (see the module doc)."""

    def __init__(self, node: Any, period_s: float = 5.0) -> None:
        self.node = node
        self.drops = DropReporter(node, period_s)
        self._errors_seen = 0
        self._drops_seen = 0
        self._pub = node.create_publisher(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics', 10)
        node.create_timer(period_s, self.publish)

    def status(self) -> tuple[int, str, dict[str, int]]:
        """(level, message, counters) for the period since the last call."""
        errors = int(getattr(self.node, 'callback_errors', 0))
        drops = sum(dropped_by_topic(self.node).values())
        new_errors, new_drops = errors - self._errors_seen, drops - self._drops_seen
        self._errors_seen, self._drops_seen = errors, drops
        counters = {'callback_errors': errors, 'subscriber_drops': drops}
        own = getattr(self.node, 'health_counters', None)
        if own is not None:
            counters.update({str(k): int(v) for k, v in own().items()})
        if new_errors:
            last = getattr(self.node, 'last_callback_error', '') or 'see the node log'
            return _ERROR, f'{new_errors} callbacks raised in the last period: {last}', counters
        if new_drops:
            return _WARN, f'{new_drops} messages dropped by full subscription queues (the node falls behind)', counters
        return _OK, 'running', counters

    def publish(self) -> None:
        level, text, counters = self.status()
        KeyValue = get_message('diagnostic_msgs/msg/KeyValue')
        status = get_message('diagnostic_msgs/msg/DiagnosticStatus')(
            level=bytes([level]) if USING_ROS else level, name=f'social_touch: {self.node.get_fully_qualified_name()}',
            message=text, hardware_id='', values=[KeyValue(key=k, value=str(v)) for k, v in counters.items()])
        self._pub.publish(get_message('diagnostic_msgs/msg/DiagnosticArray')(status=[status]))
