"""The robustness report's figures, each measured on real components (synthetic data, labelled so).

- ``flood``: bogus and lost frames per MB of fake headers (:mod:`touch_lab.bench.framing`);
- ``unplug``: a driver's recovery time after its port comes back, on a virtual device in simulated time;
- ``recorder_kill``: a recording process killed with SIGKILL, then ``reindex``: messages lost;
- ``bag_corruption``: one bit flipped in 8 places of a bag's chunks: detected by reindex, the rosbags
  reader and the mcap reader (with and without its CRC check)?
"""

from __future__ import annotations

import signal
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap.records import Chunk
from mcap.stream_reader import StreamReader
from rosbags.rosbag2 import Reader

from touch_driver.skin.node import SkinDriverNode
from touch_graph.bag import BagRecorder, reindex
from touch_graph.bag.reindex import scan_mcap
from touch_graph.messages import deserialize, get_message, serialize
from touch_graph.node_health import level_number
from touch_graph.runtime import Context, Node, Parameter, QoSProfile, ReliabilityPolicy, SingleThreadedExecutor
from touch_lab.bench.framing import FLOODS, run_flood
from touch_sim.virtual_port import forget_devices

__all__ = ['bag_corruption', 'flood', 'recorder_kill', 'unplug', 'unplug_recovery']


def flood(megabytes: float = 4.0) -> dict[str, Any]:
    """Each flood of :data:`touch_lab.bench.framing.FLOODS`, ``megabytes`` MB, seed 0."""
    return {kind: run_flood(kind, megabytes, seed=0) for kind in FLOODS}


def unplug_recovery(replug_phases: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75)) -> dict[str, Any]:
    """:func:`unplug` with the replug at several phases of the reconnect period: the recovery depends on
    where in the period the device comes back (at most ``reconnect_period_s`` plus a poll)."""
    runs = [unplug(replug_at_s=4.0 + phase) for phase in replug_phases]
    recovery = [r['recovery_s'] for r in runs]
    return {'runs': len(runs), 'recovery_s': recovery, 'max_recovery_s': max(recovery),
            'reconnect_period_s': runs[0]['reconnect_period_s'],
            'error_while_unplugged': all(r['error_while_unplugged'] for r in runs),
            'reconnects': [r['reconnects'] for r in runs], 'synthetic_data': True}


def unplug(unplug_at_s: float = 2.0, replug_at_s: float = 4.0, seconds: float = 7.0) -> dict[str, Any]:
    """A skin driver on ``skinsim://`` unplugged between the two times (device seconds), simulated time:
    from the replug to the first frame published again, frames lost, and what the status said meanwhile."""
    forget_devices()
    ctx = Context('sim')
    ctx.init()
    try:
        node = SkinDriverNode(context=ctx, namespace='skin', parameter_overrides=[Parameter(
            'port', value=f'skinsim://unplug?unplug_at={unplug_at_s}&replug_at={replug_at_s}&seed=1')])
        listener = Node('listener', context=ctx)
        stamps: list[float] = []
        levels: list[int] = []
        listener.create_subscription(get_message('SkinFrame'), '/skin/frame',
                                     lambda m: stamps.append(m.header.stamp.sec + m.header.stamp.nanosec * 1e-9),
                                     QoSProfile(depth=1000, reliability=ReliabilityPolicy.BEST_EFFORT))  # as the driver
        listener.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                                     lambda m: levels.append(level_number(m.status[0])), 100)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.add_node(listener)
        executor.spin_for(seconds)
        status = node.status()
        node.destroy_node()
    finally:
        ctx.shutdown()
        forget_devices()
    t0 = stamps[0]
    rel = [s - t0 for s in stamps]
    after = [s for s in rel if s >= replug_at_s]
    gap_start = max((s for s in rel if s < replug_at_s), default=0.0)
    return {'unplug_at_s': unplug_at_s, 'replug_at_s': replug_at_s, 'reconnect_period_s': node.reconnect_period_s,
            'recovery_s': (after[0] - replug_at_s) if after else None, 'last_frame_before_s': gap_start,
            'reconnects': status.reconnects, 'frames': status.frames,
            'error_while_unplugged': 2 in levels, 'synthetic_data': True}


RECORDING_SCENE = textwrap.dedent('''
    import sys
    from touch_graph.bag.recorder_node import RecorderNode
    from touch_graph.messages import get_message
    from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
    String = get_message('std_msgs/msg/String')
    ctx = Context('wall', network=False); ctx.init()
    talker = Node('talker', context=ctx)
    pub = talker.create_publisher(String, '/chatter', 10)
    count = [0]
    def tick():
        pub.publish(String(data=f'm{count[0]}')); count[0] += 1
        sys.stdout.write(f'{count[0]}\\n'); sys.stdout.flush()
    talker.create_timer(0.005, tick)
    recorder = RecorderNode(context=ctx, parameter_overrides=[Parameter('output', value=sys.argv[1]),
                                                              Parameter('topics', value=['/chatter']),
                                                              Parameter('flush_period', value=float(sys.argv[2]))])
    executor = SingleThreadedExecutor(context=ctx)
    executor.add_node(talker); executor.add_node(recorder)
    executor.spin()
''')


def recorder_kill(run_s: float = 3.0, flush_period_s: float = 1.0) -> dict[str, Any]:
    """A real recording process (a 200 Hz talker and the recorder node) killed with SIGKILL ``run_s`` after it
    starts publishing;
    ``reindex`` recovers the bag. Lost = published - recovered; the recovered ones must be a gapless prefix."""
    with tempfile.TemporaryDirectory() as tmp:
        script = Path(tmp) / 'scene.py'
        script.write_text(RECORDING_SCENE)
        bag = Path(tmp) / 'killed'
        out = Path(tmp) / 'published.txt'
        with out.open('w') as sink:
            proc = subprocess.Popen([sys.executable, str(script), str(bag), str(flush_period_s)], stdout=sink,
                                    stderr=subprocess.DEVNULL)
            deadline = time.monotonic() + 60.0
            while not out.read_text().strip() and time.monotonic() < deadline:   # started talking
                time.sleep(0.05)
            time.sleep(run_s)
            proc.send_signal(signal.SIGKILL)
            proc.wait(timeout=10)
        lines = out.read_text().split()
        published = int(lines[-1]) if lines else 0
        report = reindex(bag)
        with Reader(bag) as reader:
            got = [deserialize(d, c.msgtype).data for c, _, d in reader.messages()]
    gapless = got == [f'm{i}' for i in range(len(got))]
    return {'killed_by': 'SIGKILL', 'returncode': proc.returncode, 'published': published,
            'recovered': report.message_count, 'lost': published - len(got), 'gapless_prefix': gapless,
            'flush_period_s': flush_period_s, 'lost_s_at_200_hz': (published - len(got)) / 200.0}


def bag_corruption(places: int = 8) -> dict[str, Any]:
    """A closed bag of 3 chunks x 10 messages; one bit flipped at ``places`` spots across the chunks' records.
    Counts the corruptions each of reindex, the rosbags reader and the mcap reader (CRC check on, and off,
    its default) notices."""
    String = get_message('std_msgs/msg/String')
    seen = {'reindex': 0, 'rosbags_reader': 0, 'mcap_reader_crc_on': 0, 'mcap_reader_default': 0}
    with tempfile.TemporaryDirectory() as tmp:
        clean = Path(tmp) / 'clean'
        rec = BagRecorder(clean, flush_period_s=None).open()
        for block in range(3):
            for i in range(10 * block, 10 * block + 10):
                rec.write('/chatter', 'std_msgs/msg/String', 1_000_000 * (i + 1), serialize(String(data=f'm{i}')))
            rec.flush()
        rec.close()
        mcap = clean / 'clean.mcap'
        spans = _chunk_spans(mcap)
        original = mcap.read_bytes()
        for k in range(places):
            offset, length = spans[k % len(spans)]
            data = bytearray(original)
            data[offset + (k * 37) % length] ^= 1 << (k % 8)
            bag = Path(tmp) / f'bad{k}'
            bag.mkdir()
            (bag / 'bad.mcap').write_bytes(bytes(data))
            meta = (clean / 'metadata.yaml').read_text().replace('clean.mcap', 'bad.mcap')
            (bag / 'metadata.yaml').write_text(meta)
            seen['reindex'] += scan_mcap(bag / 'bad.mcap').corrupt_chunks > 0
            try:
                with Reader(bag) as reader:
                    list(reader.messages())
            except Exception:  # any refusal is a detection
                seen['rosbags_reader'] += 1
            for key, validate in (('mcap_reader_crc_on', True), ('mcap_reader_default', False)):
                try:
                    with (bag / 'bad.mcap').open('rb') as f:
                        list(make_reader(f, validate_crcs=validate).iter_messages())
                except Exception:
                    seen[key] += 1
    return {'corruptions': places, 'detected': seen}


def _chunk_spans(path: Path) -> list[tuple[int, int]]:
    """``(offset, length)`` of the records inside every chunk of an MCAP file, in file order."""
    out = []
    with path.open('rb') as f:
        for record in StreamReader(f, emit_chunks=True).records:
            if isinstance(record, Chunk):
                out.append((f.tell() - len(record.data), len(record.data)))
    return out
