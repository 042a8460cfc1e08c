"""Fast DDS shared-memory segments left in /dev/shm by processes the suite killed, removed at its end.

A Fast DDS participant maps a segment ``fastrtps_<16 hex digits>`` (about 0.5 MB) and holds an exclusive
``flock`` on its lock file ``fastrtps_<…>_el`` while it lives; one killed outright (the suite kills robots
on purpose) leaves both behind, and nothing of Fast DDS removes them: about 70 MB per full run on a
developer's machine, run after run. A segment whose lock nobody holds has no owner any more. Only the
segments created during this run are touched (a robot's own leftovers are not the suite's to remove), and
the ports' segments (``fastrtps_port<n>``, reused by the next participant on that port) stay.

Fast DDS's own ``fastdds shm clean`` (in the wheels' ``bin/``) applies the same lock rule, but to every
segment and port of the machine and with no grace for a lock file a starting participant has just made
and not locked yet: run at the end of one suite while the other Python's suite still starts processes
(CI runs both side by side), it could remove a live participant's files. Hence these few lines.
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import re
import time
from pathlib import Path

__all__ = ["SHM", "dead_segments", "remove_dead_segments"]

SHM = Path("/dev/shm")
_SEGMENT = re.compile(r"fastrtps_[0-9a-f]{16}")
_SETTLED_S = 5.0
"""A lock file younger than this is left alone (its owner locks it right after creating it)."""


def _held(lock: Path) -> bool:
    """Whether a process holds the lock file's ``flock`` (or it cannot be told)."""
    try:
        fd = os.open(lock, os.O_RDONLY)
    except OSError:
        return True
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # releases the lock if it was taken
    return False


def dead_segments(since: float, folder: Path = SHM, *, settled_s: float = _SETTLED_S) -> list[Path]:
    """The participant segments in `folder` created since `since` (a wall-clock time), `settled_s` ago or
    more, whose owner is gone."""
    now = time.time()
    dead = []
    for lock in folder.glob("fastrtps_*_el"):
        segment = lock.with_name(lock.name.removesuffix("_el"))
        if not _SEGMENT.fullmatch(segment.name):
            continue
        try:
            made = lock.stat().st_mtime
        except OSError:
            continue
        if made >= since and now - made >= settled_s and not _held(lock):
            dead.append(segment)
    return sorted(dead)


def remove_dead_segments(since: float, folder: Path = SHM, *, settled_s: float = _SETTLED_S) -> int:
    """Remove the dead segments of `dead_segments` and their lock files; return how many."""
    removed = 0
    for segment in dead_segments(since, folder, settled_s=settled_s):
        for path in (segment, segment.with_name(f"{segment.name}_el")):
            with contextlib.suppress(FileNotFoundError):
                path.unlink()
        removed += 1
    return removed
