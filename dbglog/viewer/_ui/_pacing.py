"""When the viewer's render loop draws a frame: a frame-rate cap, and no redraws while nothing changes.

A frame costs 10-40 ms of CPU with a software renderer (Mesa llvmpipe), however little changed, so the
loop renders only when something did (new data for a widget, input, a dialog, an edit) and otherwise
waits: for the X connection to have input, for new data (looked for every `idle_poll_s`), or for the
slow idle frame (`idle_render_s`) that keeps blinking cursors and late events going. No Dear PyGui here.
"""

from __future__ import annotations

import math
import os
import select
import socket
import stat
import time
from dataclasses import dataclass

__all__ = ["DEFAULT_FPS", "Pacer", "wait_readable", "x_connection_fd"]

DEFAULT_FPS = 60.0
"""The default frame cap (``dbglog view --fps``)."""


@dataclass
class Pacer:
    """Decides, from the monotonic clock, whether the loop renders now and how long it may wait.

    Args:
        fps: the frame cap; frames never start closer together than 1/fps.
        active_s: after input or a change, keep rendering at the cap this long (hover effects, tooltips,
            the frames Dear ImGui needs to settle after a click).
        idle_render_s: while idle, still render this often.
        idle_poll_s: while idle, look for new data this often (without rendering).
    """

    fps: float = DEFAULT_FPS
    active_s: float = 1.0
    idle_render_s: float = 0.5
    idle_poll_s: float = 0.05
    last_render: float = -math.inf
    active_until: float = -math.inf
    pending: bool = False
    """Something changed since the last frame: render it as soon as the cap allows."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be a positive number, not {self.fps}")

    @property
    def period(self) -> float:
        """The shortest time between two frames."""
        return 1.0 / self.fps

    def poke(self, now: float) -> None:
        """Something changed or the user did something: render at the cap for a while."""
        self.active_until = max(self.active_until, now + self.active_s)

    def request(self) -> None:
        """Something on screen changed (new data, a new status text): render one frame soon."""
        self.pending = True

    def active(self, now: float) -> bool:
        """Whether the loop is rendering at the cap (not idle)."""
        return now < self.active_until

    def due(self, now: float) -> bool:
        """Whether to render a frame now."""
        if now - self.last_render < self.period:
            return False
        return self.pending or self.active(now) or now - self.last_render >= self.idle_render_s

    def rendered(self, now: float) -> None:
        """A frame was rendered at `now`."""
        self.last_render = now
        self.pending = False

    def wait(self, now: float) -> float:
        """Seconds the loop may sleep before it has anything to do."""
        next_frame = self.last_render + self.period
        if self.pending or self.active(now):
            return max(0.0, next_frame - now)
        idle_frame = max(next_frame, self.last_render + self.idle_render_s)
        return max(0.0, min(self.idle_poll_s, idle_frame - now))


def x_connection_fd() -> int | None:
    """Return this process's connection to the X server (a socket whose peer is an X display), or None."""
    try:
        fds = sorted(int(name) for name in os.listdir("/proc/self/fd"))
    except OSError:  # no /proc: the loop falls back to its idle frames
        return None
    for fd in fds:
        try:
            if not stat.S_ISSOCK(os.fstat(fd).st_mode):
                continue
            sock = socket.socket(fileno=fd)
        except OSError:
            continue
        try:
            peer = sock.getpeername() if sock.family == socket.AF_UNIX else ""
        except OSError:
            peer = ""
        finally:
            sock.detach()  # the fd stays GLFW's
        if isinstance(peer, bytes):
            peer = peer.decode(errors="replace")
        if ".X11-unix/X" in str(peer):
            return fd
    return None


def wait_readable(fd: int | None, seconds: float) -> bool:
    """Sleep up to `seconds`; return True early when `fd` has data to read (input for the window)."""
    if seconds <= 0:
        return False
    if fd is None:
        time.sleep(seconds)
        return False
    try:
        readable, _, _ = select.select([fd], [], [], seconds)
    except (OSError, ValueError):
        time.sleep(seconds)
        return False
    return bool(readable)
