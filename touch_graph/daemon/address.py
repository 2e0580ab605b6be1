"""Where the graph daemon of this domain and discovery setting listens, and the code version it must have."""

from __future__ import annotations

import hashlib
import os
import stat
import sys
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

from ..dds.config import domain_id, read_discovery
from ..errors import GraphError

__all__ = ['DaemonAddress', 'code_version', 'daemon_address', 'is_older', 'runtime_dir']

#: The package whose files make the code version (what a daemon runs).
_PACKAGE_DIR = Path(__file__).resolve().parent.parent


@dataclass(frozen=True)
class DaemonAddress:
    """The daemon of one domain and discovery setting: its socket, its lock, what it is for."""

    domain_id: int
    discovery_range: str
    socket_path: Path
    lock_path: Path


def runtime_dir(environ: Mapping[str, str] | None = None) -> Path:
    """``$XDG_RUNTIME_DIR/social-touch`` (else ``/tmp/social-touch-<uid>``), made 0700 and checked to be ours.

    Raises:
        GraphError: the directory belongs to another user or others may enter it.
    """
    env = os.environ if environ is None else environ
    base = env.get('XDG_RUNTIME_DIR')
    path = Path(base) / 'social-touch' if base else Path('/tmp') / f'social-touch-{os.getuid()}'
    path.mkdir(mode=0o700, exist_ok=True)
    info = path.stat()
    if info.st_uid != os.getuid() or stat.S_IMODE(info.st_mode) & 0o077:
        raise GraphError(f'{path} belongs to another user or others may enter it; the graph daemon needs it to be '
                         'yours alone (chmod 700, or remove it)')
    return path


def daemon_address(environ: Mapping[str, str] | None = None) -> DaemonAddress:
    """The daemon for the domain and discovery setting of ``environ`` (default ``os.environ``)."""
    env = os.environ if environ is None else environ
    domain = domain_id(env)
    options = read_discovery(env)
    old_gids = env.get('ROS_DISTRO', '').strip().lower()  # the GID layout follows it (discovery.gid_size)
    setting = '\n'.join([options.range, *options.static_peers, env.get('CYCLONEDDS_URI', ''), old_gids])
    digest = hashlib.sha1(setting.encode()).hexdigest()[:8]
    stem = f'domain-{domain}-{options.range.lower()}-{digest}'
    where = runtime_dir(env)
    return DaemonAddress(domain, options.range, where / f'{stem}.sock', where / f'{stem}.lock')


def code_version() -> str:
    """The installation a daemon runs: ``<newest file time, ns>-<digest>`` of its environment (``sys.prefix``) and
    the size and time of each file of ``touch_graph``.

    A client that finds a daemon of an older installation makes it leave and starts its own (ros2cli compares the
    RMW implementation in the same way); :func:`is_older` orders two versions.
    """
    digest = hashlib.sha1(f'{sys.prefix}\n'.encode())
    newest = 0
    for path in sorted(_PACKAGE_DIR.rglob('*.py')):
        info = path.stat()
        newest = max(newest, info.st_mtime_ns)
        digest.update(f'{path}:{info.st_size}:{info.st_mtime_ns}\n'.encode())
    return f'{newest}-{digest.hexdigest()[:12]}'


def is_older(version: str, than: str) -> bool:
    """Whether installation ``version`` is not newer than ``than`` (and not the same): its newest file is as old
    or older. Unreadable versions count as older.

    >>> is_older('100-aa', '200-bb'), is_older('200-aa', '100-bb'), is_older('100-aa', '100-bb'), is_older('x', '1-a')
    (True, False, True, True)
    """
    if version == than:
        return False
    try:
        return int(version.split('-', 1)[0]) <= int(than.split('-', 1)[0])
    except ValueError:
        return True
