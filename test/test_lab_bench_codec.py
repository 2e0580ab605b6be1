"""``social-touch bench codec``: both codecs timed on every kind, and the long loop's memory growth."""

import pytest

from touch_graph import cdr_accel, messages
from touch_lab.bench.codec import bench_codec
from touch_lab.bench.transport_echo import KINDS


def test_the_codec_bench_times_both_codecs_on_every_kind():
    if not cdr_accel.available():
        pytest.skip(f'the compiled CDR codec was not built here: {cdr_accel.IMPORT_ERROR}')
    result = bench_codec(repeats=1, calls=5, leak_calls=200)
    assert result['in_use'] == messages.codec_implementation() and result['compiled_available']
    assert set(result['kinds']) == set(KINDS)
    for figures in result['kinds'].values():
        assert figures['bytes'] > 0
        for key in ('python_encode_us', 'python_decode_us', 'c_encode_us', 'c_decode_us', 'python_over_c_decode'):
            assert figures[key] > 0, key
    assert result['long_loop']['calls_per_kind'] == 200 and 'rss_growth_kib' in result['long_loop']
