"""Read a rosbag2 for replay (rosbags' Reader: MCAP or SQLite3): topics, definition checks, messages in time order."""

from __future__ import annotations

import math
import os
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Reader, ReaderError

from ..errors import BagError, ConfigError
from ..yamlconf import YamlBoundsError, check_bounds, did_you_mean, read_text
from .definitions import DefinitionCheck, check_definition

__all__ = ['BagPlayer', 'BagTopic', 'bag_info', 'open_reader']


@dataclass
class BagTopic:
    """A topic of a bag."""

    name: str
    type_name: str
    count: int
    qos: list[Any] = field(default_factory=list)  # rosbags Qos of the recorded publishers
    check: DefinitionCheck | None = None
    connections: list[Any] = field(default_factory=list)

    @property
    def depth(self) -> int:
        """A queue depth for republishing: the recorded one, at least 10."""
        return max([10, *(int(q.depth) for q in self.qos if int(q.depth) > 0)])


def open_reader(path: str | os.PathLike) -> Reader:
    """An open rosbags Reader, or a BagError that says what to do."""
    path = Path(path)
    if not path.exists():
        raise BagError(f'bag {path} does not exist')
    metadata = path / 'metadata.yaml'
    if metadata.is_file():
        try:  # bounded before rosbags parses it: a few bytes of aliases must not expand in its reader
            check_bounds(read_text(metadata), str(metadata))
        except YamlBoundsError as err:
            raise BagError(f'cannot read bag {path}: {err}') from err
        except ConfigError:
            pass  # rosbags reports a syntax error in its own words below
    try:
        reader = Reader(path)
        reader.open()
    except FileNotFoundError as err:
        if path.is_dir() and any(path.glob('*.mcap')):
            raise BagError(f'cannot read bag {path}: it has an MCAP file but no metadata.yaml (was its recorder '
                           f'killed?); run social-touch bag reindex {path}') from err
        raise BagError(f'cannot read bag {path}: {err}') from err
    except (ReaderError, OSError, KeyError, ValueError) as err:
        hint = f' (if its recorder was killed, social-touch bag reindex {path} rebuilds it)' \
            if path.is_dir() and any(path.glob('*.mcap')) else ''
        raise BagError(f'cannot read bag {path}: {err}{hint}') from err
    return reader


def bag_info(path: str | os.PathLike) -> dict[str, Any]:
    """What ``social-touch bag info`` prints: files, size, duration, start/end (ns), topics with counts."""
    path = Path(path)
    reader = open_reader(path)
    try:
        files = sorted(p for p in path.iterdir() if p.suffix in ('.mcap', '.db3')) if path.is_dir() else [path]
        topics = [{'name': name, 'type': info.msgtype or '?', 'count': info.msgcount,
                   'format': info.connections[0].ext.serialization_format if info.connections else '?'}
                  for name, info in sorted(reader.topics.items())]
        count = reader.message_count
        return {'path': str(path), 'files': [p.name for p in files], 'size': sum(p.stat().st_size for p in files),
                'storage': 'mcap' if any(p.suffix == '.mcap' for p in files) else 'sqlite3',
                'messages': count, 'start_ns': reader.start_time if count else None,
                'end_ns': reader.end_time - 1 if count else None, 'duration_ns': max(0, reader.duration - 1),
                'topics': topics}
    finally:
        reader.close()


class BagPlayer:
    """A bag opened for replay.

    Args:
        path: the bag (directory, or a single ``.mcap``/``.db3`` file).
        topics: topics to play (None: all).
        rate: replay speed factor (2.0: twice as fast); must be > 0 and finite.
        start_offset_s: skip the first seconds of the bag.
        check_definitions: refuse topics whose recorded definition differs from ours.

    Raises (from :meth:`open`):
        BagError: unreadable bag, unknown topic, or a definition that differs from ours.
    """

    def __init__(self, path: str | os.PathLike, *, topics: list[str] | None = None, rate: float = 1.0,
                 start_offset_s: float = 0.0, check_definitions: bool = True) -> None:
        if not (rate > 0 and math.isfinite(rate)):
            raise ValueError(f'rate must be > 0 and finite, got {rate} (for no waiting use fast mode)')
        if not start_offset_s >= 0:
            raise ValueError(f'start offset must be >= 0 s, got {start_offset_s}')
        self.path = Path(path)
        self.wanted = list(topics) if topics else None
        self.rate = rate
        self.start_offset_ns = round(start_offset_s * 1e9)
        self.check_definitions = check_definitions
        self.topics: dict[str, BagTopic] = {}
        self.start_ns = 0
        self.end_ns = 0
        self._reader: Reader | None = None

    def open(self) -> BagPlayer:
        reader = open_reader(self.path)
        try:
            self._load(reader)
        except BaseException:
            reader.close()
            raise
        self._reader = reader
        return self

    def _load(self, reader: Reader) -> None:
        available: dict[str, BagTopic] = {}
        for conn in reader.connections:
            topic = available.get(conn.topic)
            if topic is None:
                topic = available[conn.topic] = BagTopic(conn.topic, conn.msgtype, 0)
            elif topic.type_name != conn.msgtype:
                raise BagError(f"bag {self.path}: topic '{conn.topic}' has two types, {topic.type_name} and "
                               f'{conn.msgtype}; play one of them with its own --topics run is not possible')
            topic.count += conn.msgcount
            topic.qos += list(getattr(conn.ext, 'offered_qos_profiles', []) or [])
            topic.connections.append(conn)
        if self.wanted is not None:
            for name in self.wanted:
                if name not in available:
                    raise BagError(f"bag {self.path} has no topic '{name}'{did_you_mean(name, list(available))}; "
                                   f'its topics: {", ".join(sorted(available)) or "none"}')
            available = {n: available[n] for n in self.wanted}
        problems = []
        for topic in available.values():
            conn = topic.connections[0]
            topic.check = check_definition(topic.name, topic.type_name, conn.msgdef.data or '', conn.digest or '')
            if not topic.check.ok:
                problems += [f"  {topic.name}: {d}" for d in topic.check.differences]
        if problems and self.check_definitions:
            raise BagError(f'bag {self.path} was recorded with message definitions that differ from ours:\n'
                           + '\n'.join(problems) + '\nleave those topics out with --topics, or replay with the '
                           'version of the .msg files it was recorded with')
        self.topics = available
        count = reader.message_count
        self.start_ns = reader.start_time if count else 0
        self.end_ns = reader.end_time - 1 if count else 0

    def close(self) -> None:
        reader, self._reader = self._reader, None
        if reader is not None:
            reader.close()

    def __enter__(self) -> BagPlayer:
        return self.open() if self._reader is None else self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def first_ns(self) -> int:
        """Recorded time that maps to the start of replay (bag start + start offset)."""
        return self.start_ns + self.start_offset_ns

    def messages(self) -> Iterator[tuple[BagTopic, int, bytes]]:
        """``(topic, recorded stamp ns, CDR bytes)`` in time order, from the start offset on.

        Raises:
            BagError: the bag's data turns out unreadable part way.
        """
        if self._reader is None:
            raise BagError('open() the player first')
        by_conn = {id(c): t for t in self.topics.values() for c in t.connections}
        conns = [c for t in self.topics.values() for c in t.connections]
        if not conns:
            return
        try:
            for conn, stamp, data in self._reader.messages(connections=conns, start=self.first_ns):
                yield by_conn[id(conn)], stamp, bytes(data)
        except ReaderError as err:
            raise BagError(f'bag {self.path} is unreadable past some point: {err}') from err

    def play_time(self, stamp_ns: int, origin_ns: int) -> int:
        """ROS time (ns) at which to publish a message recorded at ``stamp_ns``, replay started at ``origin_ns``.

        >>> p = BagPlayer('x', rate=2.0); p.start_ns = 1_000
        >>> p.play_time(3_000, origin_ns=10_000)
        11000
        """
        return origin_ns + round((stamp_ns - self.first_ns) / self.rate)
