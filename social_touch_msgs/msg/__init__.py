"""The message classes of social_touch_msgs, made on first use from the package's ``.msg`` files.

>>> from social_touch_msgs.msg import SymbolicGesture
>>> SymbolicGesture.__msgtype__
'social_touch_msgs/msg/SymbolicGesture'
"""

from __future__ import annotations

from typing import Any

from touch_graph.errors import MessageError
from touch_graph.messages import get_message, interface_names


def _names() -> list[str]:
    return [name.rsplit('/', 1)[1] for name in interface_names()]


def __getattr__(name: str) -> Any:
    if name.startswith('__'):
        raise AttributeError(name)
    try:
        return get_message(f'social_touch_msgs/msg/{name}')
    except MessageError as err:
        raise AttributeError(f"module 'social_touch_msgs.msg' has no message {name!r}; "
                             f'its messages: {", ".join(_names())}') from err


def __dir__() -> list[str]:
    return sorted([*globals(), *_names()])


__all__ = _names()  # computed from the .msg files, so `import *` gives every message
