"""Benchmark of the cross-process path: bridge throughput and latency, bag write and read rates.

Two graphs with a bridge each run in one process (each executor in a thread of its own;
the bytes still cross a Unix socket, are framed, queued and injected as between two
processes). The message is a synthetic ``PatchFrame`` (16x16 float32 activation, uint16
raw counts, bool mask: 1.8 kB of CDR). Each figure is the median of ``repeats`` runs;
latency is per message, publish to the remote subscription's callback, one message in
flight at a time.
"""

from __future__ import annotations

import shutil
import statistics
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from ..messages import get_message, serialize
from ..runtime import Context, Node, SingleThreadedExecutor
from .bridge import Bridge

__all__ = ['bench_bridge']


def _frame():
    cls = get_message('social_touch_msgs/msg/PatchFrame')
    rng = np.random.default_rng(0)
    return cls(activation=rng.random(256, dtype=np.float32), raw=rng.integers(0, 1024, 256).astype(np.uint16),
               in_outline=np.ones(256, bool))


class _Graph:
    def __init__(self, name: str, directory: Path) -> None:
        self.context = Context('wall')
        self.context.init()
        self.executor = SingleThreadedExecutor(context=self.context)
        self.node = Node(name, context=self.context)
        self.executor.add_node(self.node)
        self.bridge = Bridge(self.context, self.executor, name=name, directory=directory,
                             send_queue_frames=100_000, send_queue_bytes=1 << 30, inbound_limit=100_000).start()
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.context.ok():
            self.executor.spin_once(0.05)

    def run(self, fn):
        done = threading.Event()
        self.executor.call_soon_threadsafe(lambda: (fn(), done.set()))
        done.wait(30)

    def close(self) -> None:
        self.bridge.stop()
        self.context.try_shutdown()
        self.thread.join(10)


def _bridge_run(messages: int, latency_samples: int) -> tuple[float, list[float], int]:
    directory = Path(tempfile.mkdtemp(prefix='stb'))
    sender, receiver = _Graph('bench_sender', directory), _Graph('bench_receiver', directory)
    try:
        cls = get_message('social_touch_msgs/msg/PatchFrame')
        frame = _frame()
        got = [0]
        arrived = threading.Event()
        sent_at = [0.0]
        latencies: list[float] = []

        def on_msg(_msg) -> None:
            got[0] += 1
            if sent_at[0]:
                latencies.append(time.perf_counter() - sent_at[0])
                sent_at[0] = 0.0
            arrived.set()
        receiver.run(lambda: receiver.node.create_subscription(cls, '/bench', on_msg, 100_000))
        box = []
        sender.run(lambda: box.append(sender.node.create_publisher(cls, '/bench', 10)))
        pub = box[0]
        deadline = time.monotonic() + 10
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        for _ in range(latency_samples):
            arrived.clear()
            sent_at[0] = time.perf_counter()
            sender.run(lambda: pub.publish(frame))
            arrived.wait(5)
        got[0] = 0
        start = time.perf_counter()
        # Bursts of 100, each once the bridge has taken the previous one from its local queue
        # (depth 1000): the sustained rate, not how deep a queue is.
        outbound = sender.bridge._outbound['/bench']
        for first in range(0, messages, 100):
            burst = min(100, messages - first)
            sender.run(lambda n=burst: [pub.publish(frame) for _ in range(n)])
            while outbound._queue:
                time.sleep(0.0002)
        while got[0] < messages and time.perf_counter() - start < 60:
            time.sleep(0.001)
        elapsed = time.perf_counter() - start
        return got[0] / elapsed, latencies, sender.bridge.stats()['dropped']
    finally:
        sender.close()
        receiver.close()
        shutil.rmtree(directory, ignore_errors=True)


def _bag_run(messages: int) -> tuple[float, float]:
    from ..bag.player import BagPlayer
    from ..bag.recorder import BagRecorder
    directory = Path(tempfile.mkdtemp(prefix='stb'))
    try:
        data = serialize(_frame())
        start = time.perf_counter()
        with BagRecorder(directory / 'bag', flush_period_s=1.0) as rec:
            for i in range(messages):
                rec.write('/patch/frame', 'social_touch_msgs/msg/PatchFrame', i * 50_000_000, data)
        write_rate = messages / (time.perf_counter() - start)
        start = time.perf_counter()
        with BagPlayer(directory / 'bag') as player:
            count = sum(1 for _ in player.messages())
        read_rate = count / (time.perf_counter() - start)
        return write_rate, read_rate
    finally:
        shutil.rmtree(directory, ignore_errors=True)


def bench_bridge(messages: int = 5_000, repeats: int = 5, latency_samples: int = 200) -> dict:
    """Medians over ``repeats`` runs: bridge messages/s and latency (us), bag write/read messages/s."""
    rates, latencies, drops, writes, reads = [], [], 0, [], []
    for _ in range(repeats):
        rate, lat, dropped = _bridge_run(messages, latency_samples)
        rates.append(rate)
        latencies += lat
        drops += dropped
        write_rate, read_rate = _bag_run(messages)
        writes.append(write_rate)
        reads.append(read_rate)
    return {
        'message': f'synthetic PatchFrame, {len(serialize(_frame()))} bytes of CDR',
        'bridge_messages_per_s': round(statistics.median(rates)),
        'bridge_latency_median_us': round(statistics.median(latencies) * 1e6, 1) if latencies else None,
        'bridge_latency_p95_us': round(float(np.percentile(latencies, 95)) * 1e6, 1) if latencies else None,
        'bridge_dropped': drops,
        'bag_write_messages_per_s': round(statistics.median(writes)),
        'bag_read_messages_per_s': round(statistics.median(reads)),
        'repeats': repeats,
    }
