"""What colcon's ament_python build needs beyond pyproject.toml: the files it installs under share/.

The metadata, dependencies, packages and entry points are in pyproject.toml (pip and colcon read them
from there); setup.cfg puts the node executables under lib/social_touch/ for `ros2 run`.
"""

from glob import glob

from setuptools import setup

PACKAGE = 'social_touch'

setup(
    # Here, not in pyproject.toml: colcon cannot read a static requires-python (pyproject.toml says why).
    python_requires='>=3.10',
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/launch', glob('launch/*.yaml')),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.npz') + glob('config/*.md')),
        (f'share/{PACKAGE}/config/scenes', glob('config/scenes/*.yaml')),
        (f'share/{PACKAGE}/msg', glob('msg/*.msg')),
        (f'share/{PACKAGE}/srv', glob('srv/*.srv')),
    ],
)
