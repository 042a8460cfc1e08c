"""The timeline bar's maths: source time <-> pixels, round tick steps, and how times and sizes read.

Pure functions (no Dear PyGui), so the bar's layout is tested without a display; `_timebar` draws it.
Times are source times in epoch seconds, as the data source gives them.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "MIN_SPAN_S",
    "TICK_STEPS",
    "TimeScale",
    "event_columns",
    "format_ago",
    "format_bytes",
    "format_clock",
    "format_duration",
    "format_offset",
    "history_text",
    "label_left",
    "mark_runs",
    "tick_step",
]

MIN_SPAN_S = 1.0
"""The track shows at least this many seconds (a history of one sample still has a width)."""
TICK_STEPS: tuple[float, ...] = (
    1, 2, 5, 10, 15, 30,
    60, 120, 300, 600, 900, 1800,
    3600, 7200, 3 * 3600, 6 * 3600, 12 * 3600, 86400,
)  # fmt: skip
"""Tick spacings in seconds, round to a clock reader: 1 s ... 30 s, 1 min ... 30 min, 1 h ... 1 day."""


@dataclass(frozen=True, slots=True)
class TimeScale:
    """Maps source times between `oldest` and `newest` onto the pixels `x0`..`x1` of the track."""

    oldest: float
    newest: float
    x0: float
    x1: float

    @classmethod
    def of(cls, span: tuple[float, float], x0: float, x1: float) -> TimeScale:
        """Return the scale of a history span; a span shorter than `MIN_SPAN_S` is widened to the left."""
        oldest, newest = span
        return cls(min(oldest, newest - MIN_SPAN_S), newest, x0, max(x1, x0 + 1.0))

    @property
    def seconds(self) -> float:
        """How many seconds the track shows."""
        return self.newest - self.oldest

    def x_of(self, t: float) -> float:
        """Return the pixel of time `t` (clamped to the track)."""
        f = (t - self.oldest) / self.seconds
        return self.x0 + min(1.0, max(0.0, f)) * (self.x1 - self.x0)

    def t_of(self, x: float) -> float:
        """Return the time under pixel `x` (clamped to the span)."""
        f = (x - self.x0) / (self.x1 - self.x0)
        return self.oldest + min(1.0, max(0.0, f)) * self.seconds

    def ticks(self, min_px: float = 70.0) -> list[tuple[float, float]]:
        """Return (pixel, seconds before the newest) of round ticks at least `min_px` apart, newest first.

        Ticks sit at whole steps before the newest sample (``-1:00``, ``-2:00``, ...), so while live they
        keep their labels and only slide when the oldest end moves.
        """
        step = tick_step(self.seconds, self.x1 - self.x0, min_px)
        out = []
        k = 1
        while k * step <= self.seconds + 1e-9:
            out.append((self.x_of(self.newest - k * step), k * step))
            k += 1
        return out

    def ticks_from_start(self, min_px: float = 70.0) -> list[tuple[float, float]]:
        """Return (pixel, seconds after the oldest) of round ticks at least `min_px` apart, oldest first.

        A recording's track counts from its start (``0:10``, ``0:20``, ...), as a media player's does.
        """
        step = tick_step(self.seconds, self.x1 - self.x0, min_px)
        out = []
        k = 1
        while k * step <= self.seconds + 1e-9:
            out.append((self.x_of(self.oldest + k * step), k * step))
            k += 1
        return out


def tick_step(seconds: float, width_px: float, min_px: float = 70.0) -> float:
    """Return the smallest round step (`TICK_STEPS`) whose ticks on the track are `min_px` apart or more."""
    if seconds <= 0 or width_px <= 0:
        return TICK_STEPS[-1]
    px_per_s = width_px / seconds
    for step in TICK_STEPS:
        if step * px_per_s >= min_px:
            return step
    days = math.ceil(min_px / px_per_s / 86400)
    return days * 86400.0


def format_duration(seconds: float) -> str:
    """Return a length of time as a clock reads it: ``45 s``, ``5:12``, ``1:02:03``."""
    s = max(0, round(seconds))
    if s < 60:
        return f"{s} s"
    h, rest = divmod(s, 3600)
    m, sec = divmod(rest, 60)
    return f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"


def format_ago(seconds: float, *, precise: bool = False) -> str:
    """Return how long before the newest sample: ``now``, ``-2 s`` (precise: ``-2.0 s``), ``-5:12``.

    The minus is the typographic one (U+2212).
    """
    if seconds < (0.05 if precise else 0.5):
        return "now"
    if precise and seconds < 60:
        return f"\u2212{seconds:.1f} s"
    return "\u2212" + format_duration(seconds)


def format_offset(seconds: float, *, precise: bool = False) -> str:
    """Return a time into a recording as a media player shows it: ``0:07``, ``12:30``, ``1:02:03``.

    Precise adds tenths of a second (``0:07.4``), for the cursor.
    """
    s = max(0.0, seconds)
    whole = math.floor(s * 10 + 0.5) / 10 if precise else float(round(s))
    h, rest = divmod(int(whole), 3600)
    m, sec = divmod(rest, 60)
    text = f"{h}:{m:02d}:{sec:02d}" if h else f"{m}:{sec:02d}"
    if precise:
        text += f".{round((whole - int(whole)) * 10) % 10}"
    return text


def format_clock(t: float, *, millis: bool = True) -> str:
    """Return a source time as the local clock: ``12:03:04.512`` (or ``12:03:04``)."""
    if not millis:
        return time.strftime("%H:%M:%S", time.localtime(t))
    seconds, ms = divmod(round(t * 1000), 1000)
    return time.strftime("%H:%M:%S", time.localtime(seconds)) + f".{ms:03d}"


def format_bytes(n: float) -> str:
    """Return a size in bytes as ``512 B``, ``3.4 kB``, ``34.2 MB``, ``1.2 GB`` (powers of 1024)."""
    if n < 1024:
        return f"{int(n)} B"
    value = float(n)
    for unit in ("kB", "MB", "GB"):
        value /= 1024
        if value < 1024:
            return f"{value:.1f} {unit}"
    return f"{value / 1024:.1f} TB"


def history_text(span: tuple[float, float] | None, bytes_used: int | None, samples: int | None = None) -> str:
    """Return the status bar's history part: ``history 5:12 \u00b7 34.2 MB`` (empty without a history)."""
    if span is None and bytes_used is None:
        return ""
    parts = ["history " + (format_duration(span[1] - span[0]) if span is not None else "empty")]
    if samples is not None:
        parts.append(f"{samples:,} samples")
    if bytes_used is not None:
        parts.append(format_bytes(bytes_used))
    return " \u00b7 ".join(parts)


def label_left(center: float, width: float, lo: float, hi: float) -> float:
    """Return where a label `width` wide centred on `center` starts, kept within lo..hi."""
    left = center - width / 2
    return max(lo, min(left, hi - width))


def event_columns(
    times: npt.NDArray[np.float64], markers: npt.NDArray[np.bool_], scale: TimeScale
) -> list[tuple[int, bool]]:
    """(pixel, marker) for each pixel column of a timeline track that holds events at `times`, by pixel:
    however many there are, one mark a column, a user's marker (`markers`) before a parameter change."""
    if not len(times) or scale.seconds <= 0:
        return []
    keep = (times >= scale.oldest) & (times <= scale.newest)
    t, m = times[keep], markers[keep]
    if not len(t):
        return []
    x = np.round(scale.x0 + (t - scale.oldest) / scale.seconds * (scale.x1 - scale.x0)).astype(np.int64)
    order = np.lexsort((m, x))  # by column, then markers last: the last of a column says whether it has one
    xs, ms = x[order], m[order]
    last = np.append(xs[1:] != xs[:-1], True)
    return list(zip(xs[last].tolist(), ms[last].tolist(), strict=True))


def mark_runs(
    columns: npt.NDArray[np.intp], levels: npt.NDArray[np.uint8]
) -> tuple[tuple[int, int, int], ...]:
    """Adjacent marked pixel columns of one level as runs: (first pixel, last pixel, level), by pixel.

    `columns` are the marked columns in increasing order and `levels` the level of each; the timeline bar
    draws a run as one rectangle, however many columns it spans (a flood marks hundreds of them).
    """
    if not len(columns):
        return ()
    cut = np.flatnonzero((np.diff(columns) != 1) | (levels[1:] != levels[:-1])) + 1
    starts = np.concatenate(([0], cut))
    ends = np.concatenate((cut - 1, [len(columns) - 1]))
    firsts, lasts = columns[starts].tolist(), columns[ends].tolist()
    return tuple(zip(firsts, lasts, levels[starts].astype(int).tolist(), strict=True))
