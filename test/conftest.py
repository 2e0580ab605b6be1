"""Shared test setup: the suite's graphs off the network unless a test asks, a domain each; the view's fixtures.

``SOCIAL_TOUCH_NETWORK=0`` makes every ``Context`` that is not told otherwise stay in
process, so in-process tests never meet another graph on this machine (another test
run, a robot). What joins DDS anyway (``social-touch demo`` and ``launch`` join because
they are told to) lands in a domain this test session holds, with discovery on this host
only. A test that wants DDS takes the ``dds_domain`` fixture: a domain id no other test
on the machine holds (a lock file per id); it sets ``ROS_DOMAIN_ID`` and
``ROS_AUTOMATIC_DISCOVERY_RANGE`` for the test and for the processes it starts, and lifts
``SOCIAL_TOUCH_NETWORK``.

The touch view's tests share ``run_scene`` (a scene spinning in the background),
``busy_port`` and ``scene_launch`` (a launch file of scripted bear and skin scenes).
"""

import os
import socket

import pytest
from dds_testing import allocate_domain

from touch_sim.virtual_port import forget_devices
from touch_view.scene import BackgroundScene

os.environ['SOCIAL_TOUCH_NETWORK'] = '0'
os.environ['SOCIAL_TOUCH_DAEMON'] = '0'  # no graph daemon outlives a test (test_cli_daemon.py starts its own)
# Held until the session's process ends (the lock goes with its file descriptor).
_session_domain = allocate_domain()
os.environ['ROS_DOMAIN_ID'] = str(_session_domain.__enter__())
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
for _name in ('ROS_STATIC_PEERS', 'CYCLONEDDS_URI', 'ROS_LOCALHOST_ONLY'):
    os.environ.pop(_name, None)


@pytest.fixture
def dds_domain(monkeypatch):
    """A DDS domain id of the test's own (int), set in the environment with LOCALHOST discovery."""
    with allocate_domain() as domain:
        monkeypatch.setenv('ROS_DOMAIN_ID', str(domain))
        monkeypatch.setenv('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
        monkeypatch.delenv('ROS_STATIC_PEERS', raising=False)
        monkeypatch.delenv('CYCLONEDDS_URI', raising=False)
        monkeypatch.delenv('ROS_DISTRO', raising=False)
        monkeypatch.delenv('SOCIAL_TOUCH_NETWORK', raising=False)
        yield domain


@pytest.fixture
def run_scene():
    """``run_scene(launch_file, rate=2.0)``: start a launch file's graph in the background; stopped afterwards."""
    started = []

    def start(launch_file, rate: float = 2.0) -> BackgroundScene:
        forget_devices()
        scene = BackgroundScene(launch_file, rate=rate).start()
        started.append(scene)
        return scene
    try:
        yield start
    finally:
        for scene in started:
            scene.stop()
        forget_devices()


@pytest.fixture
def busy_port():
    """A localhost port another socket listens on."""
    busy = socket.socket()
    busy.bind(('127.0.0.1', 0))
    busy.listen()
    try:
        yield busy.getsockname()[1]
    finally:
        busy.close()


@pytest.fixture
def scene_launch(tmp_path):
    """``scene_launch(bear=[touch, ...], skin=[event, ...], serve=['touch_view'])``: a launch file in tmp_path.

    The package's bear and skin launch files on scripted scenes written here (SYNTHETIC: the
    virtual devices play them), plus the named serving nodes on free ports (port 0).
    """
    def write(bear: list[str] = (), skin: list[str] = (), serve: list[str] = ()) -> str:
        parts = ['launch:']
        for sensor, items, header, port in (('bear', bear, 'sensor: bear\ntouches:\n', 'bearsim://bear'),
                                            ('skin', skin, 'skin_scene: 1\nduration_s: 30.0\nevents:\n',
                                             'skinsim://skin')):
            if items:
                (tmp_path / f'{sensor}.yaml').write_text(header + ''.join(f'  - {item}\n' for item in items))
                url = f'{port}?scene={tmp_path}/{sensor}.yaml'
                parts.append(f"""- include:
    file: $(find-pkg-share social_touch)/launch/{sensor}.launch.yaml
    arg: [{{name: monitor, value: 'false'}}, {{name: {sensor}_port, value: '{url}'}}]""")
        for exec_name in serve:
            parts.append(f"""- node:
    pkg: social_touch
    exec: {exec_name}
    name: {exec_name}
    param:
    - {{name: port, value: 0, type: int}}""")
        launch = tmp_path / 'scene.launch.yaml'
        launch.write_text('\n'.join(parts) + '\n')
        return str(launch)
    return write


def pytest_configure(config):
    # Tests that start real ROS 2 (rclpy from a sourced Jazzy and a colcon-built social_touch_msgs): they
    # skip without one, and fail instead with SOCIAL_TOUCH_REQUIRE_ROS2=1 (.ci/ros2-jazzy).
    config.addinivalue_line('markers', 'ros2: needs real ROS 2 (rclpy and a built social_touch_msgs); '
                                       '.ci/ros2-jazzy runs them')


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under SOCIAL_TOUCH_REQUIRE_ROS2=1 a skipped ``ros2`` test fails: the ROS 2 step cannot pass by skipping."""
    outcome = yield
    report = outcome.get_result()
    if report.skipped and item.get_closest_marker('ros2') and os.environ.get('SOCIAL_TOUCH_REQUIRE_ROS2') == '1':
        report.outcome = 'failed'
        report.longrepr = f'SOCIAL_TOUCH_REQUIRE_ROS2=1, but this ros2 test was skipped: {report.longrepr}'
