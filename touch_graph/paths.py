"""Where the package's shared files (launch/, config/, msg/) are.

The same lookup serves a source checkout, ``pip install .`` (data files under
``<prefix>/share/social_touch``) and a colcon workspace (``AMENT_PREFIX_PATH``), as
``ros2 pkg prefix`` / ``$(find-pkg-share ...)`` do on ROS 2.
"""

from __future__ import annotations

import os
import sys
from functools import cache
from pathlib import Path

from .errors import ConfigError

PACKAGE = 'social_touch'
#: Name of the interface package that `social-touch export-interfaces` writes; message type
#: names use it (``social_touch_msgs/msg/SkinFrame``) so bags open on a ROS 2 machine.
INTERFACE_PACKAGE = 'social_touch_msgs'

_SOURCE_ROOT = Path(__file__).resolve().parent.parent


def _candidates(package: str) -> list[Path]:
    out = []
    if package == PACKAGE and (_SOURCE_ROOT / 'package.xml').is_file() and (_SOURCE_ROOT / 'msg').is_dir():
        out.append(_SOURCE_ROOT)  # a source checkout or editable install: prefer the live files
    for prefix in os.environ.get('AMENT_PREFIX_PATH', '').split(os.pathsep):
        if prefix:
            out.append(Path(prefix) / 'share' / package)
    out.append(Path(sys.prefix) / 'share' / package)
    return out


@cache
def package_share(package: str = PACKAGE) -> Path:
    """The share directory of ``package``.

    Raises:
        ConfigError: when the package is not found anywhere.
    """
    for candidate in _candidates(package):
        if (candidate / 'package.xml').is_file():
            return candidate
    searched = ', '.join(str(c) for c in _candidates(package))
    raise ConfigError(f"package '{package}' not found (searched {searched}); is it installed "
                      f'(pip install . or colcon build + source install/setup.bash)?')


def share_file(*parts: str, package: str = PACKAGE) -> Path:
    """A file under the package's share directory, e.g. ``share_file('config', 'x.yaml')``."""
    return package_share(package).joinpath(*parts)
