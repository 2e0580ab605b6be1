"""A recording session on disk: one rosbag2 (MCAP) with the sensor's topics and ``/touch/label``.

:class:`SessionWriter` records the sensor's messages and one ``social_touch_msgs/msg/TouchLabel`` per
kept trial on :data:`LABEL_TOPIC`; ``metadata.yaml``'s ``custom_data`` names the sensor and whether the
data is synthetic. :func:`read_session` reads one back and checks it: missing labels or sensor topic,
overlapping or outlying labels, another sensor's labels are a :class:`SessionError` naming bag and time.
"""

from __future__ import annotations

import itertools
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader

from touch_graph import messages
from touch_graph.bag import BagRecorder
from touch_graph.errors import ConfigError
from touch_graph.yamlconf import read_text, safe_load

__all__ = ['LABEL_TOPIC', 'LABEL_TYPE', 'SENSOR_TOPICS', 'LabelRow', 'SessionError', 'SessionRecording',
           'SessionWriter', 'read_session', 'read_sessions']

LABEL_TOPIC = '/touch/label'
LABEL_TYPE = 'social_touch_msgs/msg/TouchLabel'
_NS = 1_000_000_000

#: What a session of each sensor records: topic -> message type (the driver nodes' outputs).
SENSOR_TOPICS: dict[str, dict[str, str]] = {
    'bear': {'/bear/frame': 'social_touch_msgs/msg/BearFrame'},
    'patch': {'/patch/frame': 'social_touch_msgs/msg/PatchFrame',
              '/patch/panels': 'social_touch_msgs/msg/PanelContact'},
    'skin': {'/skin/frame': 'social_touch_msgs/msg/SkinFrame'},
}
#: The topic a sensor's recogniser learns from (the first of SENSOR_TOPICS).
FRAME_TOPIC = {sensor: next(iter(topics)) for sensor, topics in SENSOR_TOPICS.items()}


class SessionError(ConfigError):
    """A session bag that cannot be trained or evaluated on; the message names the bag and the time."""


def _time(ns: int) -> Any:
    return messages.get_message('builtin_interfaces/msg/Time')(sec=int(ns // _NS), nanosec=int(ns % _NS))


class SessionWriter:
    """Write one session bag.

    Args:
        path: the bag directory to create (must not exist).
        sensor: ``'bear'``, ``'patch'`` or ``'skin'``.
        synthetic: True when simulated people made the data (readers and model cards say so).
        flush_period_s: see :class:`~touch_graph.bag.BagRecorder` (a live session survives a crash).
    """

    def __init__(self, path: str | os.PathLike, sensor: str, *, synthetic: bool,
                 flush_period_s: float | None = 1.0) -> None:
        if sensor not in SENSOR_TOPICS:
            raise ValueError(f"sensor must be one of {', '.join(SENSOR_TOPICS)}; got {sensor!r}")
        self.sensor = sensor
        self.labels = 0
        self._label_cls = messages.get_message(LABEL_TYPE)
        self._bag = BagRecorder(path, flush_period_s=flush_period_s, custom_data={
            'social_touch.session_sensor': sensor, 'social_touch.synthetic': 'true' if synthetic else 'false'})
        self._bag.open()
        for topic, type_name in {**SENSOR_TOPICS[sensor], LABEL_TOPIC: LABEL_TYPE}.items():
            self._bag.add_topic(topic, type_name)

    @property
    def path(self) -> Path:
        return self._bag.path

    def write(self, topic: str, message: Any, stamp_ns: int) -> None:
        """Record one sensor message received at ``stamp_ns`` (ROS time, ns)."""
        self._bag.write(topic, SENSOR_TOPICS[self.sensor][topic], stamp_ns, messages.serialize(message))

    def write_raw(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Record one sensor message as received (CDR bytes) at ``stamp_ns`` (ROS time, ns)."""
        self._bag.write(topic, SENSOR_TOPICS[self.sensor][topic], stamp_ns, data)

    def label(self, person: str, gesture: str, variant: str, start_ns: int, end_ns: int, stamp_ns: int) -> Any:
        """Record the label of one kept trial (ROS time, ns); returns the message."""
        if not end_ns > start_ns:
            raise ValueError(f'a trial must end after it starts; got {start_ns} .. {end_ns} ns')
        msg = self._label_cls(person=person, gesture=gesture, variant=variant, sensor=self.sensor,
                              start=_time(start_ns), end=_time(end_ns))
        msg.header.stamp = _time(stamp_ns)
        self._bag.write(LABEL_TOPIC, LABEL_TYPE, stamp_ns, messages.serialize(msg))
        self.labels += 1
        return msg

    def close(self) -> None:
        self._bag.close()

    def __enter__(self) -> SessionWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


# ----------------------------------------------------------------------------- reading
@dataclass(frozen=True)
class LabelRow:
    """One labelled trial: who, what, how, and when (s since the bag's first sensor message)."""

    person: str
    gesture: str
    variant: str
    start_s: float
    end_s: float


@dataclass
class SessionRecording:
    """One session bag, read and checked.

    Attributes:
        path: the bag.
        sensor: which sensor it recorded.
        synthetic: from the bag's metadata (False when it does not say).
        origin_ns: ROS time of the first sensor message; every time below counts from it.
        labels: the trials, in time order.
        stamps_s: topic -> (n,) float64 message times, s from ``origin_ns``.
        frames: topic -> the n deserialised messages, in time order.
        warnings: what was odd but usable (undecodable messages skipped, ...), each naming the bag.
    """

    path: Path
    sensor: str
    synthetic: bool
    origin_ns: int
    labels: list[LabelRow]
    stamps_s: dict[str, np.ndarray]
    frames: dict[str, list[Any]]
    warnings: list[str] = field(default_factory=list)

    @property
    def people(self) -> list[str]:
        return sorted({lab.person for lab in self.labels})

    @property
    def duration_s(self) -> float:
        return max((float(s[-1]) for s in self.stamps_s.values() if len(s)), default=0.0)

    def rate_hz(self, topic: str | None = None) -> float:
        """Frame rate of ``topic`` (default: the sensor's frame topic): 1 / median step, Hz."""
        steps = np.diff(self.stamps_s[topic or FRAME_TOPIC[self.sensor]])
        steps = steps[steps > 0]
        if not len(steps):
            raise SessionError(f'{self.path}: fewer than two frames with different stamps; no rate')
        return 1.0 / float(np.median(steps))


def _open(path: Path):
    if not path.exists():
        raise SessionError(f'session bag {path} not found')
    try:
        reader = Reader(path)
        reader.open()
    except Exception as err:  # rosbags raises several kinds for a damaged bag
        raise SessionError(f'cannot open session bag {path}: {err}') from err
    return reader


def _stamp_ns(msg: Any) -> int:
    return int(msg.sec) * _NS + int(msg.nanosec)


def read_session(path: str | os.PathLike, sensor: str) -> SessionRecording:
    """Read and check one session bag of ``sensor`` (module doc).

    Raises:
        SessionError: naming the bag (and the time in it) for a missing or damaged bag, a bag of
            another sensor, no frames, no labels, labels that overlap or lie outside the frames.
    """
    if sensor not in SENSOR_TOPICS:
        raise ValueError(f"sensor must be one of {', '.join(SENSOR_TOPICS)}; got {sensor!r}")
    path = Path(path)
    reader = _open(path)
    warnings: list[str] = []
    try:
        topics = {c.topic: c.msgtype for c in reader.connections}
        frame_topic = FRAME_TOPIC[sensor]
        if frame_topic not in topics:
            other = [s for s, t in FRAME_TOPIC.items() if t in topics]
            hint = f': it is a {other[0]} session' if other else ''
            raise SessionError(f'{path} has no {frame_topic} (a {sensor} session records it){hint}; '
                               f'its topics: {", ".join(sorted(topics)) or "none"}')
        if LABEL_TOPIC not in topics:
            raise SessionError(f'{path} has no labels ({LABEL_TOPIC}): record sessions with `social-touch collect '
                               f'{sensor}`, or train from a CSV')
        wanted = {**SENSOR_TOPICS[sensor], LABEL_TOPIC: LABEL_TYPE}
        for topic, type_name in wanted.items():
            if topic in topics and topics[topic] != type_name:
                raise SessionError(f'{path}: {topic} carries {topics[topic]}; expected {type_name}')
        conns = [c for c in reader.connections if c.topic in wanted]
        raw_frames: dict[str, list[Any]] = {t: [] for t in SENSOR_TOPICS[sensor] if t in topics}
        raw_stamps: dict[str, list[int]] = {t: [] for t in raw_frames}
        label_msgs: list[Any] = []
        skipped: dict[str, int] = {}
        for conn, log_ns, raw in reader.messages(connections=conns):
            try:
                msg = messages.deserialize(raw, conn.msgtype)
            except Exception:  # a damaged message is counted and skipped, never fatal
                skipped[conn.topic] = skipped.get(conn.topic, 0) + 1
                continue
            if conn.topic == LABEL_TOPIC:
                label_msgs.append(msg)
            else:
                raw_frames[conn.topic].append(msg)
                header = getattr(msg, 'header', None)
                raw_stamps[conn.topic].append(_stamp_ns(header.stamp) if header is not None else int(log_ns))
    finally:
        reader.close()
    for topic, n in skipped.items():
        warnings.append(f'{path}: {n} undecodable messages on {topic} skipped')
    if len(raw_frames[frame_topic]) < 2:
        raise SessionError(f'{path}: {len(raw_frames[frame_topic])} readable messages on {frame_topic}; '
                           'need at least 2')
    origin = min(s[0] for s in raw_stamps.values() if s)
    stamps_s, frames = {}, {}
    for topic, stamps in raw_stamps.items():
        order = np.argsort(np.array(stamps, dtype=np.int64), kind='stable')
        stamps_s[topic] = (np.array(stamps, dtype=np.int64)[order] - origin) / _NS
        frames[topic] = [raw_frames[topic][i] for i in order]
    labels = _check_labels(path, sensor, label_msgs, origin, float(stamps_s[frame_topic][-1]), warnings)
    synthetic = _custom_data(path).get('social_touch.synthetic', 'false') == 'true'
    return SessionRecording(path, sensor, synthetic, origin, labels, stamps_s, frames, warnings)


def _custom_data(path: Path) -> dict[str, str]:
    """``custom_data`` of the bag's metadata.yaml (empty when absent or unreadable: it only informs)."""
    try:
        doc = safe_load(read_text(path / 'metadata.yaml'), str(path / 'metadata.yaml'))
        return {str(k): str(v) for k, v in (doc['rosbag2_bagfile_information'].get('custom_data') or {}).items()}
    except (ConfigError, KeyError, TypeError, AttributeError):
        return {}


def _check_labels(path: Path, sensor: str, msgs: list[Any], origin_ns: int, last_s: float,
                  warnings: list[str]) -> list[LabelRow]:
    if not msgs:
        raise SessionError(f'{path} has a {LABEL_TOPIC} topic but no readable label on it')
    rows = []
    for msg in msgs:
        if msg.sensor and msg.sensor != sensor:
            raise SessionError(f'{path}: labels are for the {msg.sensor}, not the {sensor}; '
                               f'use `social-touch train {msg.sensor}`')
        start, end = (_stamp_ns(msg.start) - origin_ns) / _NS, (_stamp_ns(msg.end) - origin_ns) / _NS
        where = f'{path} at {start:.2f} s'
        if not msg.person or not msg.gesture:
            raise SessionError(f'{where}: a label without person or gesture')
        if not end > start:
            raise SessionError(f'{where}: label {msg.gesture!r} ends at {end:.2f} s, before it starts')
        if start < -0.5 or end > last_s + 0.5:
            raise SessionError(f'{where}: label {msg.gesture!r} ({start:.2f} .. {end:.2f} s) lies outside the '
                               f'recording (0 .. {last_s:.2f} s of sensor frames)')
        rows.append(LabelRow(msg.person, msg.gesture, msg.variant, max(0.0, start), min(last_s, end)))
    rows.sort(key=lambda r: r.start_s)
    for a, b in itertools.pairwise(rows):
        if b.start_s < a.end_s:
            raise SessionError(f'{path} at {b.start_s:.2f} s: label {b.gesture!r} of {b.person} overlaps '
                               f'{a.gesture!r} ({a.start_s:.2f} .. {a.end_s:.2f} s); fix or drop one of them')
    return rows


def read_sessions(paths: list[str | os.PathLike], sensor: str, progress=None) -> list[SessionRecording]:
    """Read several session bags (progress as ``progress(text)``); warnings are passed to ``progress`` too."""
    out = []
    say = progress or (lambda _m: None)
    for i, path in enumerate(paths):
        say(f'reading {path} ({i + 1}/{len(paths)})')
        session = read_session(path, sensor)
        for w in session.warnings:
            say(f'warning: {w}')
        out.append(session)
    return out
