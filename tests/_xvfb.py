"""An X display for GUI tests that talk to a window system: the caller's, or a private Xvfb."""

from __future__ import annotations

import os
import subprocess
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["x_display"]


@contextmanager
def x_display(*, private: bool = False) -> Iterator[str]:
    """Yield a display name: ``$DISPLAY`` when set (and not `private`), else a private Xvfb started here.

    The private server runs with ``-noreset``: by default an X server resets when its last client
    disconnects, and a connection opened during that reset is refused ("cannot open display"). A test
    connecting right after the previous test's viewer and connection had closed met that once in CI.
    """
    if os.environ.get("DISPLAY") and not private:
        yield os.environ["DISPLAY"]
        return
    read, write = os.pipe()
    xvfb = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", "1920x1080x24", "-nolisten", "tcp", "-noreset"],
        pass_fds=(write,),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )
    os.close(write)
    with os.fdopen(read) as f:
        number = f.readline().strip()
    assert number, "Xvfb did not start"
    try:
        yield f":{number}"
    finally:
        xvfb.terminate()
        xvfb.wait(10)
