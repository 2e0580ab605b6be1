"""Labelled patch recordings for training and evaluation: CoST-layout CSV and rosbag2 bags.

A :class:`Session` is one recording of one subject with one gesture class (sympartner2018 6.3): for
training, every frame gets the session's class, silences included.

**CSV** in the layout of the Corpus of Social Touch (CoST), one row per frame::

    subject,variant,gesture,frame,ch1,ch2,...,chN

``N = rows * cols`` channels, row-major. A session starts where subject, variant or gesture changes
or the frame number does not increase. Values are raw counts turned into activations by eq. (1)-(2)
(:func:`activation_from_raw`), or activations (``values='activation'``); empty cells are NaN.

**Bags**: a YAML manifest lists rosbag2 recordings of ``/patch/frame``::

    topic: /patch/frame        # optional (default)
    sessions:
      - {bag: bags/p1_stroke, subject: p1, gesture: stroke}
      - {bag: bags/p1_push, subject: p1, gesture: push, events: [[2.1, 4.0], [9.5, 11.2]]}

Bag paths are relative to the manifest; ``events`` (onset, offset, s from the bag's first frame) are
optional ground truth, else events are segmented.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from rosbags.rosbag2 import Reader

from touch_graph.errors import ConfigError, MessageError
from touch_graph.messages import deserialize
from touch_graph.yamlconf import check_keys, load_yaml, typed
from touch_sim.patch.render import FRAME_RATE_HZ, render_scene

__all__ = ['DatasetError', 'Session', 'activation_from_raw', 'parse_grid', 'read_bag_manifest', 'read_cost_csv',
           'render_session']

_HEADER = ('subject', 'variant', 'gesture', 'frame')


class DatasetError(ConfigError):
    """A recording (CSV, manifest, bag) is missing, malformed or inconsistent."""


@dataclass
class Session:
    """One labelled, continuous recording.

    Attributes:
        subject: who performed it (the unit of leave-one-subject-out).
        gesture: the session's class; every frame is labelled with it for training.
        activations: (T, R, C) float32 activation maps, unitless in [k, 1] (NaN = no reading).
        rate_hz: frame rate, Hz.
        events: ground-truth (onset_s, offset_s) of the gestures, or None to segment them.
        source: where it came from (file:line, bag path or "simulated").
        synthetic: True for simulated data (reports must say so).
        panels: optional (T, 11) bool panel contact per frame.
    """

    subject: str
    gesture: str
    activations: np.ndarray
    rate_hz: float
    events: list[tuple[float, float]] | None = None
    source: str = ''
    synthetic: bool = False
    panels: np.ndarray | None = field(default=None, repr=False)

    @property
    def n_frames(self) -> int:
        return int(self.activations.shape[0])

    @property
    def grid(self) -> tuple[int, int]:
        return (int(self.activations.shape[1]), int(self.activations.shape[2]))


def parse_grid(text: str) -> tuple[int, int]:
    """``'8x8'`` -> ``(8, 8)``.

    >>> parse_grid('16x16'), parse_grid('8X4')
    ((16, 16), (8, 4))
    """
    parts = str(text).lower().replace('*', 'x').split('x')
    try:
        rows, cols = (int(p) for p in parts)
    except ValueError:
        raise ValueError(f'grid must be ROWSxCOLS such as 8x8 (CoST) or 16x16 (the patch); got {text!r}') from None
    if rows < 1 or cols < 1:
        raise ValueError(f'grid must have at least one row and column; got {text!r}')
    return rows, cols


def activation_from_raw(raw: np.ndarray, gain: float, k: float = 0.08, tau: float = 0.001) -> np.ndarray:
    """Eq. (1)-(2) of sympartner2018 6.1 on raw counts of any grid, frame by frame.

    ``m_t = min(a_t, m_{t-1} + tau (a_t - m_{t-1}))`` tracks each cell's resting value
    (instantly down, slowly up with rate ``tau`` per frame), ``r_t = min(max(g (a_t - m_t), k), 1)``.
    The first frame starts the minimum. A NaN reading leaves the cell's minimum unchanged
    and gives a NaN activation.

    Args:
        raw: (T, R, C) raw readings (counts).
        gain: g, per count (e.g. 1 / counts at full activation).
        k: activation floor (paper: 0.08).
        tau: adaptation rate of the minimum per frame.

    Returns:
        (T, R, C) float32 activations.

    >>> [round(float(v), 4) for v in activation_from_raw(np.array([[[10.0]], [[60.0]], [[5.0]]]), gain=0.01).ravel()]
    [0.08, 0.4995, 0.08]
    """
    a = np.asarray(raw, dtype=np.float64)
    if a.ndim != 3:
        raise ValueError(f'raw must be (T, R, C); got shape {a.shape}')
    out = np.empty(a.shape, dtype=np.float32)
    if a.shape[0] == 0:
        return out
    m = np.where(np.isfinite(a[0]), a[0], np.nan)
    for t in range(a.shape[0]):
        frame = a[t]
        ok = np.isfinite(frame)
        fresh = ok & np.isnan(m)
        m = np.where(fresh, frame, m)
        m = np.where(ok, np.minimum(frame, m + tau * (frame - m)), m)
        out[t] = np.clip(gain * (frame - m), k, 1.0)  # NaN stays NaN
    return out


def read_cost_csv(path: str | Path, grid: tuple[int, int] = (8, 8), rate_hz: float = 135.0,
                  values: str = 'raw', gain: float | None = None, k: float = 0.08, tau: float = 0.001,
                  max_rows: int | None = None) -> list[Session]:
    """Read a CoST-layout CSV into sessions.

    Args:
        path: the CSV file (header row required).
        grid: (rows, cols); the file must have rows * cols channel columns.
        rate_hz: the frame rate of the recording (CoST: 135 Hz).
        values: 'raw' (counts, converted by eq. 1-2) or 'activation' (already in [k, 1]).
        gain: eq. (2) gain for raw values, per count (default 1/1023, the 10-bit full scale).
        k, tau: eq. (1)-(2) floor and minimum-tracking rate.
        max_rows: stop after this many data rows (for quick looks).

    Raises:
        DatasetError: naming file and line for a missing file, a wrong header, a channel
            count that does not match the grid, or a value that is not a number.
    """
    path = Path(path)
    if values not in ('raw', 'activation'):
        raise ValueError(f"values must be 'raw' or 'activation'; got {values!r}")
    if not rate_hz > 0:
        raise ValueError(f'rate_hz must be > 0; got {rate_hz!r}')
    gain = 1.0 / 1023.0 if gain is None else gain
    n_ch = grid[0] * grid[1]
    try:
        handle = path.open(newline='', encoding='utf-8')
    except OSError as err:
        raise DatasetError(f'cannot open CSV: {err}', str(path)) from err
    sessions: list[Session] = []
    with handle:
        reader = csv.reader(handle)
        header = [h.strip().lower() for h in next(reader, [])]
        if tuple(header[:4]) != _HEADER:
            raise DatasetError(f'expected the CoST header "subject,variant,gesture,frame,ch1..chN"; got '
                               f'{",".join(header[:6]) or "an empty file"}', str(path), 1)
        if len(header) - 4 != n_ch:
            raise DatasetError(f'{len(header) - 4} channel columns, but --grid {grid[0]}x{grid[1]} needs {n_ch}; '
                               'give the grid the recording was made with', str(path), 1)
        key, rows, start_line, last_frame = None, [], 2, None

        def flush() -> None:
            if rows:
                frames = np.array(rows, dtype=np.float64).reshape(len(rows), *grid)
                acts = activation_from_raw(frames, gain, k, tau) if values == 'raw' else frames.astype(np.float32)
                sessions.append(Session(subject=key[0], gesture=key[2], activations=acts, rate_hz=rate_hz,
                                        source=f'{path}:{start_line}'))

        for line_no, row in enumerate(reader, start=2):
            if max_rows is not None and line_no - 1 > max_rows:
                break
            if not row or all(not c.strip() for c in row):
                continue
            if len(row) != n_ch + 4:
                raise DatasetError(f'{len(row)} fields; the header has {n_ch + 4}', str(path), line_no)
            try:
                frame_no = int(float(row[3]))
                cells = [float(c) if c.strip() else math.nan for c in row[4:]]
            except ValueError as err:
                raise DatasetError(f'frame and channel values must be numbers: {err}', str(path), line_no) from None
            row_key = (row[0].strip(), row[1].strip(), row[2].strip())
            if not row_key[0] or not row_key[2]:
                raise DatasetError('subject and gesture must not be empty', str(path), line_no)
            if row_key != key or (last_frame is not None and frame_no <= last_frame):
                flush()
                key, rows, start_line = row_key, [], line_no
            rows.append(cells)
            last_frame = frame_no
        flush()
    if not sessions:
        raise DatasetError('no data rows after the header', str(path))
    return sessions


def read_bag_manifest(path: str | Path, grid: tuple[int, int] = (16, 16)) -> list[Session]:
    """Read the sessions a YAML manifest lists from rosbag2 recordings of PatchFrame messages.

    Raises:
        ConfigError: naming the manifest line for unknown keys, a missing bag, a bag without
            the topic, or a topic of another message type.
    """
    doc = load_yaml(path)
    check_keys(doc, required=('sessions',), optional=('topic',), what='bag manifest')
    topic = typed(doc, 'topic', str, 'bag manifest', '/patch/frame')
    items = doc['sessions']
    if not isinstance(items, list) or not items:
        raise doc.error("'sessions' must be a non-empty list of {bag, subject, gesture}", 'sessions')
    base = Path(path).parent
    sessions = []
    for i, item in enumerate(items):
        what = f'session {i + 1} of the bag manifest'
        if not isinstance(item, dict):
            raise items.error(f'{what} must be a mapping with bag, subject, gesture', i)
        check_keys(item, required=('bag', 'subject', 'gesture'), optional=('events',), what=what)
        bag = base / typed(item, 'bag', str, what)
        events = None
        if 'events' in item:
            events = []
            for pair in item['events']:
                if not (isinstance(pair, list) and len(pair) == 2 and all(isinstance(v, (int, float)) for v in pair)
                        and pair[0] < pair[1]):
                    raise item.error(f'events must be [onset_s, offset_s] pairs with onset < offset; got {pair!r}',
                                     'events')
                events.append((float(pair[0]), float(pair[1])))
        acts, rate, skipped = _read_bag(bag, topic, grid, item)
        source = f'{bag} ({skipped} undecodable messages skipped)' if skipped else str(bag)
        sessions.append(Session(subject=str(typed(item, 'subject', (str, int), what)),
                                gesture=typed(item, 'gesture', str, what), activations=acts, rate_hz=rate,
                                events=events, source=source))
    return sessions


def _read_bag(bag: Path, topic: str, grid: tuple[int, int], item) -> tuple[np.ndarray, float, int]:
    if not bag.exists():
        raise item.error(f'bag {bag} not found', 'bag')
    try:
        reader = Reader(bag)
        reader.open()
    except Exception as err:  # rosbags raises several kinds for a damaged bag
        raise item.error(f'cannot open bag {bag}: {err}', 'bag') from err
    try:
        conns = [c for c in reader.connections if c.topic == topic]
        if not conns:
            topics = sorted({c.topic for c in reader.connections})
            raise item.error(f'bag {bag} has no topic {topic}; it has {", ".join(topics) or "none"}', 'bag')
        frames, stamps = [], []
        skipped = 0
        for conn, _ts, raw in reader.messages(connections=conns):
            if not conn.msgtype.endswith('/PatchFrame'):
                raise item.error(f'{topic} in {bag} carries {conn.msgtype}; expected social_touch_msgs/msg/PatchFrame',
                                 'bag')
            try:
                msg = deserialize(raw, conn.msgtype)
            except MessageError:
                skipped += 1  # a damaged message is counted and skipped
                continue
            act = np.asarray(msg.activation, dtype=np.float32)
            if act.size != grid[0] * grid[1]:
                raise item.error(f'PatchFrame with {act.size} cells; expected {grid[0]}x{grid[1]}', 'bag')
            frames.append(act.reshape(grid))
            stamps.append(msg.header.stamp.sec + msg.header.stamp.nanosec * 1e-9)
    finally:
        reader.close()
    if len(frames) < 2:
        raise item.error(f'bag {bag} has {len(frames)} readable frames on {topic}; need at least 2', 'bag')
    steps = np.diff(np.array(stamps))
    steps = steps[steps > 0]
    rate = 1.0 / float(np.median(steps)) if len(steps) else 20.0
    return np.stack(frames), rate, skipped


def render_session(scene: Any, subject: str, gesture: str, seed: int = 0) -> Session:
    """A labelled :class:`Session` (SYNTHETIC) of a simulated ``scene`` as the robot's graph renders it
    (virtual patch -> ``patch_driver``, :func:`touch_sim.patch.render.render_scene`), with its
    ground-truth events."""
    out = render_scene(scene, seed=seed)
    events = [(e.onset_s, e.offset_s) for e in scene.events]
    return Session(subject=subject, gesture=gesture, activations=out.activations, rate_hz=FRAME_RATE_HZ,
                   events=events, source='simulated (virtual patch, patch_driver node)', synthetic=True,
                   panels=out.panel_contact)
