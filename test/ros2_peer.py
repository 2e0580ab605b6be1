"""A real rclpy node (ROS 2 Jazzy, Fast DDS) in a process of its own, for the tests beside a real ROS 2.

The python of a venv with Jazzy's rclpy (``/work/ros2-venv/bin/python``, made as
``shared/ros2-from-pypi.md`` says) is named by ``SOCIAL_TOUCH_ROS2_PYTHON``; tests that need it
skip when it is unset or cannot import rclpy.

As a script, it measures how often ``social-touch node list`` lists a real rclpy node started
0.1 s before the call::

    SOCIAL_TOUCH_ROS2_PYTHON=/work/ros2-venv/bin/python .venv/bin/python test/ros2_peer.py 20
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys
import textwrap
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent

#: A node that publishes std_msgs/String on /fast_chatter (best effort, as sensor data) every 50 ms.
NODE = textwrap.dedent('''
    import sys
    import rclpy
    from rclpy.qos import qos_profile_sensor_data
    from std_msgs.msg import String
    rclpy.init()
    node = rclpy.create_node(sys.argv[1])
    pub = node.create_publisher(String, '/fast_chatter', qos_profile_sensor_data)
    n = [0]

    def tick():
        pub.publish(String(data=f'fast {n[0]}'))
        n[0] += 1
    node.create_timer(0.05, tick)
    print('ready', flush=True)
    try:
        rclpy.spin(node)
    except KeyboardInterrupt:
        pass
''')


@functools.cache
def ros2_python() -> str | None:
    """The python of the ROS 2 venv, if ``SOCIAL_TOUCH_ROS2_PYTHON`` names one that imports rclpy."""
    python = os.environ.get('SOCIAL_TOUCH_ROS2_PYTHON')
    if not python:
        return None
    result = subprocess.run([python, '-c', 'import rclpy, std_msgs'], capture_output=True, timeout=120)
    return python if result.returncode == 0 else None


def start_node(name: str, env: dict[str, str]) -> subprocess.Popen:
    """A real rclpy node ``name`` in the domain of ``env``, returned once it exists (printed 'ready')."""
    python = ros2_python()
    if python is None:
        raise RuntimeError('SOCIAL_TOUCH_ROS2_PYTHON does not name a python that imports rclpy')
    ros_env = {k: v for k, v in env.items() if k not in ('PYTHONPATH', 'SOCIAL_TOUCH_SHIM')}
    proc = subprocess.Popen([python, '-c', NODE, name], env=ros_env, stdout=subprocess.PIPE,
                            stderr=subprocess.DEVNULL, text=True)
    if proc.stdout.readline().strip() != 'ready':
        proc.kill()
        proc.wait()
        raise RuntimeError(f'the rclpy node {name} did not start')
    return proc


def stop(proc: subprocess.Popen) -> None:
    proc.kill()
    proc.wait(10)


def listed_of(tries: int, domain: int) -> int:
    """How many of ``tries`` ``social-touch node list`` runs list a rclpy node started 0.1 s before each."""
    import time
    env = {**os.environ, 'ROS_DOMAIN_ID': str(domain), 'ROS_AUTOMATIC_DISCOVERY_RANGE': 'LOCALHOST',
           'PYTHONPATH': str(REPO)}
    listed = 0
    for i in range(tries):
        node = start_node(f'fast_talker_{i}', env)
        try:
            time.sleep(0.1)
            started = time.monotonic()
            run = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'node', 'list'], env=env,
                                 cwd=REPO, capture_output=True, text=True, timeout=60)
            if f'/fast_talker_{i}' in run.stdout.split():
                listed += 1
            else:  # what the tool saw instead, for the cause
                print(f'try {i}: not listed after {time.monotonic() - started:.1f} s; node list said '
                      f'{run.stdout.split()} {run.stderr.strip()[-300:]}', file=sys.stderr)
        finally:
            stop(node)
    return listed


if __name__ == '__main__':
    n = int(sys.argv[1]) if len(sys.argv) > 1 else 20
    domain = int(sys.argv[2]) if len(sys.argv) > 2 else 77
    print(f'social-touch node list listed a real rclpy (Fast DDS) node started 0.1 s before: '
          f'{listed_of(n, domain)} of {n}')
