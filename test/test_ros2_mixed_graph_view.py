"""The view and Foxglove in processes of their own show the skin's frames on real rclpy and on our runtime,
whichever backend the scene runs on, started before the scene (their subscriptions exist before the driver's
publisher: they must follow what it offers, best effort) or after it.

``social-touch bench view-live`` measures the rates (median of windows); here each window's frames received
are compared with the frames the driver published in it (test_view_live_bench.check_live).
"""
import pytest
from dds_testing import allocate_domain
from ros2_testing import require_ros2
from test_view_live_bench import check_live

from touch_view.bench_live import bench_live

pytestmark = [pytest.mark.ros2, pytest.mark.slow]


@pytest.mark.parametrize(('scene', 'view', 'orders'), [
    ('rclpy', 'rclpy', ('view-first', 'scene-first')),
    ('rclpy', 'ours', ('view-first',)),
    ('ours', 'rclpy', ('view-first',)),
])
def test_view_and_foxglove_show_the_skin_from_another_process(scene, view, orders):
    require_ros2()
    with allocate_domain() as domain:
        result = bench_live(repeats=1, warmup_s=5.0, window_s=3.0, domain=domain, orders=orders,
                            scene_backend=scene, view_backend=view)
    check_live({order: result[order] for order in orders}, orders)
