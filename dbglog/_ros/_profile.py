"""The Fast DDS profile of dbglog's own command processes: discovery writers that send from their own thread.

Fast DDS 2.14 (ROS 2 Jazzy) sends a new participant's first announcement from the thread that creates the
participant, and registers the receivers that take the answers only after it. A participant already
running answers that announcement at once, and only once (later copies of the same announcement are
ignored), so when its answer came back before the receivers were registered it was dropped, and the
newcomer found that participant only at its next periodic announcement, every 3 s: a viewer, ``dbglog
tags`` or a recorder missed a running robot for up to 3 s, one run in two on a loaded machine. The profile
(``discovery.xml``) gives the participant a throughput controller, which makes its discovery writers send
from the flow controller's thread: the creating thread registers the receivers meanwhile. Its log section
sends Fast DDS's warnings and errors to stderr, so a command's stdout stays its own when piped.

A Fast DDS profile is the default of every participant of the process, so it is used only by a process
that `claim`\\ s it (the ``dbglog`` commands, never ``dbglog run``'s program, the SDK or an agent in a
robot's process), only for its first participant (Fast DDS reads its profiles then, once), and never when
the user configured Fast DDS with a file of their own. The variable naming it is set only while that
participant is created, so child processes never inherit it. Fast DDS 3 reads another variable and never
sees it.
"""

from __future__ import annotations

import contextlib
import os
import threading
from collections.abc import Iterator, Mapping
from pathlib import Path

__all__ = ["ENV", "PROFILE", "claim", "claimed", "first_participant", "user_configuration"]

ENV = "FASTRTPS_DEFAULT_PROFILES_FILE"
"""The variable Fast DDS 2.x reads its default profiles file from when it creates its first participant."""
PROFILE = Path(__file__).with_name("discovery.xml")
_USER_VARIABLES = (ENV, "FASTDDS_DEFAULT_PROFILES_FILE")
"""Set by the user: their own profiles file (Fast DDS 2.x, 3.x)."""
_USER_FILES = ("DEFAULT_FASTRTPS_PROFILES.xml", "DEFAULT_FASTDDS_PROFILES.xml")
"""Fast DDS also loads a file of this name from the working directory."""


class _Process:
    """Whether this process claimed the profile, and whether its first participant was created since."""

    def __init__(self) -> None:
        self.lock = threading.Lock()
        self.claimed = False
        self.done = False


_PROCESS = _Process()


def claim() -> None:
    """Mark this process as one of dbglog's own: its first participant gets the discovery profile."""
    with _PROCESS.lock:
        _PROCESS.claimed = True


def claimed() -> bool:
    """True once this process claimed the discovery profile."""
    return _PROCESS.claimed


def user_configuration(environ: Mapping[str, str] | None = None, cwd: Path | None = None) -> str | None:
    """Return what configures Fast DDS with the user's own profiles (a variable or a file), None if nothing.

    Args:
        environ: the environment (the process's by default).
        cwd: the working directory Fast DDS looks in (the process's by default).
    """
    env = os.environ if environ is None else environ
    for name in _USER_VARIABLES:
        if name in env:
            return name
    folder = Path.cwd() if cwd is None else cwd
    for name in _USER_FILES:
        if (folder / name).exists():
            return str(folder / name)
    return None


@contextlib.contextmanager
def first_participant() -> Iterator[bool]:
    """Around the creation of a ROS node: yield True when this is the process's first and gets the profile.

    Only in a process that claimed it, once, and not when the user configured Fast DDS themselves.
    ``rmw_fastrtps`` creates a context's participant with its first node, so this wraps both.
    """
    with _PROCESS.lock:
        use = _PROCESS.claimed and not _PROCESS.done and user_configuration() is None
        _PROCESS.done = _PROCESS.done or _PROCESS.claimed
        if use:  # held while the participant is created: no other dbglog node starts meanwhile
            os.environ[ENV] = str(PROFILE)
            try:
                yield True
            finally:
                os.environ.pop(ENV, None)
            return
    yield False
