"""Where the package's shared files (launch/, config/, msg/) are: a source checkout, ``pip install .``
(``<prefix>/share/social_touch``) or a colcon workspace (``AMENT_PREFIX_PATH``).

``social-touch launch`` in a source checkout calls :func:`prefer_checkout`, which sets
:data:`CHECKOUT_ENV`: that process and its node processes then read ``config/`` and ``launch/``
from the checkout (``msg/`` and ``srv/`` stay the installed ones).
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
#: A checkout whose config/ and launch/ replace the installed ones (set by prefer_checkout()).
CHECKOUT_ENV = 'SOCIAL_TOUCH_CHECKOUT'
#: The parts of the share directory a checkout replaces: what users edit to tune a scene.
CHECKOUT_PARTS = ('config', 'launch')

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
    """A file under the package's share directory, e.g. ``share_file('config', 'x.yaml')``.

    ``config/`` and ``launch/`` come from the checkout :func:`prefer_checkout` chose, if any.
    """
    checkout = os.environ.get(CHECKOUT_ENV)
    if checkout and package == PACKAGE and parts and parts[0] in CHECKOUT_PARTS:
        return Path(checkout).joinpath(*parts)
    return package_share(package).joinpath(*parts)


def launch_share(package: str) -> Path:
    """``$(find-pkg-share package)`` for launch files: the preferred checkout for this package, if any."""
    checkout = os.environ.get(CHECKOUT_ENV)
    if checkout and package == PACKAGE:
        return Path(checkout)
    return package_share(package)


def find_checkout(start: Path | None = None) -> Path | None:
    """The source checkout of this package that ``start`` (default: the working directory) is in, or None.

    A checkout is a directory with this package's ``package.xml`` (``<name>social_touch</name>``)
    and a ``config/`` directory: ``start`` itself or the nearest one above it.
    """
    here = (start or Path.cwd()).resolve()
    for directory in (here, *here.parents):
        manifest = directory / 'package.xml'
        if manifest.is_file() and (directory / 'config').is_dir():
            try:
                text = manifest.read_text(encoding='utf-8')
            except (OSError, UnicodeDecodeError):
                continue
            if f'<name>{PACKAGE}</name>' in text:
                return directory
    return None


def prefer_checkout(start: Path | None = None) -> tuple[Path | None, Path | None]:
    """Use the checkout around ``start`` for ``config/`` and ``launch/`` when it is not the installed copy.

    Returns ``(checkout, installed)``: the checkout now preferred (None when there is none, or when
    it is what is installed, as with ``pip install -e .``) and the share directory it replaces.
    Sets :data:`CHECKOUT_ENV`, which node processes started afterwards inherit.
    """
    checkout = find_checkout(start)
    try:
        installed = package_share(PACKAGE)
    except ConfigError:
        installed = None
    if checkout is None or (installed is not None and installed.resolve() == checkout):
        return None, installed
    os.environ[CHECKOUT_ENV] = str(checkout)
    return checkout, installed
