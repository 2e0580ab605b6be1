"""On real rclpy (ROS 2 Jazzy) the skin driver also reads a real pty when bytes arrive: the guard condition
and the clock's ``ros_time_is_active`` it relies on are rclpy's own."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from dds_testing import allocate_domain
from ros2_testing import ROOT, require_ros2, ros2_env

CHILD = r'''
import json, os, threading, time
import rclpy
from rclpy.parameter import Parameter
from touch_graph import compat
from touch_driver.skin.node import SkinDriverNode
from touch_lab.bench.replay import PtyPort
from touch_lab.robustness.pty_run import skin_frames

rclpy.init()
port = PtyPort()
node = SkinDriverNode(namespace='skin', parameter_overrides=[Parameter('port', value=port.path)])
got = []
node.create_subscription(node.frame_pub.msg_type, node.frame_pub.topic_name, got.append, compat.sensor_data_qos(1000))
executor = rclpy.executors.SingleThreadedExecutor()
executor.add_node(node)

def feed():
    for frame in skin_frames(range(100)):
        os.write(port.master, frame)
        time.sleep(1 / 150)

threading.Thread(target=feed).start()
end = time.monotonic() + 20
while time.monotonic() < end and len(got) < 100:
    executor.spin_once(timeout_sec=0.1)
stamps = [m.header.stamp.sec * 10**9 + m.header.stamp.nanosec for m in got]
print(json.dumps({'using_ros': compat.USING_ROS, 'arrival': node.reads_on_arrival, 'timers': len(list(node.timers)),
                  'frames': node.counters()['frames'], 'received': len(got),
                  'increasing': all(b > a for a, b in zip(stamps, stamps[1:]))}))
node.destroy_node()
rclpy.shutdown()
port.close()
'''


@pytest.mark.ros2
def test_the_skin_driver_on_real_rclpy_reads_when_bytes_arrive() -> None:
    require_ros2()
    with allocate_domain() as domain:
        done = subprocess.run([sys.executable, '-c', CHILD], cwd=ROOT, capture_output=True, text=True, timeout=120,
                              env=ros2_env(ROS_DOMAIN_ID=str(domain), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST'))
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    assert out == {'using_ros': True, 'arrival': True, 'timers': 1, 'frames': 100, 'received': 100,
                   'increasing': True}
