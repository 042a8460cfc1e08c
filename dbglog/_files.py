"""Files dbglog creates (recordings, snapshots, CSV exports, screenshots): 0666 & ~umask, never half-written.

A new file is written under a temporary name in the target's folder, created with mode 0666 so that the
kernel applies the user's umask as it does for ``open(path, "w")`` (``tempfile.mkstemp`` makes 0600
files), then renamed onto the target: a failure at any step removes the temporary file and leaves an
existing target as it was. Without ``replace`` an existing target is never overwritten, also when it
appears while the file is written (the rename is a hard link, which fails on an existing name).

Pure standard library; no ROS.
"""

from __future__ import annotations

import contextlib
import errno
import os
import secrets
from collections.abc import Callable
from pathlib import Path

__all__ = ["TEMP_MARK", "create_temp", "discard_temp", "put_in_place", "write_new_file"]

TEMP_MARK = ".dbglog-part-"
"""In the name of a file being written: ``.NAME.dbglog-part-XXXXXXXX[.suffix]``."""

_NO_LINKS = {errno.EPERM, errno.EOPNOTSUPP, errno.ENOSYS, errno.EXDEV, errno.EMLINK}
"""Errors of ``link`` on filesystems without hard links (FAT, some network and FUSE filesystems)."""


def create_temp(path: str | os.PathLike[str]) -> tuple[int, Path]:
    """Create an empty file beside `path` to be renamed onto it; return its descriptor and its path.

    Its mode is 0666 less the umask (as any new file's); it keeps `path`'s suffix (``.png`` stays last).

    Raises:
        OSError: the folder does not exist or cannot be written.
    """
    target = Path(path)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC | os.O_NOFOLLOW
    while True:
        tmp = target.with_name(f".{target.name}{TEMP_MARK}{secrets.token_hex(4)}{target.suffix}")
        try:
            return os.open(tmp, flags, 0o666), tmp  # the kernel applies the umask
        except FileExistsError:  # another writer drew the same name: draw again
            continue


def put_in_place(tmp: Path, path: str | os.PathLike[str], *, replace: bool) -> None:
    """Rename the finished `tmp` onto `path` in one step.

    Args:
        tmp: a file from `create_temp` for `path`.
        path: the target.
        replace: replace an existing target; otherwise an existing one is left alone.

    Raises:
        FileExistsError: `path` exists and `replace` is False (`tmp` is left for the caller to discard).
        OSError: the rename failed.
    """
    if replace:
        os.replace(tmp, path)
        return
    try:
        os.link(tmp, path)  # fails on an existing name, atomically
    except OSError as exc:
        if exc.errno not in _NO_LINKS:
            raise
        if os.path.lexists(path):
            raise FileExistsError(errno.EEXIST, "File exists", os.fspath(path)) from None
        os.rename(tmp, path)
        return
    os.unlink(tmp)


def discard_temp(tmp: Path) -> None:
    """Remove a temporary file that will not be put in place (gone already: nothing to do)."""
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def write_new_file(
    path: str | os.PathLike[str], write: Callable[[Path], None], *, replace: bool = False
) -> None:
    """Create `path` whole or not at all: `write` fills a temporary file beside it, which is then renamed.

    Args:
        path: the file to create.
        write: called with the temporary file's path (it exists, empty, with the mode the file gets).
        replace: replace an existing `path`; otherwise FileExistsError and `path` is left alone.

    Raises:
        FileExistsError: `path` exists and `replace` is False.
        OSError: the file cannot be created or written; whatever `write` raises (the temporary file is
            removed in every case).
    """
    fd, tmp = create_temp(path)
    os.close(fd)
    try:
        write(tmp)
        put_in_place(tmp, path, replace=replace)
    finally:
        discard_temp(tmp)
