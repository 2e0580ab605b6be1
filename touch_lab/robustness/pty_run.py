"""Driver nodes reading a real pseudo-terminal, fed bytes written by the caller (synthetic frames).

Used by the report's driver-fault cases, ``test/test_robustness_diagnostics.py`` and
``test/test_driver_pty_sequence.py``.
"""

from __future__ import annotations

import random
from typing import Any

import numpy as np

from touch_driver.bear.node import BearDriverNode
from touch_driver.bear.protocol import BEAR_ID, encode_payload
from touch_driver.framing import crc16, encode_frame
from touch_driver.skin.protocol import encode_skin_frame
from touch_graph.compat import sensor_data_qos
from touch_graph.messages import get_message
from touch_graph.node_health import level_number
from touch_graph.runtime import Context, Node, Parameter, SingleThreadedExecutor
from touch_lab.bench.replay import PtyPort

__all__ = ['ERROR', 'OK', 'RAW', 'SKIN_RAW', 'WARN', 'FailingBearDriver', 'bad_bits_frame', 'corrupt_some', 'level_of',
           'paced', 'run_bear', 'run_driver', 'skin_frames', 'v1_frame', 'value_of']

OK, WARN, ERROR = 0, 1, 2
#: A quiet bear scan: every channel at 300 counts, (64,) uint16.
RAW = np.full(64, 300, dtype=np.uint16)
#: An untouched skin: every taxel at 1000 counts, (144,) uint16 row-major.
SKIN_RAW = np.full(144, 1000, dtype=np.uint16)


class FailingBearDriver(BearDriverNode):
    """A stand-in for a run-time fault (a calibration that raises on every frame), named as such."""

    def handle_frame(self, frame: Any) -> None:
        raise FloatingPointError('calibration diverged')


def bad_bits_frame(seq: int) -> bytes:
    """A bear frame with a good CRC whose channel 0 has bit 12 set: no 10-bit converter sends it."""
    payload = bytearray(encode_payload(RAW))
    payload[1] |= 0x10
    return encode_frame(BEAR_ID, seq, bytes(payload))


def v1_frame(seq: int) -> bytes:
    """A bear scan in protocol version 1 (old firmware): sync, id, length, seq, payload, CRC-16."""
    body = bytes([BEAR_ID]) + (128).to_bytes(2, 'little') + seq.to_bytes(2, 'little') + encode_payload(RAW)
    return b'\xa5\x5a' + body + crc16(body).to_bytes(2, 'little')


def level_of(diagnostic: Any) -> int:
    """A DiagnosticStatus level as an int (see :func:`touch_graph.node_health.level_number`)."""
    return level_number(diagnostic)


def run_bear(wire: bytes, seconds: float = 2.5, node_class: type = BearDriverNode,
             **params: Any) -> tuple[Any, list, list]:
    """A bear driver on a pty carrying ``wire``, simulated time; returns the node, its DriverStatus
    messages and its /diagnostics statuses."""
    # The driver flushes its port when it opens it, and a pty holds 4 KiB: write in pieces while it
    # reads, all within the first status period.
    writes = [(wire[start:start + 2048], 0.2) for start in range(0, len(wire), 2048)]
    node, statuses, diagnostics, _ = run_driver(node_class, 'bear', writes, seconds, **params)
    return node, statuses, diagnostics


def skin_frames(seqs: Any, taxels: np.ndarray | None = None) -> list[bytes]:
    """Skin wire frames with the sequence numbers ``seqs`` (taken mod 65536) of an untouched skin (synthetic)."""
    raw = SKIN_RAW if taxels is None else taxels
    return [encode_skin_frame(s & 0xFFFF, raw) for s in seqs]


def corrupt_some(wire: list[bytes], share: float, seed: int) -> tuple[list[bytes], int]:
    """``wire`` with each frame but the last (which closes the count) corrupted with probability ``share``:
    one random byte anywhere (sync, header, payload or CRC) XORed with a non-zero value. Returns the
    frames and how many were corrupted."""
    rng = random.Random(seed)
    out, hit = list(wire), 0
    for i in range(len(out) - 1):
        if rng.random() < share:
            bad = bytearray(out[i])
            bad[rng.randrange(len(bad))] ^= rng.randrange(1, 256)
            out[i], hit = bytes(bad), hit + 1
    return out, hit


def value_of(diagnostic: Any, key: str) -> str:
    """The value of ``key`` among a DiagnosticStatus's key-values."""
    return next(kv.value for kv in diagnostic.values if kv.key == key)


def paced(frames: list[bytes], rate_hz: float, per_write: int = 4) -> list[tuple[bytes, float]]:
    """``frames`` as (bytes, simulated seconds to run after writing them) pieces of ``per_write``
    frames, so they arrive at ``rate_hz`` (a pty holds 4 KiB: keep a piece below that)."""
    return [(b''.join(frames[i:i + per_write]), len(frames[i:i + per_write]) / rate_hz)
            for i in range(0, len(frames), per_write)]


def run_driver(node_class: type, namespace: str, writes: list[tuple[bytes, float]], seconds: float = 1.5,
               **params: Any) -> tuple[Any, list, list, int]:
    """A driver node on a real pty, simulated time: write each piece of ``writes``, run the graph the
    piece's seconds, then ``seconds`` more. Returns the node, its DriverStatus messages, its
    /diagnostics statuses and the count of messages it published on its frame topic."""
    port = PtyPort()
    ctx = Context('sim')
    ctx.init()
    try:
        node = node_class(context=ctx, namespace=namespace, parameter_overrides=[
            Parameter(k, value=v) for k, v in {'port': port.path, **params}.items()])
        listener = Node('listener', context=ctx)
        statuses: list = []
        diagnostics: list = []
        published: list = []
        name = node.get_name()
        listener.create_subscription(get_message('DriverStatus'), f'/{namespace}/{name}/status', statuses.append, 100)
        listener.create_subscription(get_message('diagnostic_msgs/msg/DiagnosticArray'), '/diagnostics',
                                     diagnostics.append, 100)
        listener.create_subscription(node.frame_pub.msg_type, node.frame_pub.topic_name, published.append,
                                     sensor_data_qos(10_000))
        executor = SingleThreadedExecutor(context=ctx)
        executor.add_node(node)
        executor.add_node(listener)
        for data, run_s in writes:
            port.write(data)
            executor.spin_for(run_s)
        executor.spin_for(seconds)
        node.destroy_node()
    finally:
        ctx.shutdown()
        port.close()
    return node, statuses, [d.status[0] for d in diagnostics], len(published)

