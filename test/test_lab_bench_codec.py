"""``social-touch bench codec``: our codec and rosbags' timed on every kind, on the same bytes."""

from touch_lab.bench.codec import bench_codec
from touch_lab.bench.transport_echo import KINDS


def test_the_codec_bench_times_our_codec_and_rosbags_on_every_kind():
    result = bench_codec(repeats=1, calls=5)
    assert set(result['kinds']) == set(KINDS) and result['rounds'] == 1 and result['calls_per_round'] == 5
    for figures in result['kinds'].values():
        assert figures['bytes'] > 0
        for key in ('python_encode_us', 'python_decode_us', 'rosbags_encode_us', 'rosbags_decode_us'):
            assert figures[key] > 0, key
        assert figures['rosbags_over_python_decode'] == round(figures['rosbags_decode_us']
                                                               / figures['python_decode_us'], 2)
