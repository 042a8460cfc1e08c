"""A time plot's axis as the user handles it: ImPlot's zoom and pan read back into the shared `TimeRange`.

ImPlot does the interaction (wheel zoom about the pointer, drag pan, box zoom); the plot reads its x limits
back every frame, and `AxisSync` turns a change it did not make into the user's gesture on the `TimeRange`
(`user_moved`): a pan holds the range, a wheel zoom while following keeps following with a new length, a
box zoom holds the box. Limits are pushed to ImPlot only when the range moved another way (a linked plot,
a reset, the cursor), for one frame, so ImPlot keeps its own input the rest of the time. Also: clock-time
ticks, the hover (where the pointer is over the plot area) and the value of a series at a time. Pure
maths, no Dear PyGui.
"""

from __future__ import annotations

import functools
import math
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from dbglog.viewer.widget_api import TimeRange

__all__ = [
    "FAR",
    "TICK_STEPS",
    "AxisSync",
    "HoverTracker",
    "Limits",
    "close",
    "is_zoom",
    "remap",
    "sample_at",
    "tick_format",
    "time_ticks",
    "user_moved",
    "zoom_about",
]

Limits = tuple[float, float]
"""An axis range: (minimum, maximum)."""

FAR = 100.0
"""A held range more than this many of its own lengths from the axis origin moves the origin to it: ImPlot
keeps axis limits as 32-bit floats, so x values stay small (relative to an origin) to keep their precision."""
ZOOM_TOL = 1e-3
"""A change of the axis length by more than this fraction is a zoom; less, a pan."""
TICK_STEPS = (
    *(0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5),
    *(1.0, 2.0, 5.0, 10.0, 15.0, 30.0),
    *(60.0, 120.0, 300.0, 600.0, 900.0, 1800.0),
    *(3600.0, 7200.0, 10800.0, 21600.0, 43200.0, 86400.0),
)
"""Round steps between clock ticks, in seconds."""
CHAR_PX = 7.5
"""About how wide a tick label's character is (the viewer's 15 px font), for spacing the ticks."""
TICK_GAP_PX = 20.0
"""Free pixels at least between two tick labels."""


def close(a: Limits, b: Limits) -> bool:
    """Whether two axis ranges are the same up to what 32-bit floats (ImPlot's) can tell apart."""
    span = max(abs(a[1] - a[0]), abs(b[1] - b[0]), 1e-9)
    scale = max(abs(a[0]), abs(a[1]), abs(b[0]), abs(b[1]), 1.0)
    tol = max(span * 1e-4, scale * 1e-6)
    return abs(a[0] - b[0]) <= tol and abs(a[1] - b[1]) <= tol


def is_zoom(before: Limits, after: Limits) -> bool:
    """Whether `before` to `after` changed the length (a zoom) rather than only moved it (a pan)."""
    old, new = before[1] - before[0], after[1] - after[0]
    return abs(new - old) > ZOOM_TOL * max(abs(old), 1e-12)


def zoom_about(view: Limits, anchor: float, factor: float) -> Limits:
    """Return `view` scaled by `factor` (< 1 zooms in) about `anchor`, which stays where it is on screen.

    ImPlot's wheel does this about the pointer, with its zoom rate 0.1: one notch in is
    ``factor = 1 - 0.1 / 1.2``, one notch out ``1.1``.
    """
    return (anchor - (anchor - view[0]) * factor, anchor + (view[1] - anchor) * factor)


def remap(x: float, before: Limits, after: Limits) -> float:
    """Return where the screen position of `x` under axis range `before` lies under `after`."""
    span = before[1] - before[0]
    fraction = (x - before[0]) / span if span else 0.0
    return after[0] + fraction * (after[1] - after[0])


def user_moved(
    rng: TimeRange, before: Limits, after: Limits, *, box: bool = False, extra: float = 0.0
) -> None:
    """Apply the user's change of a plot's time axis from `before` to `after` (source times) to `rng`.

    A box zoom (`box`) or any change of a held range holds the new range; a pan of a following range holds
    it too (it stops following); a wheel zoom of a following range keeps following, with the new length:
    the range stays at the newest data (the cursor, paused). `extra` is the fraction of the length a plot
    shows past the end while following (paused plots show a little past the cursor), not counted in it.
    """
    if box or not rng.following or not is_zoom(before, after):
        rng.hold(*after)
    else:
        rng.follow((after[1] - after[0]) / (1.0 + extra))


@dataclass
class AxisSync:
    """What a plot's ImPlot x axis holds, so that a change it did not make is known as the user's.

    Data are drawn at ``x = t - origin`` (source time less an origin near the range, for float32). After
    `place`, ImPlot shows `shown`; when `forcing`, the limits were pushed to ImPlot (locked while pushed)
    and must be let go (`release`) once a frame was drawn with them, or the user could not zoom or pan.
    """

    origin: float | None = None
    """The source time at x = 0 of what was drawn last."""
    shown: Limits | None = None
    """The x limits ImPlot holds (relative to `origin`), as pushed or as read back."""
    forcing: bool = False
    """The limits are pushed to ImPlot (`set_axis_limits`) and must be let go after the next frame."""
    forced_at: int = -1
    """The frame count when they were pushed: a later frame drew them."""

    def observe(self, actual: Limits) -> Limits | None:
        """Take the limits ImPlot reports; return the range the user moved to (source times) or None.

        None while limits are being pushed (ImPlot took no input then), and when nothing changed.
        """
        if self.forcing or self.shown is None or self.origin is None or close(actual, self.shown):
            return None
        self.shown = actual
        return (actual[0] + self.origin, actual[1] + self.origin)

    def before(self) -> Limits | None:
        """Return the range shown before the last change (source times), None before anything was placed."""
        if self.shown is None or self.origin is None:
            return None
        return (self.shown[0] + self.origin, self.shown[1] + self.origin)

    def place(self, window: Limits, anchor: float | None = None, *, frame: int = -1) -> Limits | None:
        """Show `window` (source times); return the x limits to push to ImPlot, or None when it has them.

        A following plot passes the end it follows as `anchor` (x = 0 there: the limits stay put while the
        data move, so ImPlot is not told anything as data arrive); a held one keeps its origin unless the
        range is `FAR` from it. `frame` is the frame count now (see `release`).
        """
        start, end = window
        span = max(end - start, 1e-9)
        origin = self.origin
        if anchor is not None:
            origin = anchor
        elif origin is None or max(abs(start - origin), abs(end - origin)) > FAR * span:
            origin = end
        limits = (start - origin, end - origin)
        self.origin = origin
        if self.shown is not None and close(limits, self.shown):
            return None  # the data move (a new origin), the axis stays: ImPlot keeps its own input
        self.shown = limits
        self.forcing, self.forced_at = True, frame
        return limits

    def due(self, frame: int) -> bool:
        """Whether limits pushed at an earlier frame were drawn by now (frame counts) and can be let go."""
        return self.forcing and frame > self.forced_at

    def release(self, frame: int) -> bool:
        """Stop pushing the limits if a frame was drawn with them since (`due`); return whether it did."""
        if not self.due(frame):
            return False
        self.forcing = False
        return True


class HoverTracker:
    """Where over its plot area the pointer is, from what Dear PyGui reports once per frame.

    Dear PyGui reports the pointer over the whole plot item (axes and labels included) and one plot
    position for all plots, written only while the pointer is over some plot area. So: over the item,
    a plot position that changed means the pointer is over the area; the pointer moved without it, it is
    over an axis; neither moved, nothing changed.
    """

    def __init__(self) -> None:
        self.frame = -1
        self.mouse: tuple[float, float] | None = None
        self.plot_pos: tuple[float, float] | None = None
        self.x: float | None = None
        """The pointer's x in plot coordinates while it is over the plot area, else None."""

    def see(
        self, frame: int, hovered: bool, mouse: tuple[float, float], plot_pos: tuple[float, float]
    ) -> float | None:
        """Take one frame's report (counted once per frame) and return `x`."""
        if frame == self.frame:
            return self.x
        self.frame = frame
        if not hovered:
            self.x = None
        elif plot_pos != self.plot_pos:
            self.x = plot_pos[0]
        elif mouse != self.mouse:
            self.x = None
        self.mouse, self.plot_pos = mouse, plot_pos
        return self.x


def sample_at(
    times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], t: float
) -> tuple[float, float] | None:
    """Return a series' state at time `t`: its last sample at or before `t`, as (time, value); None before
    the first. (A line between two sparse samples is not a value the robot sent: the last sample is.)"""
    n = min(len(times), len(values))
    i = int(np.searchsorted(times[:n], t, side="right")) - 1
    if i < 0:
        return None
    return float(times[i]), float(values[i])


def tick_format(step: float) -> tuple[str, int]:
    """Return the clock format of ticks `step` seconds apart (`strftime`, then how many decimals)."""
    if step >= 86400:
        return "%d %b", 0
    if step >= 60:
        return "%H:%M", 0
    if step >= 1:
        return "%H:%M:%S", 0
    return "%M:%S", 3 if step < 0.01 else (2 if step < 0.1 else 1)


def _label_chars(step: float) -> int:
    fmt, decimals = tick_format(step)
    return len(time.strftime(fmt, time.gmtime(0))) + (decimals + 1 if decimals else 0)


_LABEL_CHARS = tuple(_label_chars(step) for step in TICK_STEPS)
"""How long the labels of each step are (characters)."""


def time_ticks(
    start: float, end: float, width_px: float, *, offset: float | None = None
) -> list[tuple[float, str]]:
    """Return clock-time ticks for the source times [start, end] on an axis `width_px` wide: (time, label).

    The step is the smallest round one (`TICK_STEPS`) whose labels fit side by side; labels say as much
    of the local clock as the step needs (``12:03``, ``12:03:05``, ``03:05.25``); a tick whose centred
    label would stick out of the axis is left out. `offset` is the local time's offset from UTC in seconds
    (default: the machine's, at `start`).
    """
    span = end - start
    if not (math.isfinite(span) and span > 0 and width_px > 0):
        return []
    if offset is None:
        offset = _utc_offset(int(max(0.0, start)) // 900)
    step, chars = TICK_STEPS[-1], _LABEL_CHARS[-1]
    for candidate, n in zip(TICK_STEPS, _LABEL_CHARS, strict=True):
        if span / candidate * (n * CHAR_PX + TICK_GAP_PX) <= width_px:
            step, chars = candidate, n
            break
    fmt, decimals = tick_format(step)
    half = chars * CHAR_PX / 2 / width_px * span  # half a label, in seconds
    step_ms = round(step * 1000)
    first = math.ceil((start + half + offset) * 1000 / step_ms)
    last = math.floor((end - half + offset) * 1000 / step_ms)
    ticks: list[tuple[float, str]] = []
    for k in range(first, min(last, first + 200) + 1):
        at_ms = k * step_ms
        ticks.append((at_ms / 1000 - offset, _tick_label(at_ms, fmt, decimals)))
    return ticks


@functools.lru_cache(maxsize=4096)
def _tick_label(at_ms: int, fmt: str, decimals: int) -> str:
    """A tick's label (kept: following, the same ticks are labelled at every frame as they scroll by)."""
    whole, ms = divmod(at_ms, 1000)
    label = time.strftime(fmt, time.gmtime(whole))
    return label + f".{ms:03d}"[: decimals + 1] if decimals else label


@functools.lru_cache(maxsize=64)
def _utc_offset(quarter_hour: int) -> float:
    """The local time's offset from UTC during a quarter of an hour (numbered since the epoch)."""
    return float(time.localtime(quarter_hour * 900).tm_gmtoff)
