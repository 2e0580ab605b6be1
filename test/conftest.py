"""Fixtures the touch view's tests share: a scene spinning in the background, a port that is taken."""

from __future__ import annotations

import socket

import pytest

from touch_driver.virtual_port import forget_devices
from touch_view.scene import BackgroundScene


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
