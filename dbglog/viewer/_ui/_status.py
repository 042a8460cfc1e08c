"""The status bar: on the left, dim, what the window shows (the CPU note, the replay, the dashboard, the
history held, the frame rate); then the last message."""

from __future__ import annotations

import collections
import time
from collections.abc import Callable
from typing import Protocol

import dearpygui.dearpygui as dpg

from dbglog._sched import CpuWaitMeter, cpu_times_ns, in_background
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._pacing import Pacer, cpu_wait_text
from dbglog.viewer._ui._time import TimeControl
from dbglog.viewer._ui._timescale import history_text

__all__ = ["FrameRate", "StatusBar"]


class FrameRate(Protocol):
    """What the status bar reads of the frame loop (its frame rate)."""

    render_starts: collections.deque[float]
    pacer: Pacer


class StatusBar:
    """The status bar of one window.

    Args:
        time: the window's time control (the replay shown, the history held).
        summary: what the dashboard is (its file, widgets, problems), most important first.
        frames: the frame loop (its frame rate).
    """

    def __init__(
        self, time_control: TimeControl, summary: Callable[[], list[str]], frames: FrameRate
    ) -> None:
        self.time, self.summary, self.frames = time_control, summary, frames
        self.text = ""
        """The last message (`say`), in full."""
        self.message: int | str = 0
        self.info: int | str = 0
        """The text item of what the window shows."""
        self._built = False
        self._shown_info = ""
        self._fps_text = ""
        self._fps_at = -1.0
        self._cpu_wait = CpuWaitMeter()
        self._cpu: tuple[float | None, bool] = (None, False)
        self._history_at = -1.0
        self._history_next = ""
        self._history_text = ""
        self._source_changes = 0

    def build(self) -> None:
        """Create the bar (a row of the window)."""
        with dpg.group(horizontal=True):
            self.info = dpg.add_text("", color=theme.DIM)
            self.message = dpg.add_text("")
        self._built = True

    def say(self, text: str) -> None:
        """Show a message."""
        self.text = text
        if self._built:
            dpg.set_value(self.message, text)

    # -- the right side -------------------------------------------------------------------------------

    def parts(self, now: float) -> list[str]:
        """What the window shows, most important first (figures refreshed twice a second)."""
        if now - self._fps_at >= 0.5 and self.frames.render_starts:
            self._fps_at = now
            starts = self.frames.render_starts
            recent = sum(1 for t in starts if t > now - 1.0)
            if now - starts[0] < 1.0:
                self._fps_text = ""  # not measured yet
            elif recent < 5 and not self.frames.pacer.active(now):
                self._fps_text = "idle"
            else:
                self._fps_text = f"{min(recent, 999)} fps"
            times = cpu_times_ns()  # (this is the window's thread: the one whose frames come late)
            share = None if times is None else self._cpu_wait.add(now, *times)
            self._cpu = (share, in_background())
        parts = []
        cpu = cpu_wait_text(*self._cpu)
        if cpu:  # first: it says why everything else comes late
            parts.append(cpu)
        replay = self.time.replay_name
        if replay is not None:
            loading = " (loading the rest\u2026)" if getattr(self.time.source, "loading", False) else ""
            parts.append(f"replay of {replay}{loading}")
        parts.extend(self.summary())
        self._history_text = self._history_status(now)
        if self._history_text:
            parts.append(self._history_text)
        if self._fps_text:
            parts.append(self._fps_text)
        return parts

    def _history_status(self, now: float) -> str:
        if self.time.source_changes != self._source_changes:
            self._source_changes, self._history_at = self.time.source_changes, -1.0
        if now - self._history_at >= 0.5:
            self._history_at = now
            stats = self.time.timeline.stats()
            if stats is None:
                self._history_next = ""
            else:
                span = None if stats.oldest is None or stats.newest is None else (stats.oldest, stats.newest)
                self._history_next = history_text(span, stats.bytes_used, stats.samples)
        return self._history_next

    def bar_moved(self, stale: Callable[[], bool]) -> bool:
        """Twice a second: whether the timeline bar (`stale`) or the history figures would show news."""
        now = time.monotonic()
        if self.time.source_changes == self._source_changes and now - self._history_at < 0.5:
            return False
        return stale() or self._history_status(now) != self._history_text

    def update(self) -> None:
        """Refresh the left side (content at once, figures twice a second; Dear PyGui told only changes)."""
        text = "  " + "   \u00b7   ".join(self.parts(time.monotonic())) + "   "
        if text != self._shown_info:
            self._shown_info = text
            dpg.set_value(self.info, text)
