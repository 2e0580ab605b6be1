"""What the touch view shows, kept up to date from messages and read as JSON snapshots.

:class:`ViewState` is fed by the view node's subscription callbacks (the executor thread) and
read by the server's broadcaster thread (:meth:`ViewState.snapshot`). Callbacks only keep
references to the messages' arrays (a published message is never modified, see
:mod:`touch_graph.messages`) and append to bounded deques under a lock; all conversion to JSON
happens in :meth:`snapshot`, outside the executor, at the display rate. Every snapshot is the
whole picture, so a client that missed frames is whole again with the next one.

Times: ``graph`` times are the messages' header stamps (ROS time: simulated time in a simulated
scene), in seconds since the view started; silence is measured in wall seconds since the last
frame arrived, which is what a person watching sees.

Map encodings (compact for 20 Hz): a map is ``base64`` of ``uint8`` cells, row-major, value =
``round(255 * clip(x, 0, 1))``.
"""

from __future__ import annotations

import base64
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from touch_graph.node_health import level_number

__all__ = ['SENSORS', 'SensorActivity', 'ViewState', 'encode_map']

#: sensor -> its frame topic; a sensor is in the scene when its frame topic has a publisher.
SENSORS = {'bear': '/bear/frame', 'patch': '/patch/frame', 'skin': '/skin/frame'}
#: Posterior history shown, graph seconds (sympartner2018 Fig. 7 shows a stretch of a session).
POSTERIOR_WINDOW_S = 10.0
#: Skin contact points kept for one gesture (10 s at 150 Hz) and sent per trajectory.
TRAJECTORY_POINTS = 1500
TRAJECTORY_SENT = 300
LOG_KEPT, LOG_SENT = 200, 60
MAX_DRIVERS = 32


def encode_map(values: np.ndarray) -> str:
    """``base64`` of ``uint8`` ``round(255 * clip(values, 0, 1))``; NaN reads as 0.

    >>> encode_map(np.array([0.0, 0.5, 1.0, 2.0, np.nan], dtype=np.float32))
    'AIA//wA='
    """
    cells = np.nan_to_num(np.asarray(values, dtype=np.float32), nan=0.0, posinf=1.0, neginf=0.0)
    return base64.b64encode(np.rint(np.clip(cells, 0.0, 1.0) * 255.0).astype(np.uint8).tobytes()).decode('ascii')


def _finite(x: float, digits: int = 3) -> float | None:
    """A JSON-safe float (None for NaN/inf), rounded for the wire."""
    x = float(x)
    return round(x, digits) if math.isfinite(x) else None


def _stamp_s(header: Any) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


@dataclass
class SensorActivity:
    """One sensor's liveliness: whether the scene runs it and when its last frame arrived (wall s)."""

    topic: str
    publishers: int = 0
    frames: int = 0
    last_wall: float | None = None
    since_wall: float | None = None  #: when the view first knew the sensor is in the scene
    silent: bool = False

    @property
    def present(self) -> bool:
        return self.publishers > 0 or self.frames > 0


class ViewState:
    """The view's picture of the graph; thread-safe (one lock, held briefly).

    Args:
        body_sensors: ``[{channel, name, location, region, side, ...}]`` of the bear's body map.
        panel_names: names of the patch's 11 capacitive panels, in message order.
        stale_after_s: a sensor with no frame for this many wall seconds is shown as silent.
        start_s: graph time (s) the view started at; log and plot times count from it.
        wall_clock: monotonic seconds (tests pass a fake).
    """

    def __init__(self, body_sensors: Sequence[dict], panel_names: Sequence[str], *, stale_after_s: float = 1.0,
                 start_s: float = 0.0, wall_clock: Callable[[], float] = time.monotonic) -> None:
        if not stale_after_s > 0:
            raise ValueError(f'stale_after_s must be > 0 seconds, got {stale_after_s}')
        self.stale_after_s = stale_after_s
        self.start_s = start_s
        self._wall = wall_clock
        self._lock = threading.Lock()
        self._region_of = {s['name']: s['region'] for s in body_sensors}
        self._panel_names = list(panel_names)
        self.sensors = {name: SensorActivity(topic) for name, topic in SENSORS.items()}
        self._graph_now = 0.0
        self._log: deque[tuple[int, float, str, str]] = deque(maxlen=LOG_KEPT)
        self._log_id = 0
        self._prompt = ''   # of a running collect session; '' when none
        # bear
        self._bear: Any = None
        self._gestures: dict[str, tuple[float, list[str]]] = {}
        self._subtypes: dict[str, str] = {}
        # patch
        self._patch: Any = None
        self._panels: Any = None
        self._handled = False
        self._posteriors: deque[tuple[float, np.ndarray]] = deque(maxlen=4000)
        self._classes: list[str] = []
        self._patch_events: deque[tuple[float, str, float]] = deque(maxlen=50)
        # skin
        self._skin: Any = None
        self._current: deque[tuple[float, float]] = deque(maxlen=TRAJECTORY_POINTS)
        self._last_trace: list[tuple[float, float]] = []
        self._command: dict[str, Any] | None = None
        # drivers
        self._drivers: dict[str, dict[str, Any]] = {}

    # ------------------------------------------------------------------ helpers (lock held)
    def _graph_s(self, header: Any) -> float:
        t = _stamp_s(header) - self.start_s
        self._graph_now = max(self._graph_now, t)
        return t

    def _say(self, t: float, source: str, text: str) -> None:
        self._log_id += 1
        self._log.append((self._log_id, t, source, text))

    def _arrived(self, sensor: str) -> None:
        activity = self.sensors[sensor]
        activity.frames += 1
        activity.last_wall = self._wall()

    # ------------------------------------------------------------------ inputs (executor thread)
    def set_publishers(self, sensor: str, count: int) -> None:
        """How many publishers the sensor's frame topic has (the view node polls the graph)."""
        with self._lock:
            self.sensors[sensor].publishers = int(count)

    def on_bear_frame(self, msg: Any) -> None:
        with self._lock:
            self._graph_s(msg.header)
            self._bear = msg
            self._arrived('bear')

    def on_symbolic(self, msg: Any, start_state: int) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            if msg.state == start_state:
                self._gestures[msg.gesture] = (t, list(msg.sensors))
                self._say(t, 'bear', f'{msg.gesture} started ({", ".join(msg.sensors[:6])}'
                                     f'{", ..." if len(msg.sensors) > 6 else ""})')
            else:
                self._gestures.pop(msg.gesture, None)
                self._say(t, 'bear', f'{msg.gesture} ended after {msg.duration_s:.1f} s')

    def on_subtype(self, msg: Any) -> None:
        with self._lock:
            self._graph_s(msg.header)
            if msg.subtype == 'none':
                self._subtypes.pop(msg.sensor, None)
            elif len(self._subtypes) < 64 or msg.sensor in self._subtypes:
                self._subtypes[msg.sensor] = msg.subtype

    def on_patch_frame(self, msg: Any) -> None:
        with self._lock:
            self._graph_s(msg.header)
            self._patch = msg
            self._arrived('patch')

    def on_panels(self, msg: Any) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            self._panels = msg
            if bool(msg.any_contact) != self._handled:
                self._handled = bool(msg.any_contact)
                touched = [self._panel_name(i) for i, c in enumerate(msg.contact) if c]
                self._say(t, 'panels', f'someone is handling the robot ({", ".join(touched)})' if self._handled
                          else 'hands off')

    def _panel_name(self, index: int) -> str:
        return self._panel_names[index] if index < len(self._panel_names) else f'panel {index}'

    def on_posteriors(self, msg: Any) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            history = self._posteriors
            if history and t < history[-1][0]:  # time went back (a looped bag, a restarted scene)
                history.clear()
                self._patch_events.clear()
            if list(msg.classes) != self._classes:
                self._classes = list(msg.classes)
                history.clear()
            history.append((t, msg.posteriors))
            while history and history[0][0] < t - POSTERIOR_WINDOW_S:
                history.popleft()

    def on_gesture(self, msg: Any) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            self._patch_events.append((t, msg.gesture, float(msg.probability)))
            self._say(t, 'patch', f'{msg.gesture} (p = {msg.probability:.3f}, {msg.latency_s:.2f} s after onset)')

    def on_skin_frame(self, msg: Any) -> None:
        with self._lock:
            self._graph_s(msg.header)
            self._skin = msg
            self._arrived('skin')
            if msg.contact and math.isfinite(msg.contact_x) and math.isfinite(msg.contact_y):
                self._current.append((float(msg.contact_x), float(msg.contact_y)))
            elif self._current:  # the finger lifted: this trace becomes the last one
                self._last_trace = list(self._current)
                self._current.clear()

    def on_command(self, msg: Any) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            self._command = {'t': _finite(t, 2), 'command': msg.command, 'gesture': msg.gesture,
                             'recogniser': msg.recogniser, 'distance': _finite(msg.distance, 4),
                             'margin': _finite(msg.margin, 4), 'duration_s': _finite(msg.duration_s, 2),
                             'frames': int(msg.frames)}
            self._say(t, 'skin', f"command '{msg.command}' from '{msg.gesture}' ({msg.recogniser}, distance "
                                 f'{msg.distance:.3f}, margin {msg.margin:.3f})')

    def on_diagnostics(self, msg: Any) -> None:
        with self._lock:
            t = self._graph_s(msg.header)
            for status in msg.status:
                level = level_number(status)
                before = self._drivers.get(status.name)
                if before is None and len(self._drivers) >= MAX_DRIVERS:
                    continue
                if before is not None and before['level'] < 2 <= level:
                    self._say(t, 'drivers', f'{status.name}: {status.message}')
                self._drivers[status.name] = {
                    'name': status.name, 'level': level, 'message': status.message,
                    'hardware_id': status.hardware_id, 'values': {kv.key: kv.value for kv in status.values[:16]},
                    'wall': self._wall()}

    def on_prompt(self, msg: Any) -> None:
        """The prompt of a ``social-touch collect`` session (std_msgs/String; empty: the session ended)."""
        with self._lock:
            self._prompt = str(msg.data)[:300]

    # ------------------------------------------------------------------ output (any thread)
    def check_silence(self) -> None:
        """Log a sensor that went silent or came back (the broadcaster calls this every tick)."""
        now = self._wall()
        with self._lock:
            for name, activity in self.sensors.items():
                if not activity.present:
                    continue
                if activity.since_wall is None:
                    activity.since_wall = now   # a driver without a frame yet gets the same grace period
                reference = activity.last_wall if activity.last_wall is not None else activity.since_wall
                silent = now - reference > self.stale_after_s
                if silent != activity.silent:
                    activity.silent = silent
                    self._say(self._graph_now, name, f'SILENT: no frame for over {self.stale_after_s:g} s'
                              if silent else 'frames again')

    def snapshot(self) -> dict[str, Any]:
        """The whole picture as JSON-ready data (see the module docstring for encodings)."""
        now = self._wall()
        with self._lock:  # references and small copies only; conversion happens below
            sensors = {name: (a.present, a.silent, a.frames, a.last_wall) for name, a in self.sensors.items()}
            bear, gestures, subtypes = self._bear, dict(self._gestures), dict(self._subtypes)
            patch, panels = self._patch, self._panels
            classes, history, events = list(self._classes), list(self._posteriors), list(self._patch_events)
            skin, current, last_trace, command = self._skin, list(self._current), self._last_trace, self._command
            drivers = [dict(d) for d in self._drivers.values()]
            log = list(self._log)[-LOG_SENT:]
            graph_now, prompt = self._graph_now, self._prompt
        out: dict[str, Any] = {'graph_time': _finite(graph_now, 2), 'stale_after_s': self.stale_after_s,
                               'prompt': prompt}
        out['sensors'] = {name: {'present': present, 'silent': silent, 'frames': frames,
                                 'age_s': None if last is None else _finite(now - last, 2)}
                          for name, (present, silent, frames, last) in sensors.items()}
        out['bear'] = self._bear_part(bear, gestures, subtypes)
        out['patch'] = self._patch_part(patch, panels, classes, history, events)
        out['skin'] = self._skin_part(skin, current, last_trace, command)
        out['drivers'] = [{'name': d['name'], 'level': d['level'], 'message': d['message'],
                           'hardware_id': d['hardware_id'], 'values': d['values'],
                           'age_s': _finite(now - d['wall'], 1)} for d in drivers]
        out['log'] = [{'id': i, 't': _finite(t, 2), 'source': s, 'text': text} for i, t, s, text in log]
        return out

    def _bear_part(self, msg: Any, gestures: dict, subtypes: dict) -> dict[str, Any]:
        regions = sorted({self._region_of[n] for _, names in gestures.values() for n in names if n in self._region_of})
        part: dict[str, Any] = {
            'gestures': [{'gesture': g, 'since': _finite(t, 2), 'sensors': names} for g, (t, names) in
                         sorted(gestures.items())],
            'regions': regions, 'subtypes': subtypes}
        if msg is not None:
            part['levels'] = encode_map(msg.level)
            part['active'] = np.flatnonzero(msg.active).tolist()
            part['faults'] = [[int(c), int(msg.faults[c])] for c in np.flatnonzero(msg.faults)]
        return part

    def _patch_part(self, msg: Any, panels: Any, classes: list[str], history: list, events: list) -> dict[str, Any]:
        part: dict[str, Any] = {'panel_names': self._panel_names}
        if msg is not None:
            part['activation'] = encode_map(msg.activation)
            part['outline'] = encode_map(np.asarray(msg.in_outline, np.float32))  # bool[256]: a list
        if panels is not None:
            part['panels'] = [bool(c) for c in panels.contact]
            part['any_contact'] = bool(panels.any_contact)
        if history:
            latest = history[-1][0]
            part['posteriors'] = {
                'classes': classes, 'window_s': POSTERIOR_WINDOW_S, 'latest': _finite(latest, 3),
                't': [_finite(t - latest, 3) for t, _ in history],
                'p': [[_finite(p, 4) for p in post] for _, post in history]}
            part['events'] = [{'t': _finite(t - latest, 3), 'gesture': g, 'p': _finite(p, 4)}
                              for t, g, p in events if t >= latest - POSTERIOR_WINDOW_S]
        if events:
            t, gesture, p = events[-1]
            part['last_event'] = {'t': _finite(t, 2), 'gesture': gesture, 'p': _finite(p, 4)}
        return part

    def _skin_part(self, msg: Any, current: list, last_trace: list, command: dict | None) -> dict[str, Any]:
        part: dict[str, Any] = {'command': command, 'current': _decimate(current), 'last': _decimate(last_trace)}
        if msg is not None:
            force = np.asarray(msg.force, dtype=np.float64)
            fx, fy, fz = force.reshape(-1, 3).sum(axis=0) if force.size % 3 == 0 else (math.nan,) * 3
            part.update(pressure=encode_map(msg.pressure), contact=bool(msg.contact),
                        point=[_finite(msg.contact_x, 2), _finite(msg.contact_y, 2)] if msg.contact else None,
                        force=[_finite(fx), _finite(fy), _finite(fz)], total_force=_finite(msg.total_force))
        return part


def _decimate(points: list[tuple[float, float]], limit: int = TRAJECTORY_SENT) -> list[list[float | None]]:
    """At most ``limit`` points of a trace, evenly spaced, the last one kept."""
    if len(points) > limit:
        step = math.ceil(len(points) / limit)
        points = points[::step] + ([points[-1]] if (len(points) - 1) % step else [])
    return [[_finite(x, 2), _finite(y, 2)] for x, y in points]
