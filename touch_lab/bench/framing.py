"""``social-touch bench framing``: bogus frames per MB of a flood of fake headers (the framing's false-accept rate).

Each flood (synthetic, seeded) mixes fake headers with real frames, fed to one
:class:`~touch_driver.framing.FrameDecoder` that knows every sensor: ``v1_headers`` (version-1 layout),
``v2_headers`` (random sequence and header check) and ``checked_headers`` (whole fake frames whose
header passes its check: each costs a CRC-32 over a payload). A bogus frame is one returned that was
never sent; a lost frame one sent and not returned. Also given: the expected bogus frames, failed
payload checks x 2^-32, which the measured zero bounds.
"""

from __future__ import annotations

import random
import statistics
import struct
import time
from typing import Any

from touch_driver.framing import PROTOCOL_VERSION, SYNC, FrameDecoder, crc16, encode_frame

__all__ = ['FLOODS', 'PAYLOAD_SIZES', 'bench_framing', 'flood', 'run_flood']

#: Every sensor's frame ids and payload lengths (bear, patch averaged, patch raw, skin).
PAYLOAD_SIZES = {0x42: 128, 0x50: 342, 0x51: 342, 0x53: 288}
FLOODS = ('v1_headers', 'v2_headers', 'checked_headers')


def _fake(kind: str, rnd: random.Random) -> bytes:
    sensor_id = rnd.choice(sorted(PAYLOAD_SIZES))
    length = PAYLOAD_SIZES[sensor_id]
    if kind == 'v1_headers':
        return SYNC + struct.pack('<BHH', sensor_id, length, rnd.getrandbits(16))
    if kind == 'v2_headers':
        return SYNC + struct.pack('<BBHHH', PROTOCOL_VERSION, sensor_id, length, rnd.getrandbits(16),
                                  rnd.getrandbits(16))
    if kind == 'checked_headers':
        fields = struct.pack('<BBHH', PROTOCOL_VERSION, sensor_id, length, rnd.getrandbits(16))
        return SYNC + fields + struct.pack('<H', crc16(fields)) + rnd.randbytes(length + 4)
    raise ValueError(f'unknown flood {kind!r}; expected one of {FLOODS}')


def flood(kind: str, megabytes: float, seed: int = 0, real_every: int = 2048) -> tuple[bytes, list[tuple]]:
    """A flood of ``megabytes`` MB (1e6 bytes) of fake headers of ``kind``, with a real frame after
    about every ``real_every`` bytes of fakes. Returns the stream and the real frames sent,
    ``[(sensor_id, seq, payload), ...]``."""
    if not megabytes > 0 or real_every < 1:
        raise ValueError(f'megabytes > 0 and real_every >= 1 are required; got {megabytes}, {real_every}')
    rnd = random.Random(seed)
    parts: list[bytes] = []
    sent: list[tuple] = []
    size = 0
    since_real = 0
    target = int(megabytes * 1e6)
    while size < target:
        if since_real >= real_every:
            sensor_id = rnd.choice(sorted(PAYLOAD_SIZES))
            frame = (sensor_id, len(sent) & 0xFFFF, rnd.randbytes(PAYLOAD_SIZES[sensor_id]))
            sent.append(frame)
            part = encode_frame(*frame)
            since_real = 0
        else:
            part = _fake(kind, rnd)
            since_real += len(part)
        parts.append(part)
        size += len(part)
    return b''.join(parts) + bytes(max(PAYLOAD_SIZES.values()) + 14), sent


def run_flood(kind: str, megabytes: float = 4.0, seed: int = 0, chunk: int = 4096) -> dict[str, Any]:
    """Feed one flood to a decoder in ``chunk``-byte reads; count bogus and lost frames and the checks made."""
    stream, sent = flood(kind, megabytes, seed)
    decoder = FrameDecoder(PAYLOAD_SIZES)
    start = time.process_time()
    got = [f for i in range(0, len(stream), chunk) for f in decoder.update(stream[i:i + chunk])]
    cpu_s = time.process_time() - start
    sent_set = set(sent)
    got_keys = [(f.sensor_id, f.seq, f.payload) for f in got]
    stats = decoder.stats
    payload_checks = stats.checksum_errors + stats.frames   # headers that passed: a CRC-32 over their payload
    return {
        'flood': kind, 'megabytes': len(stream) / 1e6, 'seed': seed, 'real_frames': len(sent),
        'bogus_frames': sum(1 for key in got_keys if key not in sent_set),
        'lost_frames': len(sent_set - set(got_keys)),
        'header_errors': stats.header_errors, 'version_errors': stats.version_errors,
        'length_errors': stats.length_errors, 'checksum_errors': stats.checksum_errors,
        'payload_checks': payload_checks, 'expected_bogus': stats.checksum_errors * 2.0 ** -32,
        'decode_mb_per_s': len(stream) / 1e6 / cpu_s if cpu_s > 0 else float('inf'),
    }


def bench_framing(repeats: int = 5, megabytes: float = 4.0) -> dict:
    """Every flood, ``repeats`` seeds of ``megabytes`` MB each: bogus and lost frames summed, decode speed median."""
    if repeats < 1 or not megabytes > 0:
        raise ValueError(f'repeats >= 1 and megabytes > 0 are required; got {repeats}, {megabytes}')
    out: dict[str, Any] = {}
    for kind in FLOODS:
        runs = [run_flood(kind, megabytes, seed) for seed in range(repeats)]
        total_mb = sum(r['megabytes'] for r in runs)
        bogus = sum(r['bogus_frames'] for r in runs)
        out[kind] = {
            'megabytes': total_mb, 'real_frames': sum(r['real_frames'] for r in runs),
            'bogus_frames': bogus, 'bogus_per_mb': bogus / total_mb,
            'lost_frames': sum(r['lost_frames'] for r in runs),
            'payload_checks': sum(r['payload_checks'] for r in runs),
            'expected_bogus_per_mb': sum(r['expected_bogus'] for r in runs) / total_mb,
            'decode_mb_per_s': statistics.median(r['decode_mb_per_s'] for r in runs),
            'synthetic_data': True,
        }
    out['what'] = ('fake headers with real frames between, fed to a decoder of every sensor id in 4 KiB reads '
                   '(synthetic, seeds 0..repeats-1); bogus = returned but never sent, lost = sent but not returned')
    return out
