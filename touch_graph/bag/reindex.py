"""Rebuild a readable rosbag2 from MCAP files whose writer died (``social-touch bag reindex BAG``).

:func:`scan_mcap` reads a file record by record with ``mcap``'s stream reader, checking each
chunk's CRC, up to the first torn or unreadable record. :func:`reindex` writes each damaged
file again with the ``mcap`` writer from what survived (corrupt chunks dropped and counted),
giving it summary, indexes and footer, and writes ``metadata.yaml``; a complete file is left
as it is. Safe to run twice. A rewrite needs room for one more copy of the file; without it
nothing is written, and ``output`` rebuilds the bag on another disk instead.
"""

from __future__ import annotations

import errno
import os
import shutil
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mcap.exceptions import McapError
from mcap.records import Channel, Chunk, DataEnd, Footer, Header, Message, Schema
from mcap.stream_reader import StreamReader, breakup_chunk
from mcap.writer import CompressionType, Writer

from ..errors import BagError
from .metadata import FileRecord, TopicRecord, bag_metadata, serialized_metadata, type_hash, write_metadata

__all__ = ['McapScan', 'ReindexReport', 'reindex', 'scan_mcap']

MAGIC = b'\x89MCAP0\r\n'
_U64 = struct.Struct('<Q')
_NO_MESSAGES = 2**63 - 1


@dataclass
class ChunkSpan:
    """Where a whole chunk record lies in the file and what it holds."""

    offset: int
    length: int
    messages: int


@dataclass
class McapScan:
    """What a scan of one MCAP file found.

    Attributes:
        complete: the file ends with its summary, footer and magic (a clean close).
        chunks: every whole chunk record, in file order (those with a bad CRC included).
        corrupt_chunks: chunks whose records do not match their CRC (their messages are not kept).
        keep_end: bytes of the file worth keeping (the end of the last whole record of the data).
        stop_reason: why the scan stopped before the end, '' when it did not.
    """

    path: Path
    size: int
    profile: str = ''
    complete: bool = False
    schemas: dict[int, Schema] = field(default_factory=dict)
    channels: dict[int, Channel] = field(default_factory=dict)
    chunks: list[ChunkSpan] = field(default_factory=list)
    corrupt_chunks: int = 0
    counts: dict[int, int] = field(default_factory=dict)
    start_time: int = _NO_MESSAGES
    end_time: int = 0
    keep_end: int = 0
    stop_reason: str = ''

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def count(self, message: Message) -> None:
        self.counts[message.channel_id] = self.counts.get(message.channel_id, 0) + 1
        self.start_time = min(self.start_time, message.log_time)
        self.end_time = max(self.end_time, message.log_time)


def _records(path: Path, scan: McapScan, on_messages: Any = None) -> None:
    """Read ``path`` record by record into ``scan``; ``on_messages(list)`` gets each whole chunk's
    (or loose message's) messages in file order. Never raises on a torn or corrupt file past its header."""
    with path.open('rb') as f:
        if f.read(8) != MAGIC:
            raise BagError(f'{path} is not an MCAP file (bad magic); nothing to reindex')
        f.seek(0)
        records = StreamReader(f, emit_chunks=True, validate_crcs=True, record_size_limit=scan.size).records
        pos, header, summary, footer = 0, False, False, False
        while True:
            if not footer:  # a record the file ends inside of is torn: stop before it, not inside it
                at = max(pos, len(MAGIC))
                f.seek(at)
                head = f.read(9)
                f.seek(pos)
                if len(head) == 9 and at + 9 + _U64.unpack(head[1:])[0] > scan.size:
                    if not header:
                        raise BagError(f'{path} ends inside its MCAP header; nothing can be recovered')
                    scan.stop_reason = f'torn record (opcode 0x{head[0]:02x}) at byte {at}'
                    return
            try:
                record = next(records)
            except StopIteration:
                scan.complete = True
                return
            except (McapError, struct.error, ValueError, EOFError) as err:
                if not header:
                    raise BagError(f'{path} has no whole MCAP header record; nothing can be recovered') from err
                scan.stop_reason = f'end of file at byte {pos}' if pos >= scan.size else \
                    f'unreadable record at byte {pos}: {type(err).__name__} {err}'.strip()
                return
            start, pos = pos, f.tell()
            if isinstance(record, Header):
                header = True
                scan.profile = record.profile
            elif isinstance(record, DataEnd):
                summary = True
            elif isinstance(record, Footer):
                footer = True
            elif summary:
                continue     # summary records: rebuilt on a rewrite
            elif isinstance(record, Schema):
                scan.schemas[record.id] = record
            elif isinstance(record, Channel):
                scan.channels[record.id] = record
            elif isinstance(record, Chunk):
                _chunk(record, max(start, len(MAGIC)), pos, scan, on_messages)
            elif isinstance(record, Message):
                scan.count(record)
                if on_messages is not None:
                    on_messages([record])
            if not summary:
                scan.keep_end = pos


def _chunk(record: Chunk, start: int, end: int, scan: McapScan, on_messages: Any) -> None:
    try:
        inner = breakup_chunk(record, validate_crc=True)
    except (McapError, ValueError, struct.error) as err:   # CRCValidationError is a ValueError
        scan.corrupt_chunks += 1
        scan.chunks.append(ChunkSpan(start, end - start, 0))
        scan.stop_reason = scan.stop_reason or f'corrupt chunk at byte {start}: {err}'
        return
    found = []
    for item in inner:
        if isinstance(item, Schema):
            scan.schemas[item.id] = item
        elif isinstance(item, Channel):
            scan.channels[item.id] = item
        elif isinstance(item, Message):
            found.append(item)
    for message in found:            # counted only once the whole chunk parsed
        scan.count(message)
    scan.chunks.append(ChunkSpan(start, end - start, len(found)))
    if on_messages is not None:
        on_messages(found)


def scan_mcap(path: str | os.PathLike) -> McapScan:
    """Scan an MCAP file; never raises on a torn or corrupt file (only on a file that is not MCAP).

    Raises:
        BagError: the file does not start with the MCAP magic and a whole header record.
    """
    path = Path(path)
    scan = McapScan(path, path.stat().st_size)
    _records(path, scan)
    return scan


#: Room asked for beyond the files' sizes, for their summaries and metadata.yaml, bytes.
SUMMARY_ROOM = 64 * 1024


def _space_error(bag: Path, err: OSError | None, need: int, free: int) -> BagError:
    """The error of a rewrite that has no room: what is kept, what to do."""
    cause = f'{errno.errorcode.get(err.errno, "OSError")}: {err.strerror}' if err is not None else \
        f'ENOSPC: {free / 1e6:.1f} MB free, about {need / 1e6:.1f} MB needed'
    return BagError(f'cannot reindex {bag} ({cause}): reindex writes a new copy of each damaged file beside it '
                    'before replacing it. Nothing of the bag was changed: every message recorded is still in its '
                    f'.mcap file. Free some space on that disk, or rebuild the bag on another disk with: '
                    f'social-touch bag reindex {bag} -o OTHER_DIR/{bag.name}')


def _rewrite(path: Path, scan: McapScan, info: dict, dest: Path) -> None:
    """Write ``path`` again to ``dest`` from its whole, checked records, with summary and footer, atomically:
    a temporary file renamed over ``dest``, removed on failure."""
    tmp = dest.with_name(dest.name + '.reindex')
    try:
        with tmp.open('wb') as out:
            writer = Writer(out, compression=CompressionType.NONE)
            writer.start(profile=scan.profile or 'ros2', library='social_touch reindex')
            schema_ids = {sid: writer.register_schema(s.name, s.encoding, s.data) for sid, s in scan.schemas.items()}
            channel_ids = {cid: writer.register_channel(c.topic, c.message_encoding, schema_ids.get(c.schema_id, 0),
                                                        dict(c.metadata)) for cid, c in scan.channels.items()}

            def write(found: list[Message]) -> None:
                for m in found:
                    if m.channel_id in channel_ids:
                        writer.add_message(channel_ids[m.channel_id], m.log_time, m.data, m.publish_time, m.sequence)

            _records(path, McapScan(path, scan.size), write)
            writer.add_metadata('rosbag2', {'serialized_metadata': serialized_metadata(info)})
            writer.finish()
            out.flush()
            os.fsync(out.fileno())
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    tmp.replace(dest)


@dataclass
class ReindexReport:
    """What :func:`reindex` did: files, messages recovered per topic, bytes cut off, chunks dropped."""

    bag: Path
    files: list[str]
    repaired: list[str]
    message_count: int
    topics: dict[str, int]
    bytes_dropped: int
    stop_reasons: dict[str, str]
    corrupt_chunks: int = 0


def _topics(scans: list[McapScan]) -> list[TopicRecord]:
    """One record per (topic, type) over every file, as the rosbag2 reader joins channels."""
    out: dict[tuple[str, str], TopicRecord] = {}
    for scan in scans:
        for cid, channel in sorted(scan.channels.items()):
            schema = scan.schemas.get(channel.schema_id)
            name = schema.name if schema else ''
            key = (channel.topic, name)
            if key not in out:
                definition = schema.data.decode(errors='replace') if schema else ''
                out[key] = TopicRecord(channel.topic, name, channel.message_encoding,
                                       channel.metadata.get('offered_qos_profiles', ''),
                                       type_hash(name, schema.encoding if schema else '', definition))
            out[key].message_count += scan.counts.get(cid, 0)
    return list(out.values())


def _file_record(scan: McapScan) -> FileRecord:
    return FileRecord(scan.path.name, scan.start_time if scan.message_count else 0, scan.end_time, scan.message_count)


def reindex(bag: str | os.PathLike, output: str | os.PathLike | None = None) -> ReindexReport:
    """Make ``bag`` (a rosbag2 directory of MCAP files) readable again; see the module docstring.

    Args:
        bag: the bag directory.
        output: a new directory to write the rebuilt bag to (the original is then only read), e.g. on
            another disk when the bag's own is full; None: repair ``bag`` in place.

    Raises:
        BagError: no MCAP file in the directory, a file that is not MCAP at all, an ``output`` that
            exists, or no room for the rewrite (ENOSPC; nothing of the bag changed).
    """
    bag = Path(bag)
    if not bag.is_dir():
        raise BagError(f'{bag} is not a bag directory (expected a directory with .mcap files)')
    files = sorted(bag.glob('*.mcap'))
    if not files:
        raise BagError(f'{bag} holds no .mcap file; reindex rebuilds MCAP bags only')
    scans = [scan_mcap(path) for path in files]
    custom = {'social_touch.reindexed': 'true'}
    info = bag_metadata([_file_record(s) for s in scans], _topics(scans), custom)
    target = bag if output is None else Path(output)
    damaged = [s for s in scans if not (s.complete and not s.corrupt_chunks)]
    if output is not None:
        if target.exists():
            raise BagError(f'{target} exists already; give reindex -o a new directory')
        target.mkdir(parents=True)
    need = sum(s.keep_end for s in (scans if output is not None else damaged)) + SUMMARY_ROOM
    free = shutil.disk_usage(target).free
    if free < need:
        raise _space_error(bag, None, need, free)
    repaired, dropped = [], 0
    try:
        for scan in scans:
            if scan.complete and not scan.corrupt_chunks:
                if output is not None:
                    shutil.copyfile(scan.path, target / scan.path.name)
                continue
            file_info = bag_metadata([_file_record(scan)], _topics([scan]), custom)
            dropped += scan.size - scan.keep_end
            _rewrite(scan.path, scan, file_info, target / scan.path.name)
            repaired.append(scan.path.name)
        write_metadata(target, info)
    except OSError as err:
        if err.errno in (errno.ENOSPC, errno.EDQUOT):
            raise _space_error(bag, err, need, shutil.disk_usage(target).free) from err
        raise BagError(f'cannot reindex {bag}: {err}; the original files are unchanged') from err
    bag = target
    topics = {t['topic_metadata']['name']: t['message_count']
              for t in info['rosbag2_bagfile_information']['topics_with_message_count']}
    return ReindexReport(bag, [p.name for p in files], repaired, sum(s.message_count for s in scans), topics, dropped,
                         {s.path.name: s.stop_reason for s in scans}, sum(s.corrupt_chunks for s in scans))
