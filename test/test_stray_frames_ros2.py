"""The skin recogniser's bounded parameters, change audit and frame screening on real rclpy (Jazzy).

The same checks as test/test_stray_frames.py on our runtime: the node runs on real rclpy in a
process of its own (``SOCIAL_TOUCH_ROS2_PYTHON``, a colcon-built social_touch_msgs sourced), and
prints what rclpy made of each parameter set and of stray frames as JSON.
"""

from __future__ import annotations

import json
import os
import subprocess
import textwrap

import pytest
from ros2_testing import require_ros2, ros2_env

ROS2_PYTHON = os.environ.get('SOCIAL_TOUCH_ROS2_PYTHON', '')
pytestmark = pytest.mark.ros2

SCRIPT = textwrap.dedent('''
    import json
    import numpy as np
    import rclpy
    from rclpy.exceptions import InvalidParameterValueException
    from rclpy.parameter import Parameter
    from social_touch_msgs.msg import SkinFrame
    from std_msgs.msg import Header
    from builtin_interfaces.msg import Time
    from touch_gestures.skin.node import HapticCommandsNode
    rclpy.init()
    out = {}
    quiet = ['--ros-args', '--log-level', 'error']
    try:
        HapticCommandsNode(namespace='skin', cli_args=quiet,
                           parameter_overrides=[Parameter('min_margin', value=0.0)])
        out['start_min_margin_0'] = 'accepted'
    except InvalidParameterValueException as err:
        out['start_min_margin_0'] = str(err)
    node = HapticCommandsNode(namespace='skin', cli_args=['--ros-args', '--log-level', 'warn'])
    out['rclpy'] = type(node).__mro__[1].__module__
    for name, value in (('max_distance', 1000000.0), ('min_margin', 0.0), ('min_margin', 0.3)):
        [r] = node.set_parameters([Parameter(name, value=value)])
        out[f'{name}={value}'] = [r.successful, r.reason]
    level, text, counters = node.health.status()
    out['audit'] = [level, text, counters['parameter_changes']]
    def frame(t, seq, frame_id='skin'):
        return SkinFrame(header=Header(stamp=Time(sec=t), frame_id=frame_id), sequence=seq,
                         pressure=np.zeros(144, np.float32).tolist())
    for i in range(20):
        node._on_frame(frame(1000 + i, i))
        node._on_frame(SkinFrame())          # a stray's: stamp 0, no frame_id
    level, text, counters = node.health.status()
    out['screen'] = [level, text, node.stream.frames, node.stream.restarts]
    print(json.dumps(out), flush=True)
''')


def test_ranges_audit_and_screen_hold_on_real_rclpy():
    require_ros2()
    if not ROS2_PYTHON:
        pytest.skip('SOCIAL_TOUCH_ROS2_PYTHON (a ROS 2 Jazzy Python) is unset')
    proc = subprocess.run([ROS2_PYTHON, '-c', SCRIPT], env=ros2_env(), capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr[-2000:]
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out['rclpy'].startswith('rclpy'), out
    assert 'min_margin' in out['start_min_margin_0'] and 'out of range' in out['start_min_margin_0']
    ok, why = out['max_distance=1000000.0']
    assert not ok and why.startswith('Parameter max_distance out of range Min: -1.0, Max: 0.')
    ok, why = out['min_margin=0.0']
    assert not ok and why == 'Parameter min_margin out of range Min: 0.02, Max: 2.0, value: 0.0'
    assert out['min_margin=0.3'] == [True, '']
    level, text, changes = out['audit']
    assert (level, changes) == (1, 1) and 'min_margin: 0.1 -> 0.3' in text
    assert '[WARN]' in proc.stderr and 'parameter min_margin changed: 0.1 -> 0.3' in proc.stderr
    level, text, frames, restarts = out['screen']
    assert level == 1 and '20 other_frame_id' in text and (frames, restarts) == (20, 0), out['screen']
