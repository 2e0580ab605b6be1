"""The one exception hierarchy of social_touch: every error raised on purpose is a :class:`SocialTouchError`;
a bad argument is also a :class:`ValueError`. Messages say what was expected, what arrived and how to fix it.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable


class SocialTouchError(Exception):
    """Base class of every error social_touch raises on purpose."""


class ConfigError(SocialTouchError, ValueError):
    """A configuration file (YAML launch, parameters, body map, ...) is invalid.

    Attributes:
        path: the file, when the error comes from one.
        line: 1-based line number in that file, when known.
    """

    def __init__(self, message: str, path: str | None = None, line: int | None = None) -> None:
        self.path = path
        self.line = line
        where = ''
        if path is not None:
            where = f'{path}:{line}: ' if line is not None else f'{path}: '
        self.bare_message = message
        super().__init__(where + message)


class MessageError(SocialTouchError, TypeError):
    """A message has a missing, unknown or mistyped field, or bytes that do not decode."""


class ParameterError(SocialTouchError, ValueError):
    """A node parameter is undeclared, of the wrong type, or rejected by the node."""


class GraphError(SocialTouchError):
    """Misuse of the node graph: a destroyed node, two types on one topic, no context."""


class LaunchError(ConfigError):
    """A launch file names an unknown package, executable or argument, or is malformed."""


class BagError(SocialTouchError):
    """A rosbag2 cannot be written or read."""


class ServiceCallError(GraphError):
    """A service call got no response: no server, the server vanished, or it was destroyed mid-call."""


def did_you_mean(word: str, choices: Iterable[str]) -> str:
    """`` (did you mean 'x'?)`` for the closest choice, or an empty string."""
    close = difflib.get_close_matches(str(word), [str(c) for c in choices], n=1, cutoff=0.6)
    return f" (did you mean '{close[0]}'?)" if close else ''
