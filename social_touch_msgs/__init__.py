"""``social_touch_msgs``: this project's messages, importable the ROS way.

::

    from social_touch_msgs.msg import SymbolicGesture

gives the same classes as ``touch_graph.messages.get_message('social_touch_msgs/msg/SymbolicGesture')``:
generated at import from the ``.msg`` files, with CDR through rosbags. This is a stand-in for
the package rosidl generates from the same files (``social-touch export-interfaces`` writes it
for a ROS 2 workspace). When that generated package is installed too, it wins: importing this
one finds it further along ``sys.path`` and hands out its classes instead, so node code written
against either runs unchanged on a ROS 2 robot.
"""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

_HERE = Path(__file__).resolve().parent


def _generated_package() -> Path | None:
    """The rosidl-generated social_touch_msgs on sys.path, if any (it has _<type>.py modules)."""
    for entry in sys.path:
        candidate = Path(entry or '.').resolve() / 'social_touch_msgs'
        if candidate != _HERE and (candidate / 'msg' / '_symbolic_gesture.py').is_file():
            return candidate
    return None


def _defer_to(package: Path) -> None:
    spec = importlib.util.spec_from_file_location(
        __name__, package / '__init__.py', submodule_search_locations=[str(package)])
    if spec is None or spec.loader is None:  # pragma: no cover - a broken install
        return
    module = importlib.util.module_from_spec(spec)
    sys.modules[__name__] = module
    spec.loader.exec_module(module)


_generated = _generated_package()
if _generated is not None:
    _defer_to(_generated)
