"""Errors of the skin gesture recognisers (a branch of :mod:`touch_graph.errors`).

Data and codebook files name the file and the line (or the array) that is wrong, what
was expected and what arrived.
"""

from __future__ import annotations

from touch_graph.errors import ConfigError, SocialTouchError

__all__ = ['CodebookError', 'SkinGestureError', 'TraceFormatError']


class SkinGestureError(SocialTouchError):
    """Base class of the errors raised on purpose by :mod:`touch_gestures.skin`."""


class TraceFormatError(SkinGestureError, ValueError):
    """A trace CSV file (``subject,variant,gesture,sample,stroke,x,y,t_ms``) is malformed.

    Attributes:
        path: the file.
        line: 1-based line number of the offending row, when known.
    """

    def __init__(self, message: str, path: str | None = None, line: int | None = None) -> None:
        self.path = path
        self.line = line
        where = ''
        if path is not None:
            where = f'{path}:{line}: ' if line is not None else f'{path}: '
        self.bare_message = message
        super().__init__(where + message)


class CodebookError(ConfigError, SkinGestureError):
    """A codebook file is missing, of another format version, recogniser or parameters."""
