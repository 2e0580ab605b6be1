"""``social-touch export-interfaces DIR``: the ``social_touch_msgs`` interface package for ROS 2.

ROS 2 cannot generate messages inside an ament_python package, so the same ``.msg`` and
``.srv`` files go into an ament_cmake package of their own; built in a robot's workspace, it
gives the classes the nodes use under real rclpy, with the type names bags recorded here
carry and services use on the wire.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
from pathlib import Path

from ..errors import ConfigError
from ..files import disk_full_error, is_disk_full
from ..messages import msg_files
from ..paths import INTERFACE_PACKAGE
from ..srv_types import srv_files

PACKAGE_XML = """\
<?xml version="1.0"?>
<?xml-model href="http://download.ros.org/schema/package_format3.xsd" schematypens="http://www.w3.org/2001/XMLSchema"?>
<package format="3">
  <name>{name}</name>
  <version>{version}</version>
  <description>Messages of social_touch: calibrated touch sensor frames and touch gestures.</description>
  <maintainer email="maintainers@users.noreply.h-seed-831969ee.example">social_touch maintainers</maintainer>
  <license>Apache-2.0</license>

  <buildtool_depend>ament_cmake</buildtool_depend>
  <buildtool_depend>rosidl_default_generators</buildtool_depend>
{depends}
  <exec_depend>rosidl_default_runtime</exec_depend>
  <member_of_group>rosidl_interface_packages</member_of_group>

  <export>
    <build_type>ament_cmake</build_type>
  </export>
</package>
"""

CMAKELISTS = """\
cmake_minimum_required(VERSION 3.8)
project({name})

find_package(ament_cmake REQUIRED)
find_package(rosidl_default_generators REQUIRED)
{find_packages}
rosidl_generate_interfaces(${{PROJECT_NAME}}
{files}
  DEPENDENCIES {dependencies}
)

ament_export_dependencies(rosidl_default_runtime)
ament_package()
"""

_TYPE_REF = re.compile(r'^\s*([A-Za-z][A-Za-z0-9_]*)/([A-Za-z][A-Za-z0-9_]*)', re.MULTILINE)



def message_dependencies(files: list[Path]) -> list[str]:
    """Packages the ``.msg`` and ``.srv`` files refer to (``std_msgs/Header`` -> ``std_msgs``), sorted."""
    deps = set()
    for path in files:
        for line in path.read_text(encoding='utf-8').splitlines():
            match = _TYPE_REF.match(line.split('#')[0])
            if match and match.group(1) != INTERFACE_PACKAGE:
                deps.add(match.group(1))
    return sorted(deps)


def export_interfaces(out_dir: Path, version: str = '0.1.0', force: bool = False) -> Path:
    """Write ``out_dir/social_touch_msgs``; returns the package directory."""
    package_dir = Path(out_dir) / INTERFACE_PACKAGE
    if package_dir.exists() and any(package_dir.iterdir()) and not force:
        raise ConfigError(f'{package_dir} exists and is not empty; pass --force to overwrite it')
    files = msg_files()
    services = srv_files()
    deps = message_dependencies(files + services)
    # Written whole beside the target, then renamed over it: a full disk leaves no half package.
    staging = package_dir.with_name(f'.{INTERFACE_PACKAGE}.{os.getpid()}.tmp')
    try:
        for kind, paths in (('msg', files), ('srv', services)):
            if paths:
                (staging / kind).mkdir(parents=True, exist_ok=True)
            for path in paths:
                shutil.copyfile(path, staging / kind / path.name)
        (staging / 'package.xml').write_text(PACKAGE_XML.format(
            name=INTERFACE_PACKAGE, version=version, depends=''.join(f'  <depend>{d}</depend>\n' for d in deps)))
        (staging / 'CMakeLists.txt').write_text(CMAKELISTS.format(
            name=INTERFACE_PACKAGE, find_packages=''.join(f'find_package({d} REQUIRED)\n' for d in deps),
            files='\n'.join([*(f'  "msg/{p.name}"' for p in files), *(f'  "srv/{p.name}"' for p in services)]),
            dependencies=' '.join(deps)))
    except OSError as err:
        shutil.rmtree(staging, ignore_errors=True)
        if is_disk_full(err):
            raise disk_full_error(package_dir, err, f'{package_dir} is as it was') from err
        raise
    if package_dir.exists():
        shutil.rmtree(package_dir)
    staging.rename(package_dir)
    return package_dir


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.description = __doc__.split('\n\n')[1].replace('\n', ' ')
    parser.add_argument('dir', type=Path, help='where to write the package, e.g. ~/ros2_ws/src')
    parser.add_argument('--force', action='store_true', help='overwrite an existing package directory')


def run(args: argparse.Namespace) -> int:
    package_dir = export_interfaces(args.dir, force=args.force)
    print(f'wrote {package_dir} ({len(msg_files())} messages, {len(srv_files())} services); build it with colcon in '
          'your ROS 2 workspace')
    return 0
