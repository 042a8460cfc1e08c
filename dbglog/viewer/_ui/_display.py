"""Whether the X display the viewer's window needs can be opened, asked before Dear PyGui tries.

Dear PyGui's GLFW aborts the process (an assertion, SIGABRT, a core dump) when it cannot open the display,
after printing only "Glfw Error 65544". The viewer asks Xlib first, the same way GLFW will, and says what
is wrong in words instead.
"""

from __future__ import annotations

import ctypes
import ctypes.util
import time

__all__ = ["load_xlib", "x_display_problem"]


def load_xlib() -> ctypes.CDLL:
    """Return Xlib (the libX11 GLFW links to; loading it again gives the same library).

    Raises:
        OSError: no libX11 here.
    """
    return ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")


def x_display_problem(
    name: str | None, *, wayland: bool = False, attempts: int = 3, pause: float = 0.2
) -> str | None:
    """Return why the X display `name` (``$DISPLAY``) cannot be opened, or None when it can.

    An X server that is starting, or busy accepting many clients at once, may refuse a connection for a
    moment: the display is tried `attempts` times, `pause` seconds apart, before it is called unusable.
    `wayland` says whether ``WAYLAND_DISPLAY`` is set (the window is an X11 one: it needs XWayland).
    """
    name = (name or "").strip()
    if not name:
        if wayland:
            return (
                "DISPLAY is not set: the viewer's window is an X11 window, and only WAYLAND_DISPLAY is set "
                "(start XWayland, or set DISPLAY to its display)"
            )
        return "no display: DISPLAY is not set"
    try:
        x11 = load_xlib()
    except OSError:
        return None  # no Xlib to ask: GLFW finds out for itself
    x11.XOpenDisplay.restype, x11.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x11.XCloseDisplay.restype, x11.XCloseDisplay.argtypes = ctypes.c_int, [ctypes.c_void_p]
    for attempt in range(max(1, attempts)):
        if attempt:
            time.sleep(pause)
        display = x11.XOpenDisplay(name.encode(errors="replace"))
        if display:
            x11.XCloseDisplay(display)
            return None
    return (
        f"cannot open the X display DISPLAY={name!r}: no X server answers there, "
        "or it does not let this user connect (XAUTHORITY)"
    )
