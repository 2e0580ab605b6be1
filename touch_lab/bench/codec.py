"""``social-touch bench codec``: CDR encode and decode per message kind, compiled codec against Python codec.

Both codecs of each kind are built in this one process (whatever ``SOCIAL_TOUCH_CDR`` says) and
timed in turns on the same synthetic message of the real size (the transport bench's sample):
``repeats`` rounds, each a batch of ``calls`` encodes or decodes per codec, the per-call time
of a batch in us; the medians over rounds and their ratio (Python / compiled) are reported.
These are hot-loop costs (caches warm); in a ping-pong the first call after a wait costs more.

A long loop then encodes and decodes ``leak_calls`` times with the compiled codec and reports
the growth of the process's resident memory (a leak of a few bytes per call would show as MB;
tracemalloc does not see C allocations, so the RSS is read from ``/proc/self/statm``).
"""

from __future__ import annotations

import os
import statistics
import time
from typing import Any

from touch_graph import cdr_accel, messages
from touch_graph.cdr import make_codec
from touch_graph.errors import MessageError
from touch_lab.bench.timing import gc_paused
from touch_lab.bench.transport import sample_message
from touch_lab.bench.transport_echo import KINDS

__all__ = ['bench_codec']


def _codecs(typename: str) -> dict[str, Any]:
    """The Python codec and, where built, the compiled codec of a type (name -> Codec)."""
    get = messages.get_message
    other = messages.decoder(typename)  # only big-endian input reaches it, none here
    python = make_codec(typename, messages.typestore.fielddefs, get, other)
    out = {'python': python}
    if cdr_accel.available():
        out['c'] = cdr_accel.make_accel_codec(typename, messages.typestore.fielddefs, get, other, python)
    return out


def _per_call_us(fn: Any, arg: Any, calls: int) -> float:
    start = time.perf_counter_ns()
    for _ in range(calls):
        fn(arg)
    return (time.perf_counter_ns() - start) / calls / 1000


def _rss_kib() -> int:
    with open('/proc/self/statm') as statm:
        return int(statm.read().split()[1]) * os.sysconf('SC_PAGE_SIZE') // 1024


def _bench_kind(kind: str, repeats: int, calls: int) -> dict[str, Any]:
    message = sample_message(kind)
    codecs = _codecs(KINDS[kind])
    data = codecs['python'].encode(message)
    times: dict[str, list[float]] = {f'{name}_{op}': [] for name in codecs for op in ('encode', 'decode')}
    for codec in codecs.values():  # warm
        _per_call_us(codec.encode, message, calls)
        _per_call_us(codec.decode, data, calls)
    with gc_paused():
        for _ in range(repeats):
            for name, codec in codecs.items():  # in turns, so a busy moment hits both
                times[f'{name}_encode'].append(_per_call_us(codec.encode, message, calls))
                times[f'{name}_decode'].append(_per_call_us(codec.decode, data, calls))
    out: dict[str, Any] = {'bytes': len(data)}
    for key, values in times.items():
        out[f'{key}_us'] = round(statistics.median(values), 3)
    if 'c' in codecs:
        for op in ('encode', 'decode'):
            out[f'python_over_c_{op}'] = round(out[f'python_{op}_us'] / out[f'c_{op}_us'], 2)
    return out


def _leak_check(calls: int) -> dict[str, Any]:
    """RSS growth (KiB) over ``calls`` encodes and decodes of every kind with the compiled codec."""
    pairs = []
    for kind, typename in KINDS.items():
        codec = _codecs(typename)['c']
        message = sample_message(kind)
        pairs.append((codec, message, codec.encode(message)))
    for codec, message, data in pairs:  # warm: the allocator's pools reach their working size
        for _ in range(1000):
            codec.decode(codec.encode(message))
            codec.decode(data)
    before = _rss_kib()
    for codec, message, data in pairs:
        for _ in range(calls):
            codec.decode(codec.encode(message))
            _decode_failing(codec, data[:-9])  # the failure path too
    return {'calls_per_kind': calls, 'rss_growth_kib': _rss_kib() - before}


def _decode_failing(codec: Any, data: bytes) -> None:
    try:
        codec.decode(data)
    except MessageError:
        return
    raise AssertionError('a truncated payload decoded')  # pragma: no cover - the tests check the refusal


def bench_codec(repeats: int = 5, calls: int = 2000, leak_calls: int = 100_000) -> dict[str, Any]:
    """Per kind: median us per encode and decode of each codec, the Python / compiled ratios; the RSS
    growth over a long loop. ``calls`` per batch, ``leak_calls`` per kind in the long loop (0: skip it)."""
    result: dict[str, Any] = {
        'message': 'synthetic messages of the real sizes (the transport bench\'s); hot loops, us per call',
        'in_use': messages.codec_implementation(), 'compiled_available': cdr_accel.available(),
        'rounds': repeats, 'calls_per_round': calls,
        'kinds': {kind: _bench_kind(kind, repeats, calls) for kind in KINDS},
    }
    if cdr_accel.available() and leak_calls:
        result['long_loop'] = _leak_check(leak_calls)
    return result
