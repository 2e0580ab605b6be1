"""``social-touch bench view-live`` runs: the view and Foxglove in their own processes get the skin's frames,
started before the scene (their subscriptions exist before the driver's publisher) and after it.

Asserts that frames arrive, at a rate comparable to the driver's, not how fast (the rate is the bench's figure).
"""

from dds_testing import allocate_domain

from touch_view.bench_live import ORDERS, bench_live


def check_live(result: dict, orders: tuple[str, ...] = ORDERS) -> None:
    """In each order, the view and Foxglove got at least half the frames the driver published in the windows."""
    for order in orders:
        rates = result[order]
        published = rates['driver_published_hz_median']
        assert published > 0, (order, result)
        for viewer in ('view_received_hz_median', 'foxglove_received_hz_median'):
            assert rates[viewer] >= 0.5 * published, (order, viewer, result)


def test_the_live_bench_measures_the_view_and_foxglove_beside_a_scene(monkeypatch):
    monkeypatch.setenv('SOCIAL_TOUCH_SHIM', '1')
    with allocate_domain() as domain:
        result = bench_live(repeats=1, warmup_s=4.0, window_s=2.0, domain=domain)
    check_live(result)
