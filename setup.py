"""social_touch: an ament_python package that pip can install too.

`colcon build` installs the node executables under lib/social_touch/ (see setup.cfg);
`pip install .` puts the same console scripts on PATH.
"""

import sys
from glob import glob

from setuptools import Extension, find_packages, setup

try:  # numpy's headers for the compiled CDR codec (pip gets numpy through pyproject's build requirements)
    import numpy
except ImportError:  # a build without numpy (a bare colcon build): the pure-Python package
    numpy = None

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
    'bear_sensor_frames': ('touch_gestures.bear.sensor_frames', 'BearSensorFramesNode'),
    'patch_gestures': ('touch_gestures.patch.node', 'PatchGesturesNode'),
    'haptic_commands': ('touch_gestures.skin.node', 'HapticCommandsNode'),
    'touch_state': ('touch_gestures.touch_state.node', 'TouchStateNode'),
    'touch_view': ('touch_view.node', 'TouchViewNode'),
    'foxglove_server': ('touch_view.foxglove_node', 'FoxgloveServerNode'),
}

# Plug-in points, importlib.metadata entry point groups. A package registers what it brings here; the
# runtime finds it by group, so it never names (or imports) a module of the simulation or the lab.
ENTRY_POINT_GROUPS: dict[str, list[str]] = {
    # `social-touch NAME`: a module (or object) with add_arguments(parser) and run(args) (touch_graph.cli.main).
    'social_touch.commands': [
        'launch = touch_graph.launch.cli', 'topic = touch_graph.cli.topic', 'node = touch_graph.cli.node',
        'record = touch_graph.cli.record', 'play = touch_graph.cli.play', 'bag = touch_graph.cli.bag',
        'interface = touch_graph.cli.interface', 'export-interfaces = touch_graph.cli.export_interfaces',
        'param = touch_graph.cli.param', 'service = touch_graph.cli.service',
        'view = touch_view.cli', 'foxglove = touch_view.foxglove_cli',
        'demo = touch_sim.demo',
        'eval = touch_lab.cli.targets:EVAL', 'train = touch_lab.cli.targets:TRAIN',
        'codebook = touch_lab.cli.targets:CODEBOOK', 'report = touch_lab.cli.targets:REPORT',
        'bench = touch_lab.cli.bench', 'lines = touch_lab.lines', 'collect = touch_lab.collect.cli',
        'model = touch_lab.model_cli', 'adapt = touch_lab.adapt',
    ],
    # Targets of the lab's commands (touch_lab.cli.targets): add_arguments(parser), run(args), HELP.
    'social_touch.eval': ['bear = touch_lab.bear.cli', 'patch = touch_lab.patch.cli:EVAL', 'skin = touch_lab.skin.cli',
                          'skin-sessions = touch_lab.skin.session_eval', 'adapt = touch_lab.adapt_measure',
                          'skin-collisions = touch_lab.skin.collision_eval', 'skin-ending = touch_lab.skin.ending_cli'],
    'social_touch.train': ['bear = touch_lab.bear.train', 'patch = touch_lab.patch.cli:TRAIN',
                           'skin = touch_lab.skin.train_cli'],
    'social_touch.codebook': ['record = touch_lab.skin.record_cli', 'info = touch_lab.skin.codebook_cli:INFO',
                              'add = touch_lab.skin.codebook_cli:ADD', 'remove = touch_lab.skin.codebook_cli:REMOVE',
                              'merge = touch_lab.skin.codebook_cli:MERGE'],
    'social_touch.report': ['bear = touch_lab.bear.report', 'patch = touch_lab.patch.report',
                            'skin = touch_lab.skin.report', 'skin-multistroke = touch_lab.skin.multistroke_report',
                            'view-screenshot = touch_view.screenshot', 'robustness = touch_lab.robustness.report',
                            'foxglove-layout = touch_view.foxglove_layout'],
    # `social-touch bench NAME`: a function bench(repeats=N) -> dict.
    'social_touch.bench': [
        'runtime = touch_lab.bench.runtime:bench_runtime', 'drivers = touch_lab.bench.drivers:bench_drivers',
        'transport = touch_lab.bench.transport:bench_transport', 'view = touch_view.bench:bench_view',
        'view-live = touch_view.bench_live:bench_live',
        'bear = touch_lab.bear.bench:bench_cycle',
        'patch = touch_lab.patch.bench:bench_frame', 'patch-node = touch_lab.patch.bench:bench_node',
        'skin = touch_lab.skin.bench:bench_recognition', 'skin-node = touch_lab.skin.session_eval:bench_node',
        'skin-latency = touch_lab.skin.latency:bench_latency',
        'stack = touch_lab.bench.stack:bench_stack', 'training = touch_lab.bench.training:bench_training',
        'framing = touch_lab.bench.framing:bench_framing', 'codec = touch_lab.bench.codec:bench_codec',
    ],
    # `generator: NAME` in a scene file (touch_sim.scenes): a function returning a stimulus.
    'social_touch.scene_generators': ['bear_people = touch_sim.bear.people:make_scene',
                                      'patch_people = touch_sim.patch.people:people_scene',
                                      'skin_people = touch_sim.skin.people:people_scene'],
    # URL scheme -> the package of its pyserial handler (protocol_<scheme>.py), added to
    # serial.protocol_handler_packages by the drivers when a port uses the scheme (touch_driver.ports).
    'social_touch.serial_url_handlers': ['bearsim = touch_sim.urlhandlers', 'patchsim = touch_sim.urlhandlers',
                                         'skinsim = touch_sim.urlhandlers'],
}

# The compiled CDR codec (touch_graph/cdr_accel.py): optional, as PyYAML's libyaml binding is. Where it
# does not build (no C compiler, no Python headers) the package installs without it and runs the
# Python codec; SOCIAL_TOUCH_REQUIRE_CDR_ACCEL=1 makes the tests fail then (CI sets it).
# The skin's cloud search (touch_gestures/skin/cloud_accel.py) the same way: SOCIAL_TOUCH_REQUIRE_SKIN_ACCEL=1.
# No fused multiply-adds in it: they would round otherwise than the numpy reference (MSVC does not contract).
_NO_FMA = [] if sys.platform == 'win32' else ['-ffp-contract=off']
EXTENSIONS = [Extension('touch_graph._cdr_accel', ['touch_graph/_cdr_accel.c'], include_dirs=[numpy.get_include()],
                        optional=True),
              Extension('touch_gestures.skin._cloud_accel', ['touch_gestures/skin/_cloud_accel.c',
                                                             'touch_gestures/skin/_cloud_features.c',
                                                             'touch_gestures/skin/_oriented_features.c'],
                        depends=['touch_gestures/skin/_cloud_features.h'],
                        include_dirs=[numpy.get_include()], extra_compile_args=_NO_FMA, optional=True),
              ] if numpy is not None else []

setup(
    name=PACKAGE,
    version='0.1.0',
    description='Touch perception for a social robot: drivers and gesture recognisers as a ROS 2 node graph',
    license='Apache-2.0',
    python_requires='>=3.10',
    # Three layers, one distribution: the runtime (touch_graph, touch_driver, touch_gestures), the
    # simulation (touch_sim: the demo runs on it) and the lab (touch_lab); beside them the live view
    # (touch_view) and the ROS-style import of our messages (social_touch_msgs).
    packages=find_packages(include=[f'{top}{sub}' for top in ('touch_graph', 'touch_driver', 'touch_gestures',
                                                               'touch_sim', 'touch_lab', 'touch_view',
                                                               'social_touch_msgs') for sub in ('', '.*')]),
    # The view's page, its assets and the Foxglove layout: shipped in the package, nothing fetched online.
    package_data={'touch_view': ['static/*.html', 'static/*.js', 'static/*.css', 'bear_layout.yaml',
                                 'layouts/*.json']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.yaml')),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.npz') + glob('config/*.md')),
        (f'share/{PACKAGE}/config/scenes', glob('config/scenes/*.yaml')),
        (f'share/{PACKAGE}/msg', glob('msg/*.msg')),
        (f'share/{PACKAGE}/srv', glob('srv/*.srv')),
    ],
    # Bounds are the versions CI tests: the lower ones through constraints/lowest.txt, the upper
    # ones by a plain install (the newest each bound allows). Widen a bound only after testing it.
    install_requires=[
        'numpy>=2.0.2,<2.5',
        'scikit-learn>=1.6.0,<1.10',  # 1.6: check_array(ensure_all_finite=...)
        'scipy>=1.13.1,<1.18',  # also a dependency of scikit-learn; used directly (linalg, ndimage, signal)
        'pyserial>=3.5,<4',
        'pyyaml>=6.0,<7',
        # The message type system (CDR, .msg parsing, type hashes) and the rosbag2 reader the player
        # uses; public APIs only (0.11.9 is the newest release, tested; the lower bound in CI).
        'rosbags>=0.11.6,<0.12',
        # social-touch foxglove: the Foxglove WebSocket server (touch_view.foxglove_node); 0.25 is the
        # first release whose start_server takes message_backlog_size (a bounded queue per client).
        'foxglove-sdk>=0.25.0,<0.31',
        # Cyclone DDS between processes and machines; the wheel bundles the C library. 11.0.1 is
        # the oldest release with a wheel for Python 3.11 (0.10.x must be built from source).
        'cyclonedds>=11.0.1,<12',
        # MCAP writing (the recorder, with chunk CRCs; Writer.flush() is public from 1.5.0) and
        # reading and rewriting torn files (bag reindex).
        'mcap>=1.5.0,<1.7',
        # The figures of the evaluation reports (touch_lab.figures, Agg, loaded only by `social-touch report`;
        # the runtime never imports it). 3.9.0 is the first release built for numpy 2; 3.10 tested too.
        'matplotlib>=3.9.0,<3.11',
    ],
    extras_require={
        'test': ['pytest>=7', 'hypothesis>=6.80', 'ruff>=0.5', 'colcon-core', 'colcon-ros',
                 'colcon-python-setup-py',
                 # the view's browser test (system chromium + chromedriver) and Foxglove client test
                 'selenium>=4.11,<5', 'websockets>=13.0,<18'],
    },
    ext_modules=EXTENSIONS,
    zip_safe=False,  # a compiled extension is loaded from a file
    entry_points={
        'console_scripts': [
            'social-touch = touch_graph.cli.main:main',
            *(f'{name} = {module}:main' for name, (module, _) in NODES.items()),
        ],
        # exec name -> node class, for in-process launch.
        'social_touch.nodes': [f'{name} = {module}:{cls}' for name, (module, cls) in NODES.items()],
        **ENTRY_POINT_GROUPS,
    },
)
