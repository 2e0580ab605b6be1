"""Helpers for tests that start real ROS 2: whether it is here, and a process of real rclpy.

Real ROS 2 is here when this Python finds ``rclpy`` and ``social_touch_msgs`` (a sourced Jazzy and
a colcon-built interface package: docs/ros2.md, .ci/ros2-jazzy). The test process itself may run on
our runtime (``SOCIAL_TOUCH_SHIM=1``); :func:`ros2_env` is the environment of a child process that
runs on real rclpy. Without ROS 2 the tests skip, saying so; with ``SOCIAL_TOUCH_REQUIRE_ROS2=1``
(the CI step) they fail instead, so the step cannot pass by skipping.
"""

import importlib.util
import os
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def missing_ros2() -> str:
    """Why real ROS 2 cannot run here, or '' when it can."""
    missing = [] if _find('rclpy') else ['rclpy']
    if not _generated_messages():
        missing.append('a colcon-built social_touch_msgs')
    if not missing:
        return ''
    return (f'real ROS 2 is not here ({" and ".join(missing)} not importable by {sys.executable}); '
            '.ci/ros2-jazzy and docs/ros2.md install it')


def _find(module: str) -> object:
    try:
        return importlib.util.find_spec(module)
    except ImportError:  # the parent package is missing
        return None


def _generated_messages() -> bool:
    """Whether rosidl's social_touch_msgs is on sys.path (the source tree's stand-in has no _<type>.py)."""
    return any((Path(entry or '.') / 'social_touch_msgs' / 'msg' / '_skin_frame.py').is_file() for entry in sys.path)


def require_ros2() -> None:
    """Skip the test without real ROS 2, or fail with SOCIAL_TOUCH_REQUIRE_ROS2=1."""
    why = missing_ros2()
    if why:
        if os.environ.get('SOCIAL_TOUCH_REQUIRE_ROS2') == '1':
            pytest.fail(f'SOCIAL_TOUCH_REQUIRE_ROS2=1 but {why}')
        pytest.skip(why)


def ros2_env(**extra: str) -> dict[str, str]:
    """This process's environment for a child on real rclpy (no SOCIAL_TOUCH_SHIM), plus ``extra``."""
    env = {k: v for k, v in os.environ.items() if k != 'SOCIAL_TOUCH_SHIM'}
    env.update(extra)
    return env
