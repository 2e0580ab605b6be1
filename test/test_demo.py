"""The main job: `social-touch demo` runs the demo scene, prints perceptions and ends by itself."""

import subprocess
import sys


def test_demo_runs_prints_perceptions_and_ends_by_itself(tmp_path):
    env_dir = tmp_path / 'graph'
    result = subprocess.run(
        [sys.executable, '-m', 'touch_lab.cli.main', 'demo', '--fast', '--duration', '20'],
        capture_output=True, text=True, timeout=300,
        env={**__import__('os').environ, 'SOCIAL_TOUCH_GRAPH_DIR': str(env_dir)})
    assert result.returncode == 0, result.stderr
    assert 'all sensor data is synthetic' in result.stderr
    assert 'someone is handling the robot' in result.stdout
    assert 'scene over' in result.stderr


def test_demo_rejects_a_bad_launch_argument():
    result = subprocess.run([sys.executable, '-m', 'touch_lab.cli.main', 'demo', '--fast', 'use_bare:=false'],
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 1
    assert 'use_bear' in result.stderr
