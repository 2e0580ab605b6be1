"""``touch_monitor``: prints what the robot perceives, one line per event, as it happens.

A behaviour system subscribes to the same topics; this node is the human-readable view of
them for the demo and for a person watching a robot:

    [  12.35 s] bear      hug started (back_upper, side_left_upper, side_right_upper, shoulder_left)
    [  14.10 s] patch     stroke (p = 0.998, 0.85 s after onset)
    [  16.02 s] skin      command 'stop' from gesture 'line_left_to_right' (centroid, margin 0.31)
    [  17.00 s] panels    someone is handling the robot (front_left)

Only topics whose messages arrive are printed, so the same node serves any scene. Time is
seconds since the node started, on the graph's clock (simulated time in a simulated scene).
``show_subtypes`` (print every touch subtype change too) can be switched while it runs.
"""

from __future__ import annotations

import sys
from typing import Any, TextIO

from touch_graph.compat import Node, SetParametersResult, get_message, sensor_data_qos
from touch_graph.node_main import run_node

__all__ = ['TouchMonitorNode', 'main']

SymbolicGesture = get_message('social_touch_msgs/msg/SymbolicGesture')
TouchSubtype = get_message('social_touch_msgs/msg/TouchSubtype')
GestureEvent = get_message('social_touch_msgs/msg/GestureEvent')
HapticCommand = get_message('social_touch_msgs/msg/HapticCommand')
PanelContact = get_message('social_touch_msgs/msg/PanelContact')


class TouchMonitorNode(Node):
    """Subscribes to the perception topics and prints one line per event."""

    def __init__(self, stream: TextIO | None = None, **kwargs: Any) -> None:
        super().__init__('touch_monitor', **kwargs)
        self.show_subtypes = self.declare_parameter('show_subtypes', False).value
        self.stream = stream or sys.stdout
        self.lines: list[str] = []
        self._start_ns = self.get_clock().now().nanoseconds
        self._handled = False
        self.create_subscription(SymbolicGesture, '/touch/symbolic', self._on_symbolic, 50)
        self.create_subscription(TouchSubtype, '/touch/subtype', self._on_subtype, 200)
        self.create_subscription(GestureEvent, '/touch/gesture', self._on_gesture, 50)
        self.create_subscription(HapticCommand, '/touch/haptic_command', self._on_command, 50)
        self.create_subscription(PanelContact, '/patch/panels', self._on_panels, sensor_data_qos(50))
        self.add_on_set_parameters_callback(self._on_set_parameters)

    def _on_set_parameters(self, params: list[Any]) -> Any:
        for param in params:
            if param.name == 'show_subtypes':
                self.show_subtypes = bool(param.value)
        return SetParametersResult(successful=True)

    def _say(self, source: str, text: str) -> None:
        seconds = (self.get_clock().now().nanoseconds - self._start_ns) * 1e-9
        line = f'[{seconds:8.2f} s] {source:<9} {text}'
        self.lines.append(line)
        if len(self.lines) > 1000:  # bounded on long runs; the stream has them all
            del self.lines[:500]
        print(line, file=self.stream, flush=True)

    def _on_symbolic(self, msg: Any) -> None:
        if msg.state == SymbolicGesture.START:
            sensors = ', '.join(msg.sensors[:6]) + (', ...' if len(msg.sensors) > 6 else '')
            self._say('bear', f'{msg.gesture} started ({sensors})')
        elif msg.state == SymbolicGesture.END:  # a CANDIDATE or WITHDRAWN is no decision: not said
            self._say('bear', f'{msg.gesture} ended after {msg.duration_s:.1f} s')

    def _on_subtype(self, msg: Any) -> None:
        if self.show_subtypes and msg.subtype != 'none':
            self._say('bear', f'{msg.subtype} on {msg.sensor} (peak {msg.peak_amplitude:.2f}, '
                              f'{msg.base_frequency_hz:.1f} Hz)')

    def _on_gesture(self, msg: Any) -> None:
        self._say('patch', f'{msg.gesture} (p = {msg.probability:.3f}, {msg.latency_s:.2f} s after onset)')

    def _on_command(self, msg: Any) -> None:
        self._say('skin', f"command '{msg.command}' from gesture '{msg.gesture}' "
                          f'({msg.recogniser}, distance {msg.distance:.3f}, margin {msg.margin:.3f})')

    def _on_panels(self, msg: Any) -> None:
        if msg.any_contact and not self._handled:
            touched = [str(i) for i, c in enumerate(msg.contact) if c]
            self._say('panels', f'someone is handling the robot (panels {", ".join(touched)})')
        elif not msg.any_contact and self._handled:
            self._say('panels', 'hands off')
        self._handled = bool(msg.any_contact)


def main(args: list[str] | None = None) -> int:
    return run_node(TouchMonitorNode, args)
