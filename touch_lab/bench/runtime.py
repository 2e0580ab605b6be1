"""Benchmark of the in-process graph: throughput, publish-to-callback latency, CDR round trip.

The message is a ``PatchFrame``: a 16x16 float32 activation map plus its raw counts and
mask. Each figure is the median of ``repeats`` runs (the machine may be shared and
noisy); latency is taken per message, from just before ``publish`` to the first line of
the subscription's callback, and its median is over all messages of all runs.
"""

from __future__ import annotations

import statistics
import time

import numpy as np

from touch_graph.messages import deserialize, get_message, serialize
from touch_graph.runtime import Context, Node, SingleThreadedExecutor


def _frame():
    frame_cls = get_message('social_touch_msgs/msg/PatchFrame')
    rng = np.random.default_rng(0)
    return frame_cls(activation=rng.random(256, dtype=np.float32),
                     raw=rng.integers(0, 1024, 256).astype(np.uint16), in_outline=[True] * 256)


def bench_runtime(messages: int = 20_000, repeats: int = 5) -> dict:
    """Messages per second, median latency (us) and CDR round trip (us) for a 16x16 float32 frame."""
    frame = _frame()
    rates, latencies = [], []
    for _ in range(repeats):
        ctx = Context('wall')
        ctx.init()
        talker, listener = Node('talker', context=ctx), Node('listener', context=ctx)
        pub = talker.create_publisher(type(frame), 'frame', 10)
        stamps: list[int] = []
        start_ns = [0]

        def on_frame(msg, stamps=stamps, start_ns=start_ns):
            stamps.append(time.perf_counter_ns() - start_ns[0])
        listener.create_subscription(type(frame), 'frame', on_frame, 10)
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(talker)
        executor.add_node(listener)
        spin_once = executor.spin_once
        publish = pub.publish
        # Throughput: publish and deliver back to back.
        t0 = time.perf_counter()
        for _ in range(messages):
            publish(frame)
            spin_once(0)
        rates.append(messages / (time.perf_counter() - t0))
        stamps.clear()
        counter = time.perf_counter_ns
        for _ in range(messages):
            start_ns[0] = counter()
            publish(frame)
            spin_once(0)
        latencies.extend(stamps)
        ctx.shutdown()
    cdr = []
    typename = frame.__msgtype__
    for _ in range(repeats):
        n = 2000
        t0 = time.perf_counter_ns()
        for _ in range(n):
            deserialize(serialize(frame), typename)
        cdr.append((time.perf_counter_ns() - t0) / n / 1000)
    return {
        'message': 'social_touch_msgs/msg/PatchFrame (16x16 float32 activation + raw + mask)',
        'messages_per_run': messages,
        'repeats': repeats,
        'msgs_per_s': round(statistics.median(rates)),
        'median_latency_us': round(statistics.median(latencies) / 1000, 2),
        'p99_latency_us': round(float(np.percentile(latencies, 99)) / 1000, 2),
        'cdr_roundtrip_us': round(statistics.median(cdr), 2),
        'cdr_bytes': len(serialize(frame)),
        'goals': {'msgs_per_s': 100_000, 'median_latency_us': 10.0},
    }
