"""social_touch: an ament_python package that pip can install too.

`colcon build` installs the node executables under lib/social_touch/ (see setup.cfg);
`pip install .` puts the same console scripts on PATH.
"""

from glob import glob

from setuptools import find_packages, setup

PACKAGE = 'social_touch'

# One executable per node, name -> (module, node class). `ros2 run social_touch <name>` runs the
# module's main(); `social-touch launch` finds the class through the social_touch.nodes group.
NODES: dict[str, tuple[str, str]] = {
    'bear_driver': ('touch_driver.bear.node', 'BearDriverNode'),
    'patch_driver': ('touch_driver.patch.node', 'PatchDriverNode'),
    'skin_driver': ('touch_driver.skin.node', 'SkinDriverNode'),
    'recorder': ('touch_graph.bag.recorder_node', 'RecorderNode'),
    'player': ('touch_graph.bag.player_node', 'PlayerNode'),
    'touch_monitor': ('touch_gestures.monitor_node', 'TouchMonitorNode'),
    'bear_gestures': ('touch_gestures.bear.node', 'BearGesturesNode'),
    'patch_gestures': ('touch_gestures.patch.node', 'PatchGesturesNode'),
    'haptic_commands': ('touch_gestures.skin.node', 'HapticCommandsNode'),
}

setup(
    name=PACKAGE,
    version='0.1.0',
    description='Touch perception for a social robot: drivers and gesture recognisers as a ROS 2 node graph',
    license='Apache-2.0',
    python_requires='>=3.10',
    # Three layers, one distribution: the runtime (touch_graph, touch_driver, touch_gestures), the
    # simulation (touch_sim: the demo runs on it) and the lab (touch_lab).
    packages=find_packages(include=[f'{top}{sub}' for top in ('touch_graph', 'touch_driver', 'touch_gestures',
                                                               'touch_sim', 'touch_lab') for sub in ('', '.*')]),
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.yaml')),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.npz') + glob('config/*.md')),
        (f'share/{PACKAGE}/config/scenes', glob('config/scenes/*.yaml')),
        (f'share/{PACKAGE}/msg', glob('msg/*.msg')),
    ],
    # Bounds are the versions CI tests: the lower ones through constraints/lowest.txt, the upper
    # ones by a plain install (the newest each bound allows). Widen a bound only after testing it.
    install_requires=[
        'numpy>=2.0.2,<2.5',
        'scikit-learn>=1.6.0,<1.10',  # 1.6: check_array(ensure_all_finite=...)
        'scipy>=1.13.1,<1.18',  # also a dependency of scikit-learn; used directly (linalg, ndimage, signal)
        'pyserial>=3.5,<4',
        'pyyaml>=6.0,<7',
        # The message type system and rosbag2/MCAP I/O; touch_graph.bag uses the MCAP
        # writer's chunk flush, so the minor version is pinned.
        'rosbags>=0.11.6,<0.12',
    ],
    extras_require={
        'test': ['pytest>=7', 'hypothesis>=6.80', 'ruff>=0.5', 'colcon-core', 'colcon-ros',
                 'colcon-python-setup-py'],
    },
    zip_safe=True,
    entry_points={
        'console_scripts': [
            'social-touch = touch_graph.cli.main:main',
            *(f'{name} = {module}:main' for name, (module, _) in NODES.items()),
        ],
        # exec name -> node class, for in-process launch.
        'social_touch.nodes': [f'{name} = {module}:{cls}' for name, (module, cls) in NODES.items()],
    },
)
