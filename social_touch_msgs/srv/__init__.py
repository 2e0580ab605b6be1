"""The service classes of social_touch_msgs, made on first use from the package's ``.srv`` files.

``from social_touch_msgs.srv import X`` gives ``X`` with ``X.Request`` and ``X.Response``, as the
rosidl-generated package does (see ``social_touch_msgs/msg`` for how that one wins when installed).
"""

from __future__ import annotations

from typing import Any

from touch_graph.errors import MessageError
from touch_graph.srv_types import get_service, service_names


def _names() -> list[str]:
    return [name.rsplit('/', 1)[1] for name in service_names()]


def __getattr__(name: str) -> Any:
    if name.startswith('__'):
        raise AttributeError(name)
    if name not in _names():
        raise AttributeError(f"module 'social_touch_msgs.srv' has no service {name!r}; its services: "
                             f'{", ".join(_names()) or "none"}')
    try:
        return get_service(f'social_touch_msgs/srv/{name}')
    except MessageError as err:  # pragma: no cover - a .srv that does not parse fails at import already
        raise AttributeError(str(err)) from err


def __dir__() -> list[str]:
    return sorted([*globals(), *_names()])


__all__ = _names()  # computed from the .srv files, so `import *` gives every service
