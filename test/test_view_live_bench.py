"""``social-touch bench view-live`` runs: the view and Foxglove in their own processes get the skin's frames.

Asserts that frames arrive, not how fast (the rate is the bench's figure).
"""

from dds_testing import allocate_domain

from touch_view.bench_live import bench_live


def test_the_live_bench_measures_the_view_and_foxglove_beside_a_scene():
    with allocate_domain() as domain:
        result = bench_live(repeats=1, warmup_s=6.0, window_s=2.0, domain=domain)
    assert result['view_received_hz_median'] > 0 and result['foxglove_received_hz_median'] > 0, result
    assert result['driver_published_hz_median'] >= result['foxglove_received_hz_median'] * 0.5, result
