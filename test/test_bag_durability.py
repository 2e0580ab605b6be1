"""A recorder that dies keeps what it flushed: periodic chunk flushes, reindex of torn MCAP files, SIGKILL."""

import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from rosbags.rosbag2 import Reader, ReaderError

from touch_graph.bag import BagRecorder, reindex
from touch_graph.bag.reindex import scan_mcap
from touch_graph.errors import BagError
from touch_graph.messages import deserialize, get_message, serialize

String = get_message('std_msgs/msg/String')
REPO = Path(__file__).resolve().parent.parent


def write_messages(rec, start, stop, topic='/chatter'):
    for i in range(start, stop):
        rec.write(topic, 'std_msgs/msg/String', 1_000_000 * (i + 1), serialize(String(data=f'm{i}')))


def crash_copy(bag, dest):
    """What a SIGKILL leaves: the bag directory as it is on disk now, no metadata.yaml."""
    shutil.copytree(bag, dest)
    (dest / 'metadata.yaml').unlink(missing_ok=True)
    return dest


def read_all(bag):
    with Reader(bag) as reader:
        return [(c.topic, t, deserialize(d, c.msgtype).data) for c, t, d in reader.messages()]


def flushed(mcap):
    """Messages of an MCAP file being written that are on disk (0 before its header is)."""
    try:
        return scan_mcap(mcap).message_count
    except (BagError, FileNotFoundError):
        return 0


def wait_until(predicate, timeout_s=20.0, what='condition'):
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError(f'timed out waiting for {what}')


def test_flush_puts_the_pending_chunk_on_disk(tmp_path):
    rec = BagRecorder(tmp_path / 'bag', flush_period_s=None).open()
    write_messages(rec, 0, 20)
    assert scan_mcap(tmp_path / 'bag' / 'bag.mcap').message_count == 0  # still in the writer's memory
    assert rec.flush()
    assert not rec.flush()  # nothing new: no empty chunk, no fsync
    write_messages(rec, 20, 25)
    copy = crash_copy(tmp_path / 'bag', tmp_path / 'crash')
    report = reindex(copy)
    assert report.message_count == 20 and report.topics == {'/chatter': 20}
    assert [m for _, _, m in read_all(copy)] == [f'm{i}' for i in range(20)]
    rec.close()
    assert [m for _, _, m in read_all(tmp_path / 'bag')] == [f'm{i}' for i in range(25)]


def test_background_thread_flushes_within_the_period(tmp_path):
    rec = BagRecorder(tmp_path / 'bag', flush_period_s=0.05).open()
    write_messages(rec, 0, 7)
    wait_until(lambda: scan_mcap(tmp_path / 'bag' / 'bag.mcap').message_count == 7, what='a flush')
    rec.close()
    assert rec.flushes >= 2


def test_reindex_regenerates_message_indexes_cut_off_after_the_last_chunk(tmp_path):
    rec = BagRecorder(tmp_path / 'bag', flush_period_s=None).open()
    write_messages(rec, 0, 10)
    rec.flush()
    write_messages(rec, 10, 15, topic='/other')
    write_messages(rec, 15, 18)
    rec.flush()
    copy = crash_copy(tmp_path / 'bag', tmp_path / 'crash')
    rec.close()
    path = copy / 'bag.mcap'
    scan = scan_mcap(path)
    last = scan.chunks[-1]
    cut = last.offset + last.length + 5  # inside the first index record after the last chunk
    with path.open('r+b') as f:
        f.truncate(cut)
    report = reindex(copy)
    assert report.message_count == 18 and report.topics == {'/chatter': 13, '/other': 5}
    with Reader(copy) as reader:  # counts come from the regenerated chunk indexes
        assert {c.topic: c.msgcount for c in reader.connections} == {'/chatter': 13, '/other': 5}
    assert [m for _, _, m in read_all(copy)] == [f'm{i}' for i in range(18)]
    again = reindex(copy)  # a second run leaves a readable bag alone
    assert again.repaired == [] and again.message_count == 18


@settings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(cut_fraction=st.floats(0.0, 1.0))
def test_any_truncation_recovers_a_prefix_of_the_messages(tmp_path_factory, cut_fraction):
    """Property: wherever a crash cuts the file, reindex gives back the messages of the complete chunks."""
    tmp = tmp_path_factory.mktemp('cut')
    rec = BagRecorder(tmp / 'bag', flush_period_s=None).open()
    for block in range(4):
        write_messages(rec, 10 * block, 10 * block + 10)
        rec.flush()
    copy = crash_copy(tmp / 'bag', tmp / 'crash')
    rec.close()
    path = copy / 'bag.mcap'
    size = path.stat().st_size
    cut = int(size * cut_fraction)
    with path.open('r+b') as f:
        f.truncate(cut)
    header_end = 8 + 9 + scan_header_length(tmp / 'bag' / 'bag.mcap')
    if cut < header_end:
        with pytest.raises(BagError):
            reindex(copy)
        return
    report = reindex(copy)
    messages = [m for _, _, m in read_all(copy)]
    assert messages == [f'm{i}' for i in range(len(messages))]
    assert len(messages) == report.message_count and len(messages) % 10 == 0
    complete_chunks = sum(1 for c in scan_mcap(tmp / 'bag' / 'bag.mcap').chunks if c.offset + c.length <= cut)
    assert len(messages) == 10 * complete_chunks


def scan_header_length(path):
    data = path.read_bytes()
    return int.from_bytes(data[9:17], 'little')


def test_reindex_errors(tmp_path):
    with pytest.raises(BagError, match='not a bag directory'):
        reindex(tmp_path / 'missing')
    (tmp_path / 'empty').mkdir()
    with pytest.raises(BagError, match=r'no \.mcap file'):
        reindex(tmp_path / 'empty')
    (tmp_path / 'junk').mkdir()
    (tmp_path / 'junk' / 'junk.mcap').write_bytes(b'garbage, not an mcap file')
    with pytest.raises(BagError, match='not an MCAP file'):
        reindex(tmp_path / 'junk')


RECORDING_SCENE = textwrap.dedent('''
    import sys
    from touch_graph.bag.recorder_node import RecorderNode
    from touch_graph.messages import get_message
    from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
    String = get_message('std_msgs/msg/String')
    ctx = Context('wall'); ctx.init()
    talker = Node('talker', context=ctx)
    pub = talker.create_publisher(String, '/chatter', 10)
    count = [0]
    def tick():
        pub.publish(String(data=f'm{count[0]}')); count[0] += 1
    talker.create_timer(0.005, tick)
    recorder = RecorderNode(context=ctx, parameter_overrides=[Parameter('output', value=sys.argv[1]),
                                                              Parameter('topics', value=['/chatter']),
                                                              Parameter('flush_period', value=0.2)])
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(talker); executor.add_node(recorder)
    executor.spin()
''')


def test_sigkill_of_a_recording_process_loses_at_most_the_last_flush_period(tmp_path):
    script = tmp_path / 'scene.py'
    script.write_text(RECORDING_SCENE)
    bag = tmp_path / 'killed'
    proc = subprocess.Popen([sys.executable, str(script), str(bag)], cwd=REPO,
                            stderr=subprocess.DEVNULL)
    try:
        mcap = bag / 'killed.mcap'
        wait_until(lambda: flushed(mcap) >= 40, what='two flushes on disk')
    finally:
        proc.send_signal(signal.SIGKILL)
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    assert not (bag / 'metadata.yaml').exists()
    with pytest.raises(BagError, match='bag reindex'):
        from touch_graph.bag import bag_info
        bag_info(bag)
    report = reindex(bag)
    messages = [m for _, _, m in read_all(bag)]
    assert len(messages) == report.message_count >= 40
    assert messages == [f'm{i}' for i in range(len(messages))]  # a gapless prefix of what was published


def _chunks(path):
    """(offset of the chunk's records, their length, CRC) of every chunk record of an MCAP file."""
    from mcap.records import Chunk
    from mcap.stream_reader import StreamReader
    out = []
    with path.open('rb') as f:
        reader = StreamReader(f, emit_chunks=True)
        for record in reader.records:
            if isinstance(record, Chunk):
                # The chunk's records are its last bytes before the message indexes follow.
                out.append((f.tell() - len(record.data), len(record.data), record.uncompressed_crc, record.data))
    return out


def three_chunk_bag(bag):
    """A closed bag of 30 messages in three chunks of ten."""
    rec = BagRecorder(bag, flush_period_s=None).open()
    for block in range(3):
        write_messages(rec, 10 * block, 10 * block + 10)
        rec.flush()
    rec.close()


def test_every_chunk_is_written_with_the_crc_of_its_records(tmp_path):
    import zlib
    three_chunk_bag(tmp_path / 'bag')
    chunks = _chunks(tmp_path / 'bag' / 'bag.mcap')
    assert len(chunks) == 3
    for _, _, crc, data in chunks:
        assert crc != 0 and crc == zlib.crc32(data)


def test_a_corrupted_chunk_is_detected_by_reading_and_dropped_by_reindex(tmp_path):
    from touch_graph.bag import BagPlayer
    three_chunk_bag(tmp_path / 'bag')
    path = tmp_path / 'bag' / 'bag.mcap'
    offset, length, _, _ = _chunks(path)[1]
    data = bytearray(path.read_bytes())
    data[offset + length - 3] ^= 0x40          # one bit of a message of the middle chunk, framing intact
    path.write_bytes(bytes(data))
    # Reading: the CRC catches it, where a reader without it would hand over a wrong message.
    with pytest.raises(ReaderError, match=r'(?i)checksum'):
        read_all(tmp_path / 'bag')
    with pytest.raises(BagError, match='unreadable'), BagPlayer(tmp_path / 'bag') as player:
        list(player.messages())
    # Reindex: finds it, keeps the other chunks, and leaves a bag every reader opens.
    scan = scan_mcap(path)
    assert scan.corrupt_chunks == 1 and scan.message_count == 20 and 'corrupt chunk' in scan.stop_reason
    report = reindex(tmp_path / 'bag')
    assert report.repaired == ['bag.mcap'] and report.corrupt_chunks == 1 and report.message_count == 20
    assert [m for _, _, m in read_all(tmp_path / 'bag')] == [f'm{i}' for i in (*range(10), *range(20, 30))]
    again = reindex(tmp_path / 'bag')
    assert again.repaired == [] and again.corrupt_chunks == 0 and again.message_count == 20


@pytest.mark.parametrize('name', ['touch_graph.bag.metadata', 'touch_graph.bag.definitions', 'touch_graph.bag.player'])
def test_bag_doctests(name):
    import doctest
    import importlib
    result = doctest.testmod(importlib.import_module(name))
    assert result.failed == 0 and result.attempted > 0
