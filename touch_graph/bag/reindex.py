"""Rebuild a readable rosbag2 from an MCAP file whose writer died (``social-touch bag reindex BAG``).

A recorder killed with SIGKILL leaves an MCAP file with its header, the chunks it flushed
(each followed by its message index records), perhaps a torn last record, and no
summary, footer or ``metadata.yaml``. :func:`reindex` scans the file record by record,
keeps every complete chunk (checking that its records parse), cuts the file after the
last complete one, regenerates that chunk's message indexes if they were cut, appends a
summary section (schemas, channels, chunk indexes, statistics, summary offsets, footer)
as the MCAP specification describes, and writes ``metadata.yaml``. A complete bag is
left as it is and only gets its ``metadata.yaml`` regenerated. Running it twice is safe.

MCAP records are ``u8 opcode | u64 length | body``, little endian; strings are
``u32 length | UTF-8``; maps are ``u32 byte length | entries``.
"""

from __future__ import annotations

import os
import struct
from dataclasses import dataclass, field
from pathlib import Path
from typing import BinaryIO

import yaml

from ..errors import BagError

__all__ = ['McapScan', 'ReindexReport', 'reindex', 'scan_mcap']

MAGIC = b'\x89MCAP0\r\n'
OP_HEADER, OP_FOOTER, OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_MESSAGE_INDEX = 0x01, 0x02, 0x03, 0x04, 0x05, \
    0x06, 0x07
OP_CHUNK_INDEX, OP_STATISTICS, OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET, OP_DATA_END = 0x08, 0x0B, 0x0C, \
    0x0D, 0x0E, 0x0F
#: Records after which the data section is over (what a clean close writes).
_END_OF_DATA = {OP_FOOTER, OP_CHUNK_INDEX, OP_STATISTICS, OP_METADATA, OP_METADATA_INDEX, OP_SUMMARY_OFFSET,
                OP_DATA_END}
_U16, _U32, _U64 = struct.Struct('<H'), struct.Struct('<I'), struct.Struct('<Q')
_NO_MESSAGES = 2**63 - 1


class _Body:
    """A cursor over a record body; every read is bounds-checked (a torn record raises ValueError)."""

    def __init__(self, data: bytes) -> None:
        self.data, self.pos = data, 0

    def take(self, n: int) -> bytes:
        if n < 0 or self.pos + n > len(self.data):
            raise ValueError(f'record too short: need {n} bytes at {self.pos} of {len(self.data)}')
        out = self.data[self.pos:self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return _U16.unpack(self.take(2))[0]

    def u32(self) -> int:
        return _U32.unpack(self.take(4))[0]

    def u64(self) -> int:
        return _U64.unpack(self.take(8))[0]

    def string(self) -> str:
        return self.take(self.u32()).decode()

    def str_map(self) -> dict[str, str]:
        sub = _Body(self.take(self.u32()))
        out = {}
        while sub.pos < len(sub.data):
            key = sub.string()
            out[key] = sub.string()
        return out


@dataclass
class _Chunk:
    start_time: int
    end_time: int
    offset: int
    length: int
    compression: str
    compressed_size: int
    uncompressed_size: int
    messages: dict[int, list[tuple[int, int]]]  # channel -> [(log_time, offset in chunk)]
    index_offsets: dict[int, int] = field(default_factory=dict)
    index_end: int = 0


@dataclass
class McapScan:
    """What a scan of one MCAP file found."""

    path: Path
    size: int
    complete: bool = False
    schemas: dict[int, tuple[str, str, bytes]] = field(default_factory=dict)  # id -> (name, encoding, data)
    channels: dict[int, tuple[int, str, str, dict[str, str]]] = field(default_factory=dict)
    chunks: list[_Chunk] = field(default_factory=list)
    counts: dict[int, int] = field(default_factory=dict)
    start_time: int = _NO_MESSAGES
    end_time: int = 0
    keep_end: int = 0  # bytes of the file worth keeping
    stop_reason: str = ''

    @property
    def message_count(self) -> int:
        return sum(self.counts.values())

    def _count(self, channel: int, log_time: int) -> None:
        self.counts[channel] = self.counts.get(channel, 0) + 1
        self.start_time = min(self.start_time, log_time)
        self.end_time = max(self.end_time, log_time)


def _read_schema_channel(op: int, body: _Body, scan: McapScan) -> None:
    if op == OP_SCHEMA:
        sid = body.u16()
        scan.schemas[sid] = (body.string(), body.string(), body.take(body.u32()))
    else:
        cid, sid = body.u16(), body.u16()
        scan.channels[cid] = (sid, body.string(), body.string(), body.str_map())


def _parse_chunk(body: _Body, offset: int, length: int, scan: McapScan) -> _Chunk:
    from rosbags.rosbag2.storage_mcap import decompress  # lz4/zstd, as the reader does
    start, end, usize, crc = body.u64(), body.u64(), body.u64(), body.u32()
    compression = body.string()
    csize = body.u64()
    records = decompress(body.take(csize), compression, usize, crc)
    inner = _Body(records)
    chunk = _Chunk(start, end, offset, length, compression, csize, usize, {})
    found: list[tuple[int, int]] = []
    while inner.pos < len(records):
        rec_offset = inner.pos
        op, rec = inner.take(1)[0], _Body(inner.take(inner.u64()))
        if op in (OP_SCHEMA, OP_CHANNEL):
            _read_schema_channel(op, rec, scan)
        elif op == OP_MESSAGE:
            channel, _seq, log_time = rec.u16(), rec.u32(), rec.u64()
            chunk.messages.setdefault(channel, []).append((log_time, rec_offset))
            found.append((channel, log_time))
    for channel, log_time in found:  # counted only once the whole chunk parsed
        scan._count(channel, log_time)
    return chunk


def scan_mcap(path: Path) -> McapScan:
    """Scan an MCAP file's data section; never raises on a torn file (only on a non-MCAP file).

    Raises:
        BagError: the file does not start with the MCAP magic and a header record.
    """
    size = path.stat().st_size
    scan = McapScan(path, size)
    with path.open('rb') as f:
        if f.read(8) != MAGIC:
            raise BagError(f'{path} is not an MCAP file (bad magic); nothing to reindex')
        head = f.read(9)
        if len(head) < 9 or head[0] != OP_HEADER:
            raise BagError(f'{path} has no MCAP header record; nothing can be recovered')
        f.seek(_U64.unpack(head[1:])[0], os.SEEK_CUR)
        pos = scan.keep_end = f.tell()
        if pos > size:
            raise BagError(f'{path} ends inside its MCAP header; nothing can be recovered')
        last: _Chunk | None = None
        while True:
            head = f.read(9)
            if len(head) < 9:
                scan.stop_reason = 'end of file' if not head else f'torn record header at byte {pos}'
                break
            op, length = head[0], _U64.unpack(head[1:])[0]
            if op in _END_OF_DATA:
                scan.stop_reason = 'end of data section'
                break
            if pos + 9 + length > size:
                scan.stop_reason = f'torn record (opcode 0x{op:02x}) at byte {pos}'
                break
            body = _Body(f.read(length))
            end = pos + 9 + length
            try:
                if op == OP_CHUNK:
                    last = _parse_chunk(body, pos, 9 + length, scan)
                    scan.chunks.append(last)
                    last.index_end = end
                    scan.keep_end = end
                elif op == OP_MESSAGE_INDEX and last is not None and last.index_end == pos:
                    channel = body.u16()
                    last.index_offsets[channel] = pos
                    last.index_end = end
                    if set(last.index_offsets) == set(last.messages):
                        scan.keep_end = end  # the chunk's indexes are all there
                elif op in (OP_SCHEMA, OP_CHANNEL):
                    _read_schema_channel(op, body, scan)
                    scan.keep_end = end
                elif op == OP_MESSAGE:
                    channel, _seq, log_time = body.u16(), body.u32(), body.u64()
                    scan._count(channel, log_time)
                    scan.keep_end = end
                else:
                    scan.keep_end = end
            except Exception as err:  # a corrupt record (bad lengths, bad compression) ends the data
                scan.stop_reason = f'unreadable record (opcode 0x{op:02x}) at byte {pos}: {err}'
                break
            pos = end
    if scan.chunks and scan.chunks[-1].index_end > scan.keep_end:
        scan.chunks[-1].index_offsets = {}  # its indexes were cut: regenerate them
    return scan


def _record(op: int, body: bytes) -> bytes:
    return bytes([op]) + _U64.pack(len(body)) + body


def _string(text: str) -> bytes:
    data = text.encode()
    return _U32.pack(len(data)) + data


def _str_map(entries: dict[str, str]) -> bytes:
    data = b''.join(_string(k) + _string(v) for k, v in entries.items())
    return _U32.pack(len(data)) + data


def _write_summary(f: BinaryIO, scan: McapScan, metadata_text: str) -> None:
    """Append indexes, metadata, data end, summary and footer at the current position."""
    for chunk in scan.chunks:
        if chunk.index_offsets or not chunk.messages:
            continue
        for channel, entries in chunk.messages.items():
            chunk.index_offsets[channel] = f.tell()
            pairs = b''.join(_U64.pack(t) + _U64.pack(o) for t, o in entries)
            f.write(_record(OP_MESSAGE_INDEX, _U16.pack(channel) + _U32.pack(len(pairs)) + pairs))
        chunk.index_end = f.tell()
    metadata_start = f.tell()
    f.write(_record(OP_METADATA, _string('rosbag2') + _str_map({'serialized_metadata': metadata_text})))
    metadata_end = f.tell()
    f.write(_record(OP_DATA_END, _U32.pack(0)))

    groups: list[tuple[int, int, int]] = []
    summary_start = f.tell()
    for op, items in ((OP_SCHEMA, [
            _U16.pack(sid) + _string(name) + _string(enc) + _U32.pack(len(data)) + data
            for sid, (name, enc, data) in sorted(scan.schemas.items())]), (OP_CHANNEL, [
            _U16.pack(cid) + _U16.pack(sid) + _string(topic) + _string(enc) + _str_map(meta)
            for cid, (sid, topic, enc, meta) in sorted(scan.channels.items())]), (OP_CHUNK_INDEX, [
            _U64.pack(c.start_time) + _U64.pack(c.end_time) + _U64.pack(c.offset) + _U64.pack(c.length)
            + _U32.pack(10 * len(c.index_offsets))
            + b''.join(_U16.pack(k) + _U64.pack(v) for k, v in sorted(c.index_offsets.items()))
            + _U64.pack(c.index_end - c.offset - c.length) + _string(c.compression) + _U64.pack(c.compressed_size)
            + _U64.pack(c.uncompressed_size) for c in scan.chunks]), (OP_METADATA_INDEX, [
            _U64.pack(metadata_start) + _U64.pack(metadata_end - metadata_start) + _string('rosbag2')])):
        if items:
            start = f.tell()
            for body in items:
                f.write(_record(op, body))
            groups.append((op, start, f.tell() - start))
    counts = b''.join(_U16.pack(cid) + _U64.pack(n) for cid, n in sorted(scan.counts.items()))
    start = f.tell()
    f.write(_record(OP_STATISTICS, _U64.pack(scan.message_count) + _U16.pack(len(scan.schemas))
                    + _U32.pack(len(scan.channels)) + _U32.pack(0) + _U32.pack(1) + _U32.pack(len(scan.chunks))
                    + _U64.pack(scan.start_time if scan.message_count else 0) + _U64.pack(scan.end_time)
                    + _U32.pack(len(counts)) + counts))
    groups.append((OP_STATISTICS, start, f.tell() - start))
    offsets_start = f.tell()
    for op, start, length in groups:
        f.write(_record(OP_SUMMARY_OFFSET, bytes([op]) + _U64.pack(start) + _U64.pack(length)))
    f.write(_record(OP_FOOTER, _U64.pack(summary_start) + _U64.pack(offsets_start) + _U32.pack(0)))
    f.write(MAGIC)


def _type_hash(name: str, encoding: str, data: bytes) -> str:
    """RIHS01 hash of a schema's message definition; '' when it cannot be parsed."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    if encoding != 'ros2msg':
        return ''
    try:
        store = get_typestore(Stores.EMPTY)
        store.register(get_types_from_msg(data.decode(), name))
        return store.hash_rihs01(name)
    except Exception:  # rosbags' parser raises several kinds; a hash is optional in metadata
        return ''


def _topics_metadata(scan: McapScan) -> list[dict]:
    from rosbags.rosbag2.metadata import dump_qos_v9, parse_qos
    out = []
    for cid, (sid, topic, enc, meta) in sorted(scan.channels.items()):
        name, schema_enc, data = scan.schemas.get(sid, ('', '', b''))
        try:
            qos = dump_qos_v9(parse_qos(meta.get('offered_qos_profiles', '')))
        except Exception:  # unreadable QoS text: the topic still replays
            qos = []
        out.append({'topic_metadata': {'name': topic, 'type': name, 'serialization_format': enc,
                                       'offered_qos_profiles': qos,
                                       'type_description_hash': _type_hash(name, schema_enc, data)},
                    'message_count': scan.counts.get(cid, 0)})
    return out


@dataclass
class ReindexReport:
    """What :func:`reindex` did: files, messages recovered per topic, bytes cut off."""

    bag: Path
    files: list[str]
    repaired: list[str]
    message_count: int
    topics: dict[str, int]
    bytes_dropped: int
    stop_reasons: dict[str, str]


def reindex(bag: str | os.PathLike) -> ReindexReport:
    """Make ``bag`` (a rosbag2 directory of MCAP files) readable again; see the module docstring.

    Raises:
        BagError: no MCAP file in the directory, or a file that is not MCAP at all.
    """
    bag = Path(bag)
    if not bag.is_dir():
        raise BagError(f'{bag} is not a bag directory (expected a directory with .mcap files)')
    files = sorted(bag.glob('*.mcap'))
    if not files:
        raise BagError(f'{bag} holds no .mcap file; reindex rebuilds MCAP bags only')
    scans, repaired, dropped = [], [], 0
    for path in files:
        scan = scan_mcap(path)
        scan.complete = _opens(path)
        if not scan.complete:
            info = _bag_info(scan, [scan])
            text = yaml.safe_dump(info['rosbag2_bagfile_information'], sort_keys=False)
            dropped += scan.size - scan.keep_end
            with path.open('r+b') as f:
                f.truncate(scan.keep_end)
                f.seek(scan.keep_end)
                _write_summary(f, scan, text)
                f.flush()
                os.fsync(f.fileno())
            repaired.append(path.name)
        scans.append(scan)
    merged = _merge(scans)
    info = _bag_info(merged, scans)
    tmp = bag / 'metadata.yaml.tmp'
    tmp.write_text(yaml.safe_dump(info, sort_keys=False), encoding='utf-8')
    tmp.replace(bag / 'metadata.yaml')
    topics = {t['topic_metadata']['name']: t['message_count']
              for t in info['rosbag2_bagfile_information']['topics_with_message_count']}
    return ReindexReport(bag, [p.name for p in files], repaired, merged.message_count, topics, dropped,
                         {s.path.name: s.stop_reason for s in scans})


def _opens(path: Path) -> bool:
    from rosbags.rosbag2.storage_mcap import McapReader
    reader = McapReader(path)
    try:
        reader.open()
    except Exception:  # any reader failure means the file needs repair
        return False
    reader.close()
    return True


def _merge(scans: list[McapScan]) -> McapScan:
    """One scan over several files, channels identified by (topic, type) as the rosbag2 reader does."""
    if len(scans) == 1:
        return scans[0]
    merged = McapScan(scans[0].path, 0)
    keys: dict[tuple[str, str], int] = {}
    for scan in scans:
        for cid, (sid, topic, enc, meta) in scan.channels.items():
            name, schema_enc, data = scan.schemas.get(sid, ('', '', b''))
            key = (topic, name)
            if key not in keys:
                keys[key] = new = len(keys) + 1
                merged.schemas[new] = (name, schema_enc, data)
                merged.channels[new] = (new, topic, enc, meta)
            merged.counts[keys[key]] = merged.counts.get(keys[key], 0) + scan.counts.get(cid, 0)
        if scan.message_count:
            merged.start_time = min(merged.start_time, scan.start_time)
            merged.end_time = max(merged.end_time, scan.end_time)
    return merged


def _span(scan: McapScan) -> tuple[int, int]:
    """(start ns, duration ns) of a scan's messages; (0, 0) when it has none."""
    if not scan.message_count:
        return 0, 0
    return scan.start_time, scan.end_time - scan.start_time


def _bag_info(merged: McapScan, files: list[McapScan]) -> dict:
    """metadata.yaml content, as rosbags' Writer.close writes it (version 9)."""
    start, duration = _span(merged)
    return {'rosbag2_bagfile_information': {
        'version': 9, 'storage_identifier': 'mcap', 'relative_file_paths': [s.path.name for s in files],
        'duration': {'nanoseconds': duration}, 'starting_time': {'nanoseconds_since_epoch': start},
        'message_count': merged.message_count, 'topics_with_message_count': _topics_metadata(merged),
        'compression_format': '', 'compression_mode': '',
        'files': [{'path': s.path.name, 'starting_time': {'nanoseconds_since_epoch': _span(s)[0]},
                   'duration': {'nanoseconds': _span(s)[1]}, 'message_count': s.message_count} for s in files],
        'custom_data': {'social_touch.reindexed': 'true'}, 'ros_distro': 'rosbags'}}

