"""Errors of the views: a server that cannot start says why and which flag to change."""

from __future__ import annotations

import errno

from touch_graph.errors import SocialTouchError

__all__ = ['ViewError', 'bind_error']


class ViewError(SocialTouchError):
    """A view cannot serve: its port is taken or not allowed, or its assets are missing."""


def bind_error(what: str, host: str, port: int, err: OSError, flag: str, parameter: str = 'port') -> ViewError:
    """A clear error for a server that could not listen on ``host:port``.

    >>> str(bind_error('the touch view', '127.0.0.1', 8080, OSError(errno.EADDRINUSE, 'in use'), '--port'))[:61]
    'the touch view cannot listen on 127.0.0.1:8080: the port is a'
    """
    if err.errno == errno.EADDRINUSE:
        why = 'the port is already in use (another view, or another program)'
    elif err.errno == errno.EACCES:
        why = 'ports below 1024 need privileges'
    elif err.errno == errno.EADDRNOTAVAIL:
        why = f'{host} is not an address of this machine'
    else:
        why = str(err)
    return ViewError(f'{what} cannot listen on {host}:{port}: {why}. Choose another port with {flag} N '
                     f'(0 picks a free one), or -p {parameter}:=N as a node parameter')
