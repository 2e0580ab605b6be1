"""Files written whole or not at all (:func:`replacing`: a temporary file beside the target, fsynced, renamed
over it), and :class:`DiskFullError`, naming the file and what was kept, for ``ENOSPC`` or ``EDQUOT``.

>>> import tempfile, pathlib
>>> target = pathlib.Path(tempfile.mkdtemp()) / 'report.md'
>>> write_text(target, 'one\\n')
>>> target.read_text()
'one\\n'
"""

from __future__ import annotations

import contextlib
import errno
import os
from collections.abc import Iterator
from pathlib import Path

from .errors import SocialTouchError

__all__ = ['DiskFullError', 'disk_full_error', 'is_disk_full', 'replacing', 'write_text']


class DiskFullError(SocialTouchError):
    """No space left on the disk of a file being written; the file's previous content is kept.

    Attributes:
        errno: the OS error number (``errno.ENOSPC`` or ``errno.EDQUOT``).
    """

    def __init__(self, number: int, message: str) -> None:
        super().__init__(message)
        self.errno = number


def is_disk_full(err: BaseException) -> bool:
    """Is ``err`` the OS saying the disk (or the user's quota) is full?"""
    return isinstance(err, OSError) and err.errno in (errno.ENOSPC, errno.EDQUOT)


def disk_full_error(path: Path, err: OSError, kept: str = '') -> DiskFullError:
    """A :class:`DiskFullError` for ``path``: the OS error's name, what was kept, what to do."""
    name = errno.errorcode.get(err.errno or errno.ENOSPC, 'ENOSPC')
    kept = kept or (f'the previous {path.name} is unchanged' if path.exists() else f'no {path.name} was written')
    return DiskFullError(err.errno or errno.ENOSPC, f'{name}: no space left on the disk to write {path}; {kept} '
                         '(nothing half-written is left). Free some space, or write to another disk (-o/--output), '
                         'and run the command again')


@contextlib.contextmanager
def replacing(path: str | os.PathLike) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix) to write; renamed over ``path`` when the block ends.

    On any exception the temporary file is removed and ``path`` is left as it was; a full disk is
    raised as :class:`DiskFullError`.
    """
    path = Path(path)
    tmp = path.with_name(f'.{path.stem}.{os.getpid()}.tmp{path.suffix}')
    try:
        yield tmp
        with open(tmp, 'rb+') as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as err:
        with contextlib.suppress(OSError):
            tmp.unlink()
        if is_disk_full(err) and not isinstance(err, DiskFullError):
            raise disk_full_error(path, err) from err
        raise


def write_text(path: str | os.PathLike, text: str, encoding: str = 'utf-8') -> None:
    """Write ``text`` to ``path`` whole or not at all (see :func:`replacing`)."""
    with replacing(path) as tmp:
        tmp.write_text(text, encoding=encoding)
