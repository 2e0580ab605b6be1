"""A recogniser node's health on ``/diagnostics``: callbacks that raised and messages its subscriptions dropped.

Input callbacks wrapped in :meth:`NodeHealth.guard` log and count an exception (``errors``) and the
node goes on. Every ``period_s`` one ``DiagnosticStatus`` named ``social_touch: <node>``: ERROR with
the last error of the period, WARN for dropped messages, screened frames (:meth:`NodeHealth.screen`)
or a parameter changed after its declaration (logged with old and new value), else OK; a node's
``health_counters()`` (name -> int) add to its values. Works on rclpy and on our runtime.
"""

from __future__ import annotations

import traceback
from collections.abc import Callable
from typing import Any

from .compat import get_message
from .frame_screen import FrameScreen
from .subscriber_drops import DropReporter, dropped_by_topic

__all__ = ['NodeHealth', 'level_number']

_OK, _WARN, _ERROR = 0, 1, 2
_UNSET = object()


def level_number(status: Any) -> int:
    """The level of a ``diagnostic_msgs/DiagnosticStatus`` as a number: 0 OK, 1 WARN, 2 ERROR, 3 STALE.

    The field is a ``byte``, which rclpy (and so our runtime) holds as ``bytes`` of length 1
    (``DiagnosticStatus.WARN == b'\\x01'``); write it with ``bytes([n])``, read it with this.
    """
    return status.level[0]


class NodeHealth:
    """Publish ``node``'s health on ``/diagnostics`` every ``period_s`` seconds (see the module doc)."""

    def __init__(self, node: Any, period_s: float = 5.0) -> None:
        self.node = node
        self.drops = DropReporter(node, period_s)
        self.errors = 0            # guarded callbacks that raised
        self.last_error = ''
        self._errors_seen = 0
        self._drops_seen = 0
        self.screens: list[FrameScreen] = []
        self.parameter_changes = 0
        self.last_parameter_change = ''
        self._changes_seen = 0
        self._values = {name: p.value for name, p in node.get_parameters_by_prefix('').items()}
        node.add_post_set_parameters_callback(self._on_parameters_set)
        self._pub = node.create_publisher(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics', 10)
        node.create_timer(period_s, self.publish)

    def screen(self, topic: str, **kwargs: Any) -> FrameScreen:
        """A :class:`~touch_graph.frame_screen.FrameScreen` for ``topic`` whose findings this health reports."""
        screen = FrameScreen(topic, logger=self.node.get_logger(), **kwargs)
        self.screens.append(screen)
        return screen

    def _on_parameters_set(self, params: list[Any]) -> None:
        """Log and count every change of a declared parameter (a declaration is no change)."""
        for param in params:
            old = self._values.get(param.name, _UNSET)
            self._values[param.name] = param.value
            if old is _UNSET or old == param.value:
                continue
            self.parameter_changes += 1
            self.last_parameter_change = f'{param.name}: {old!r} -> {param.value!r}'
            self.node.get_logger().warning(
                f'parameter {param.name} changed: {old!r} -> {param.value!r} (set from outside the node; '
                f'{self.parameter_changes} changes since start)')

    def guard(self, callback: Callable[..., Any], what: str = 'callback') -> Callable[..., Any]:
        """``callback`` that logs, counts and swallows an ``Exception`` instead of ending the node's spin."""
        def guarded(*args: Any) -> Any:
            try:
                return callback(*args)
            except Exception as err:  # bad input or a recogniser fault: reported, the node goes on
                self.errors += 1
                self.last_error = f'{what}: {type(err).__name__}: {err}'
                logger = self.node.get_logger()
                if self.errors == 1:
                    detail = ''.join(traceback.format_exception(err)).rstrip()
                    logger.error(f'{what} raised (1 so far); the node goes on: {detail}')
                else:
                    logger.error(f'{what} raised ({self.errors} so far); the node goes on: {type(err).__name__}: {err}',
                                 throttle_duration_sec=1.0)
                return None
        return guarded

    def status(self) -> tuple[int, str, dict[str, Any]]:
        """(level, message, counters) for the period since the last call."""
        errors = self.errors
        drops = sum(dropped_by_topic(self.node).values())
        new_errors, new_drops = errors - self._errors_seen, drops - self._drops_seen
        self._errors_seen, self._drops_seen = errors, drops
        counters: dict[str, Any] = {'callback_errors': errors, 'subscriber_drops': drops}
        own = getattr(self.node, 'health_counters', None)
        if own is not None:
            counters.update({str(k): int(v) for k, v in own().items()})
        for screen in self.screens:
            counters.update(screen.counters())
        counters['parameter_changes'] = self.parameter_changes
        if self.last_parameter_change:
            counters['last_parameter_change'] = self.last_parameter_change
        findings: list[tuple[int, str]] = []
        if new_errors:
            last = self.last_error or 'see the node log'
            findings.append((_ERROR, f'{new_errors} callbacks raised in the last period: {last}'))
        findings += [found for found in (s.status() for s in self.screens) if found is not None]
        if new_drops:
            findings.append((_WARN, f'{new_drops} messages dropped by full subscription queues (the node falls '
                                    'behind)'))
        new_changes, self._changes_seen = self.parameter_changes - self._changes_seen, self.parameter_changes
        if new_changes:
            findings.append((_WARN, f'{new_changes} parameter changes from outside the node (last: '
                                    f'{self.last_parameter_change})'))
        if not findings:
            return _OK, 'running', counters
        return max(level for level, _ in findings), '; '.join(text for _, text in findings), counters

    def publish(self) -> None:
        level, text, counters = self.status()
        KeyValue = get_message('diagnostic_msgs/msg/KeyValue')
        status = get_message('diagnostic_msgs/msg/DiagnosticStatus')(
            level=bytes([level]), name=f'social_touch: {self.node.get_fully_qualified_name()}',
            message=text, hardware_id='', values=[KeyValue(key=k, value=str(v)) for k, v in counters.items()])
        self._pub.publish(get_message('diagnostic_msgs/msg/DiagnosticArray')(status=[status]))
