"""``social-touch bench codec``: CDR encode and decode per message kind, our generated codec against rosbags'.

Both serialisers of each kind (:mod:`touch_graph.cdr`'s generated codec, which the runtime uses, and
rosbags' generic one, the library the codec's bytes are held equal to) are timed in turns in this
one process on the same synthetic message of the real size (the transport bench's sample):
``repeats`` rounds, each a batch of ``calls`` encodes or decodes per serialiser, the per-call time of a
batch in us of CPU time; the medians over rounds and their ratio (rosbags / ours) are reported. These are
hot-loop costs (caches warm); in a ping-pong the first call after a wait costs more.
"""

from __future__ import annotations

import statistics
import time
from typing import Any

from touch_graph import messages
from touch_graph.cdr import make_codec
from touch_lab.bench.timing import gc_paused
from touch_lab.bench.transport import sample_message
from touch_lab.bench.transport_echo import KINDS

__all__ = ['bench_codec']


def _serialisers(typename: str) -> dict[str, tuple[Any, Any]]:
    """name -> (encode(message), decode(bytes)) of our codec and of rosbags for ``typename``."""
    other = messages.decoder(typename)  # only big-endian input reaches it, none here
    ours = make_codec(typename, messages.typestore.fielddefs, messages.get_message, other)
    store = messages.typestore
    return {'python': (ours.encode, ours.decode),
            'rosbags': (lambda m: bytes(store.serialize_cdr(m, typename, little_endian=True)),
                        lambda b: store.deserialize_cdr(b, typename))}


def _per_call_us(fn: Any, arg: Any, calls: int) -> float:
    """CPU time of this thread per call, us: what a share of a core is made of, and blind to the time
    other processes of a busy machine hold the core."""
    start = time.thread_time_ns()
    for _ in range(calls):
        fn(arg)
    return (time.thread_time_ns() - start) / calls / 1000


def _bench_kind(kind: str, repeats: int, calls: int) -> dict[str, Any]:
    message = sample_message(kind)
    serialisers = _serialisers(KINDS[kind])
    # rosbags' serialiser takes numpy arrays where rclpy's types are array.array and lists (made once, untimed)
    given = {'python': message, 'rosbags': messages.for_rosbags(message)}
    data = serialisers['python'][0](message)
    if serialisers['rosbags'][0](given['rosbags']) != data:
        raise AssertionError(f'{kind}: our codec and rosbags encode different bytes')  # the tests hold them equal
    times: dict[str, list[float]] = {f'{name}_{op}': [] for name in serialisers for op in ('encode', 'decode')}
    for name, (encode, decode) in serialisers.items():  # warm
        _per_call_us(encode, given[name], calls)
        _per_call_us(decode, data, calls)
    with gc_paused():
        for _ in range(repeats):
            for name, (encode, decode) in serialisers.items():  # in turns, so a busy moment hits both
                times[f'{name}_encode'].append(_per_call_us(encode, given[name], calls))
                times[f'{name}_decode'].append(_per_call_us(decode, data, calls))
    out: dict[str, Any] = {'bytes': len(data)}
    for key, values in times.items():
        out[f'{key}_us'] = round(statistics.median(values), 3)
    for op in ('encode', 'decode'):
        out[f'rosbags_over_python_{op}'] = round(out[f'rosbags_{op}_us'] / out[f'python_{op}_us'], 2)
    return out


def bench_codec(repeats: int = 5, calls: int = 2000) -> dict[str, Any]:
    """Per kind: median us per encode and decode of our codec (``python_*``) and of rosbags, their ratios.
    ``calls`` per batch, ``repeats`` batches per serialiser."""
    return {'message': "synthetic messages of the real sizes (the transport bench's); hot loops, CPU us per call",
            'rounds': repeats, 'calls_per_round': calls,
            'kinds': {kind: _bench_kind(kind, repeats, calls) for kind in KINDS}}
