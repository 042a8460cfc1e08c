"""The viewer's frame loop: a frame's steps in order, its pacing (`Pacer`), rendering, the input that wakes
it, and screenshots. What a frame does is the window's (`FrameSteps`); when and how it renders is this.
"""

from __future__ import annotations

import collections
import ctypes
import os
import sys
import time
from pathlib import Path
from typing import Protocol

import dearpygui.dearpygui as dpg

from dbglog._files import write_new_file
from dbglog.viewer._ui._pacing import (
    DEFAULT_DATA_FPS,
    DEFAULT_FPS,
    DIALOG_IDLE_RENDER_S,
    IDLE_RENDER_S,
    Pacer,
    XInput,
    wait_readable,
    x_connection_fd,
)
from dbglog.viewer._widgets._plotlines import LINE_WORKER

__all__ = ["SETTLE_FRAMES", "FrameLoop", "FrameSteps", "keep_freed_memory"]

SETTLE_FRAMES = 3
"""Frames rendered before a screenshot is captured, so that the last update is fully on screen."""


def keep_freed_memory() -> bool:
    """Let glibc keep freed heap memory between frames instead of returning it to the OS; True if done.

    The GL driver allocates and frees megabytes of vertex data every frame. With glibc's defaults the top
    of the heap is trimmed each time and every page is faulted in again on the next frame: about a tenth
    of a frame's CPU with Mesa's software renderer. Kept memory is reused, so it never grows past the peak.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    m_trim_threshold, m_top_pad, m_mmap_threshold = -1, -2, -3
    results = [
        mallopt(m_trim_threshold, 64 << 20),
        mallopt(m_top_pad, 16 << 20),
        mallopt(m_mmap_threshold, 32 << 20),
    ]
    return all(r == 1 for r in results)


class FrameSteps(Protocol):
    """What a frame of the window does (the window's side of the loop)."""

    def look(self) -> bool:
        """Between frames, drawing nothing: run the hooks; whether anything on screen would change."""
        ...

    def work(self) -> None:
        """A frame's work before rendering: input, snapshots, widget updates, dialogs, chrome."""
        ...

    def view_state(self) -> tuple[object, ...]:
        """What, when it changes, means the user is at work (widgets, selection, dialogs, drags, the file)."""
        ...

    def dragging(self) -> bool:
        """Whether the user drags something (a frame at the cap however still the mouse is)."""
        ...

    def dialog_open(self) -> bool:
        """Whether a dialog is open (its text cursor blinks: idle frames come more often)."""
        ...

    def after_render(self) -> None:
        """After a rendered frame (what Dear ImGui saw of the keys in it)."""
        ...


class FrameLoop:
    """When and how the window renders: the frame cap, no frames while nothing changes, input wakes it.

    Args:
        steps: what a frame does.
        fps: the frame cap of `run` (which also skips frames while nothing changes).
        data_fps: how often `run` draws new data at most while the user does nothing.
    """

    def __init__(
        self, steps: FrameSteps, *, fps: float = DEFAULT_FPS, data_fps: float = DEFAULT_DATA_FPS
    ) -> None:
        self.steps = steps
        self.pacer = Pacer(fps, min(fps, data_fps))
        """When `run` renders: the frame cap, and no frames while nothing changes."""
        self.idle_render_s = IDLE_RENDER_S
        """Seconds between two frames while nothing changes and no dialog is open (a safety net)."""
        self.frame_times: collections.deque[float] = collections.deque(maxlen=600)
        self.render_starts: collections.deque[float] = collections.deque(maxlen=240)
        self.last_work_s = 0.0
        """Seconds the last frame spent before `render_dearpygui_frame` (input, snapshots, widget updates)."""
        self.rendered = 0
        """Frames rendered so far (the benchmark and the CPU test read this)."""
        self._x_fd: int | None = None
        self._x_input: XInput | None = None
        self._input_now = False
        """Whether the last rendered frame saw the user at work (`_input_seen`)."""
        self._mouse_seen: tuple[float, float] = (-1.0, -1.0)
        self._view_key: tuple[object, ...] = ()

    def listen_to_x(self) -> None:
        """Wait for the X connection's input between frames (once the viewport is shown)."""
        self._x_input = XInput.of_glfw(dpg.internal_dpg.__file__)
        self._x_fd = self._x_input.fd if self._x_input is not None else x_connection_fd()

    def frame(self) -> float:
        """Poll input, refresh changed widgets, render one frame; return the frame's duration in seconds."""
        t0 = time.perf_counter()
        self.look()
        self.work()
        self.last_work_s = time.perf_counter() - t0
        self.render(time.monotonic())
        elapsed = time.perf_counter() - t0
        self.frame_times.append(elapsed)
        return elapsed

    def run(self, *, seconds: float | None = None) -> None:
        """Render until the window closes (or for `seconds`), at most `fps` frames a second.

        A frame is rendered only when something changed (new data for a widget, an edit, a dialog), while
        the user is doing something (and for a second after), or now and then while idle; in between the
        loop sleeps, woken early by input on the X connection.

        Dear ImGui takes at most about one key event a frame (a key down, its character, its release:
        three frames a typed letter), so the keys GLFW read from X together are used over many frames, with
        nothing left on the X connection to wake the loop. Each key a frame uses keeps the loop at the cap
        (`note_key`): at 15 frames a second, a word typed at 60 ms a key had its last letters
        waiting 20 s for the idle frames before.
        """
        deadline = None if seconds is None else time.monotonic() + seconds
        pacer = self.pacer
        while dpg.is_dearpygui_running():
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                break
            t0 = time.perf_counter()
            self.look()
            if pacer.due(now):
                self.work()  # widgets take the newest data only for a frame that shows it
                self.last_work_s = time.perf_counter() - t0
                self.render(now)
                self.frame_times.append(time.perf_counter() - t0)
                if self._input_now:
                    pacer.poke(now)
            now = time.monotonic()
            wait = pacer.wait(now)
            if deadline is not None:
                wait = min(wait, max(0.0, deadline - now))
            if pacer.active(now):
                if wait > 0:
                    time.sleep(wait)
            elif (self._x_input is not None and self._x_input.pending()) or wait_readable(self._x_fd, wait):
                pacer.poke(time.monotonic())  # input for the window: render it at once, and keep up

    def note_key(self) -> None:
        """A frame used a key event (UI thread, `KeyBindings.after_frame`): Dear ImGui may hold more of them,
        with nothing left on the X connection to wake the loop, so it keeps rendering."""
        self.pacer.poke(time.monotonic())

    def look(self) -> None:
        """Between frames: run the hooks and see whether anything on screen would change (no drawing)."""
        if self.steps.look():
            self.pacer.request(time.monotonic())
        self._poke_if_view_changed()

    def work(self) -> None:
        """Everything of a frame but rendering (the steps' `work`), then the pacing it asks for."""
        self.steps.work()
        # With a dialog open a text cursor may blink: idle frames come more often then.
        self.pacer.idle_render_s = DIALOG_IDLE_RENDER_S if self.steps.dialog_open() else self.idle_render_s
        self._poke_if_view_changed()

    def _poke_if_view_changed(self) -> None:
        """The user's doing (or a dialog's) changed what the window shows: render at the cap for a while."""
        key = self.steps.view_state()
        if key != self._view_key:
            self._view_key = key
            self.pacer.poke(time.monotonic())

    def render(self, now: float) -> None:
        """Render one frame (what `work` prepared)."""
        self.render_starts.append(now)
        t0 = time.perf_counter()
        LINE_WORKER.start()  # plots' lines queued while the cursor moves: computed while this frame renders
        dpg.render_dearpygui_frame()
        self.rendered += 1
        self.pacer.rendered(now, time.perf_counter() - t0)
        self._input_now = self._input_seen()
        self.steps.after_render()

    def held(self, modifier: int) -> bool:
        """Whether a modifier key (Ctrl, Shift) is down now (the wheel: Shift scrolls sideways)."""
        return bool(dpg.is_key_down(modifier))

    def _input_seen(self) -> bool:
        """Whether the user moved the mouse or holds a button (checked after each rendered frame)."""
        pos = dpg.get_mouse_pos(local=False)
        mouse = (float(pos[0]), float(pos[1]))
        moved = mouse != self._mouse_seen
        self._mouse_seen = mouse
        held = any(
            dpg.is_mouse_button_down(b)
            for b in (dpg.mvMouseButton_Left, dpg.mvMouseButton_Right, dpg.mvMouseButton_Middle)
        )
        return moved or held or self.steps.dragging()

    def screenshot(self, path: str | os.PathLike[str], *, timeout: float = 10.0) -> Path:
        """Write a PNG of the window to `path` and return it.

        Raises:
            TimeoutError: the frame buffer was not written in time.
        """
        target = Path(path).resolve()
        target.parent.mkdir(parents=True, exist_ok=True)
        # Settle first: texture uploads (plugins may draw into dynamic textures) reach the screen a frame
        # late, and the capture reads the previous buffer; without this a fresh update can be missing.
        for _ in range(SETTLE_FRAMES):
            self.frame()

        def capture(tmp: Path) -> None:
            dpg.output_frame_buffer(file=str(tmp))
            deadline = time.monotonic() + timeout
            while time.monotonic() < deadline:
                self.frame()
                if tmp.stat().st_size > 0:
                    return
            raise TimeoutError(f"{target}: the window was not captured within {timeout:g} s")

        write_new_file(target, capture, replace=True)  # 0666 less the umask; a failure keeps the old file
        return target
