"""Where graph processes find each other: one Unix socket per peer in a per-user directory.

The directory is ``$SOCIAL_TOUCH_GRAPH_DIR`` if set, else ``$XDG_RUNTIME_DIR/social_touch``,
else ``/tmp/social_touch-<uid>``, with one subdirectory per ``ROS_DOMAIN_ID`` (default 0),
so two robots' graphs on one machine stay apart as they do in ROS 2. A peer's socket is
``<name>.<pid>.<n>.sock``; a socket whose owner died (SIGKILL, power cut) refuses
connections and is removed by the next peer that tries it.

>>> socket_name('bear driver', 42, 0)
'bear_driver.42.0.sock'
>>> domain_id({'ROS_DOMAIN_ID': '7'})
7
"""

from __future__ import annotations

import contextlib
import errno
import os
import re
import socket
import stat
from collections.abc import Mapping
from pathlib import Path

from ..errors import GraphError

__all__ = ['MAX_SOCKET_PATH', 'base_directory', 'connect_or_clean', 'domain_directory', 'domain_id', 'list_sockets',
           'socket_name']

#: sockaddr_un.sun_path holds 108 bytes on Linux, including the terminating NUL.
MAX_SOCKET_PATH = 107
_UNSAFE = re.compile(r'[^A-Za-z0-9_-]+')


def domain_id(environ: Mapping[str, str] | None = None) -> int:
    """``ROS_DOMAIN_ID`` as an int (0 when unset or empty).

    Raises:
        GraphError: when it is set to something other than a non-negative integer.
    """
    env = os.environ if environ is None else environ
    text = env.get('ROS_DOMAIN_ID', '').strip()
    if not text:
        return 0
    if not text.isdigit():
        raise GraphError(f"ROS_DOMAIN_ID must be a non-negative integer, got {text!r}; unset it or use e.g. 0")
    return int(text)


def base_directory(environ: Mapping[str, str] | None = None) -> Path:
    """The per-user directory holding one subdirectory per domain."""
    env = os.environ if environ is None else environ
    if env.get('SOCIAL_TOUCH_GRAPH_DIR'):
        return Path(env['SOCIAL_TOUCH_GRAPH_DIR'])
    if env.get('XDG_RUNTIME_DIR'):
        return Path(env['XDG_RUNTIME_DIR']) / 'social_touch'
    return Path('/tmp') / f'social_touch-{os.getuid()}'


def domain_directory(directory: str | os.PathLike | None = None, domain: int | None = None,
                     create: bool = True) -> Path:
    """The directory of ``domain``'s sockets (created with mode 0700 when ``create``).

    Args:
        directory: the base directory (default :func:`base_directory`).
        domain: the domain id (default :func:`domain_id`).
    """
    base = Path(directory) if directory is not None else base_directory()
    path = base / str(domain_id() if domain is None else domain)
    if create:
        path.mkdir(mode=0o700, parents=True, exist_ok=True)
    return path


def socket_name(name: str, pid: int, serial: int) -> str:
    """The socket file name of a peer: readable, unique per process and bridge."""
    return f'{_UNSAFE.sub("_", name) or "peer"}.{pid}.{serial}.sock'


def list_sockets(path: Path) -> list[Path]:
    """The peer sockets in a domain directory, oldest first (stable order for tests and logs)."""
    try:
        entries = [p for p in path.iterdir() if p.name.endswith('.sock')]
    except FileNotFoundError:
        return []
    out = []
    for entry in entries:
        try:
            info = entry.lstat()
        except FileNotFoundError:
            continue  # removed while we looked
        if stat.S_ISSOCK(info.st_mode):
            out.append((info.st_mtime_ns, entry.name, entry))
    return [entry for _, _, entry in sorted(out)]


def connect_or_clean(path: Path, timeout_s: float = 2.0) -> socket.socket | None:
    """A connected socket to the peer at ``path``, or None when nobody listens there.

    A socket file nobody listens on (its process died) is removed, so stale files do not
    pile up. Other errors (permissions) propagate as GraphError.
    """
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.settimeout(timeout_s)
    try:
        sock.connect(str(path))
    except (ConnectionRefusedError, FileNotFoundError):
        sock.close()
        with contextlib.suppress(FileNotFoundError):
            path.unlink()
        return None
    except TimeoutError:
        sock.close()
        return None  # a live but stuck peer: skip it rather than remove its socket
    except OSError as err:
        sock.close()
        if err.errno in (errno.ECONNREFUSED, errno.ENOENT):
            return None
        raise GraphError(f'cannot connect to graph peer {path}: {err}') from err
    sock.setblocking(False)
    return sock
