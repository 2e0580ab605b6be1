"""Errors of the skin gesture recognisers (a branch of :mod:`touch_graph.errors`).

Data and codebook files name the file and the line (or the array) that is wrong, what
was expected and what arrived.
"""

from __future__ import annotations

from touch_graph.errors import ConfigError, SocialTouchError

__all__ = ['CodebookError', 'SkinGestureError', 'TraceFormatError']


class SkinGestureError(SocialTouchError):
    """Base class of the errors raised on purpose by :mod:`touch_gestures.skin`."""


class TraceFormatError(ConfigError, SkinGestureError):
    """A trace CSV file (``subject,variant,gesture,sample,stroke,x,y,t_ms``) is malformed.

    A :class:`ConfigError` (so a ``ValueError``): ``path`` and ``line`` name the offending row.
    """


class CodebookError(ConfigError, SkinGestureError):
    """A codebook file is missing, of another format version, recogniser or parameters."""
