"""When the viewer's render loop draws a frame: a frame-rate cap, and no redraws while nothing changes.

A frame costs 10-40 ms of CPU with a software renderer (Mesa llvmpipe), however little changed, so the
loop renders only when something did (new data for a widget, input, a dialog, an edit) and otherwise
waits: for input on the X connection (`XInput`), for new data (looked for every `idle_poll_s`), or for
the slow idle frame (`idle_render_s`) that keeps a text cursor blinking. No Dear PyGui calls here.
"""

from __future__ import annotations

import ctypes
import math
import os
import select
import socket
import stat
import time
from dataclasses import dataclass

from dbglog.viewer._ui._display import load_xlib

__all__ = [
    "CPU_WAIT_SHOWN",
    "DEFAULT_DATA_FPS",
    "DEFAULT_FPS",
    "DIALOG_IDLE_RENDER_S",
    "IDLE_RENDER_S",
    "Pacer",
    "XInput",
    "cpu_wait_text",
    "cpu_wait_tip",
    "wait_readable",
    "x_connection_fd",
]

DEFAULT_FPS = 60.0
"""The default frame cap (``dbglog view --fps``)."""
DEFAULT_DATA_FPS = 20.0
"""How often new data is drawn at most by default (``dbglog view --data-fps``)."""
IDLE_RENDER_S = 10.0
"""Seconds between two frames while nothing changes: a safety net, as input and new data wake the loop."""
DIALOG_IDLE_RENDER_S = 0.5
"""The same with a dialog open, whose text cursor blinks."""


CPU_WAIT_SHOWN = 0.25
"""From this share of its busy time spent waiting for a CPU, the status bar says so."""


def cpu_wait_text(share: float | None, background: bool) -> str:
    """The status bar's short note on the window's thread waiting for a CPU (`share` of the time it wanted
    one), or "" (`cpu_wait_tip` says it in full)."""
    if share is None or share < CPU_WAIT_SHOWN:
        return ""
    text = f"waits for CPU {100 * share:.0f} %"
    return f"{text} (--cpu normal)" if background else text


def cpu_wait_tip(share: float | None, background: bool) -> str:
    """The note of `cpu_wait_text` in full (the status bar's tooltip), or ""."""
    if share is None or share < CPU_WAIT_SHOWN:
        return ""
    text = f"The window waited for a CPU {100 * share:.0f} % of its busy time (the last 3 s): it draws late."
    if background:
        text += " It runs in the background, so the robot comes first; --cpu normal shares the CPUs fairly."
    return text


@dataclass
class Pacer:
    """Decides, from the monotonic clock, whether the loop renders now and how long it may wait.

    Args:
        fps: the frame cap while the user is at work; frames never start closer together than 1/fps.
        data_fps: how often new data is drawn at most while nobody touches anything (at most `fps`); and
            between two such frames the loop rests at least as long as the last frame took, so that
            showing live data never takes more than half the loop's time (a software renderer's frames
            can take 50 ms and more).
        active_s: after input, keep rendering at the cap this long (hover effects, tooltips, the frames
            Dear ImGui needs to settle after a click).
        idle_render_s: while idle, still render this often.
        idle_poll_s: while idle, look for new data this often (without rendering); while data flows,
            every 1/data_fps.
    """

    fps: float = DEFAULT_FPS
    data_fps: float = DEFAULT_DATA_FPS
    active_s: float = 1.0
    idle_render_s: float = IDLE_RENDER_S
    idle_poll_s: float = 0.1
    last_render: float = -math.inf
    active_until: float = -math.inf
    last_change: float = -math.inf
    last_took: float = 0.0
    """How long the last frame took to render, in seconds."""
    pending: bool = False
    """Something changed since the last frame: render it as soon as the caps allow."""

    def __post_init__(self) -> None:
        for name in ("fps", "data_fps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, not {value}")

    @property
    def period(self) -> float:
        """The shortest time between two frames."""
        return 1.0 / self.fps

    @property
    def data_period(self) -> float:
        """The shortest time between the starts of two frames that only show new data."""
        return max(self.period, 1.0 / self.data_fps, 2.0 * self.last_took)

    def poke(self, now: float) -> None:
        """The user did something: render at the cap for a while."""
        self.active_until = max(self.active_until, now + self.active_s)

    def request(self, now: float | None = None) -> None:
        """Something on screen changed (new data, a new status text): render a frame soon."""
        self.pending = True
        self.last_change = time.monotonic() if now is None else now

    def active(self, now: float) -> bool:
        """Whether the loop is rendering at the cap for the user (not idle)."""
        return now < self.active_until

    def due(self, now: float) -> bool:
        """Whether to render a frame now."""
        since = now - self.last_render
        if since < self.period:
            return False
        if self.active(now):
            return True
        return (self.pending and since >= self.data_period) or since >= self.idle_render_s

    def rendered(self, now: float, took: float = 0.0) -> None:
        """A frame was rendered at `now`, in `took` seconds."""
        self.last_render = now
        self.last_took = max(0.0, took)
        self.pending = False

    def wait(self, now: float) -> float:
        """Seconds the loop may sleep before it has anything to do."""
        if self.active(now):
            return max(0.0, self.last_render + self.period - now)
        if self.pending:
            return max(0.0, self.last_render + self.data_period - now)
        flowing = now - self.last_change < 1.0  # data keeps coming: look again when it may be drawn
        if flowing:  # past that moment, look again as often as data may be drawn (never spin)
            due_at = self.last_render + self.data_period
            return due_at - now if due_at > now else min(self.data_period, self.idle_poll_s)
        idle_frame = self.last_render + max(self.period, self.idle_render_s)
        return max(0.0, min(self.idle_poll_s, idle_frame - now))


class XInput:
    """The X connection GLFW reads the window's input from: its socket, and whether Xlib holds events.

    Events can reach Xlib's queue while a frame is drawn (the buffer swap reads from the socket), after
    GLFW polled: the socket is then quiet though input waits, so the loop asks Xlib too (`pending`).
    Call only from the thread that renders.
    """

    def __init__(self, display: int, fd: int, x11: ctypes.CDLL) -> None:
        self.display, self.fd, self._x11 = display, fd, x11

    @classmethod
    def of_glfw(cls, library: str) -> XInput | None:
        """The X connection of the GLFW linked into `library` (Dear PyGui's extension), or None (not X11)."""
        try:
            glfw = ctypes.CDLL(library)  # already loaded: the same GLFW, with its open display
            get_display = glfw.glfwGetX11Display
            x11 = load_xlib()
        except (OSError, AttributeError):
            return None
        get_display.restype, get_display.argtypes = ctypes.c_void_p, []
        x11.XEventsQueued.restype, x11.XEventsQueued.argtypes = ctypes.c_int, [ctypes.c_void_p, ctypes.c_int]
        x11.XConnectionNumber.restype, x11.XConnectionNumber.argtypes = ctypes.c_int, [ctypes.c_void_p]
        display = get_display()
        if not display:
            return None
        return cls(display, x11.XConnectionNumber(display), x11)

    def pending(self) -> bool:
        """Whether Xlib already holds events that GLFW has not taken (no I/O: QueuedAlready)."""
        return bool(self._x11.XEventsQueued(self.display, 0) > 0)


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
