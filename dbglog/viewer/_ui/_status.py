"""The status bar: the last message on the left, kept readable; on the right, dim, what the window shows
(the CPU note, the replay, the dashboard, the history held, the frame rate), shortened to fit."""

from __future__ import annotations

import collections
import time
from collections.abc import Callable, Sequence
from typing import Protocol

import dearpygui.dearpygui as dpg

from dbglog._sched import CpuWaitMeter, cpu_times_ns, in_background
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._pacing import Pacer, cpu_wait_text, cpu_wait_tip
from dbglog.viewer._ui._time import TimeControl
from dbglog.viewer._ui._timescale import history_text

__all__ = ["SEPARATOR", "FrameRate", "StatusBar", "fit_status"]

SEPARATOR = "   \u00b7   "
"""Between two parts of the status bar's right side."""
GAP = 24.0
"""Pixels kept at least between the message and the right side."""
PADDING = 2 * 10 + 2 * 8
"""The window's padding on both sides and the spacing between the bar's three items."""


def fit_status(
    message: str, parts: Sequence[str], width: float, measure: Callable[[str], float]
) -> tuple[str, str]:
    """Return the message and the right side that fit in `width` pixels together.

    The message comes first; the right side takes the parts that fit beside it, most important first (a
    long one, such as a file's path, is left out while shorter ones after it still show), in their order;
    a message too long even alone is cut, with an ellipsis.

    Args:
        message: the status message.
        parts: what the window shows, most important first.
        width: the bar's width in pixels.
        measure: a text's width in pixels.
    """
    used = measure(message)
    if used <= width:
        keep: list[str] = []
        for part in parts:
            if used + GAP + measure(SEPARATOR.join([*keep, part])) <= width:
                keep.append(part)
        return message, SEPARATOR.join(keep)
    lo, hi = 0, len(message)  # the longest head that fits with the ellipsis
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if measure(message[:mid].rstrip() + "\u2026") <= width:
            lo = mid
        else:
            hi = mid - 1
    return message[:lo].rstrip() + "\u2026", ""


def _rate_kind(text: str) -> str:
    """What a frame rate's text says, its number aside: "" (not measured yet), ``idle`` or ``fps``."""
    return text if text in ("", "idle") else "fps"


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
        """The right side's text item."""
        self._built = False
        self._shown: tuple[object, ...] = ()
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
            self.message = dpg.add_text("")
            self.gap = dpg.add_spacer(width=1)
            self.info = dpg.add_text("", color=theme.DIM)
        with dpg.tooltip(self.message, delay=0.4, show=False) as self.message_tooltip:
            self.message_tip = dpg.add_text("", wrap=600)
        with dpg.tooltip(self.info, delay=0.4):
            self.info_tip = dpg.add_text("", wrap=600)
            self.cpu_tip = dpg.add_text("", wrap=600, color=theme.DIM)
        self._built = True

    def say(self, text: str) -> None:
        """Show a message."""
        self.text = text

    # -- the right side -------------------------------------------------------------------------------

    def parts(self, now: float) -> list[str]:
        """What the right side shows, most important first (figures refreshed twice a second)."""
        if now - self._fps_at >= 0.5 and self.frames.render_starts:
            self._fps_at = now
            self._fps_text = self._fps_now(now)
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

    def _fps_now(self, now: float) -> str:
        """The frame rate over the last second, ``idle``, or "" (not measured yet: the first second)."""
        starts = self.frames.render_starts
        if not starts or now - starts[0] < 1.0:
            return ""
        recent = sum(1 for t in starts if t > now - 1.0)
        if recent < 5 and not self.frames.pacer.active(now):
            return "idle"
        return f"{min(recent, 999)} fps"

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
        """Twice a second: whether the timeline bar (`stale`), the history figures or the frame rate would
        show news (the rate once the window went idle, when no frame would show it)."""
        now = time.monotonic()
        if now - self._fps_at >= 0.5 and _rate_kind(self._fps_now(now)) != _rate_kind(self._fps_text):
            return True  # measured at last, or idle now (not a falling number: no frames for it)
        if self.time.source_changes == self._source_changes and now - self._history_at < 0.5:
            return False
        return stale() or self._history_status(now) != self._history_text

    def update(self, width: int) -> None:
        """Refresh the bar for a window `width` pixels wide (Dear PyGui is told only what changed)."""
        parts = self.parts(time.monotonic())
        key = (self.text, tuple(parts), width)
        if not self._built or key == self._shown:
            return
        self._shown = key
        room = max(0.0, width - PADDING)

        def measure(text: str) -> float:
            size = dpg.get_text_size(text) if text else (0.0, 0.0)
            if size is None:  # the font is not ready (the first frames): a guess, and again next frame
                self._shown = ()
                return len(text) * 8.0
            return float(size[0])

        message, info = fit_status(self.text, parts, room, measure)
        dpg.set_value(self.message, message)
        dpg.set_value(self.info, info)
        dpg.configure_item(self.gap, width=max(1, int(room - measure(message) - measure(info))))
        dpg.set_value(self.message_tip, self.text)
        dpg.configure_item(self.message_tooltip, show=message != self.text)  # the message cut: in full
        dpg.set_value(self.info_tip, "\n".join(parts))
        dpg.set_value(self.cpu_tip, cpu_wait_tip(*self._cpu))
