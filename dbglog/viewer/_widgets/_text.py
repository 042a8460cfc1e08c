"""Text-like widgets: String (latest value and a scrolling history) and LED (on/off lamp)."""

from __future__ import annotations

import math
import time
from collections.abc import Sequence

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer._widgets._common import (
    DIM,
    TEXT,
    draw_centered_text,
    draw_disc,
    nonfinite_text,
    set_disc_color,
    text_size,
    value_at_cursor_only,
)
from dbglog.viewer._widgets._geometry import led_on
from dbglog.viewer.widget_api import Property, PropKind, SeriesSnapshot, ValueKind, Widget

__all__ = ["LedWidget", "StringWidget", "history_lines"]


def _stamp(t: float) -> str:
    lt = time.localtime(t)
    return time.strftime("%H:%M:%S", lt) + f".{int((t % 1) * 1000):03d}"


def _fmt(value: float) -> str:
    odd = nonfinite_text(value)
    return odd if odd is not None else f"{value:.6g}"


def history_lines(snap: SeriesSnapshot, limit: int, *, with_time: bool, collapse: bool = True) -> list[str]:
    """Return the newest `limit` history lines, newest first; a run of one repeated value is one line."""
    if snap.texts:
        texts = list(snap.texts)
        times = snap.times if len(snap.times) == len(texts) else None
        starts = [i for i in range(len(texts)) if i == 0 or not collapse or texts[i] != texts[i - 1]]
        runs = [(texts[i], i) for i in starts[-limit:]]
        total = len(texts)
    elif len(snap.values):
        values = snap.values
        if collapse:
            # Compare the numbers themselves (NaN == NaN here), not their formatted text.
            same = (values[1:] == values[:-1]) | (np.isnan(values[1:]) & np.isnan(values[:-1]))
            starts = np.concatenate(([0], np.flatnonzero(~same) + 1))[-limit:].tolist()
        else:
            starts = list(range(max(0, len(values) - limit), len(values)))
        runs = [(_fmt(float(values[i])), i) for i in starts]
        times = snap.times if len(snap.times) == len(values) else None
        total = len(values)
    elif snap.last is not None:
        return [str(snap.last).replace("\n", " \u21b5 ")]
    else:
        return []
    lines = []
    for k, (text, first) in enumerate(runs):
        repeats = (runs[k + 1][1] if k + 1 < len(runs) else total) - first
        one = text.replace("\n", " \u21b5 ")
        if with_time and times is not None:
            one = f"{_stamp(float(times[first]))}  {one}"
        if repeats > 1:
            one = f"{one}  \u00d7{repeats}"
        lines.append(one)
    lines.reverse()
    return lines


class StringWidget(Widget):
    """The latest value as large text over a scrolling history of earlier values."""

    type_name = "string"
    label = "String"
    description = "Latest text and a scrolling history"
    accepts = frozenset({ValueKind.TEXT, ValueKind.NUMBER, ValueKind.BOOL, ValueKind.ARRAY})
    properties = (
        Property(
            "history", PropKind.NUMBER, 50.0, minimum=1, maximum=1000, integer=True, label="History lines"
        ),
        Property("timestamps", PropKind.BOOL, True, label="Show timestamps"),
        Property(
            "collapse",
            PropKind.BOOL,
            True,
            label="Collapse repeats",
            help="A value repeated in a row is one line: when it first came, and how often (\u00d7N).",
        ),
    )
    default_size = (320, 200)
    min_size = (160, 100)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the large readout and the history box."""
        self._size = 22.0
        self.drawlist = dpg.add_drawlist(width, 34, parent=parent)
        self._latest = dpg.draw_text((4, 4), "\u2014", size=self._size, color=TEXT, parent=self.drawlist)
        self.history = dpg.add_input_text(
            parent=parent,
            multiline=True,
            readonly=True,
            width=width,
            height=max(30, height - 40),
            default_value="",
        )
        self.latest_text = ""

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Show the newest value and refresh the history."""
        if not snapshots:
            return
        snap = snapshots[0]
        last = snap.last
        if last is None:
            text = "\u2014"
        elif isinstance(last, float):
            text = _fmt(last)
        elif isinstance(last, tuple):
            text = "[" + ", ".join(_fmt(v) for v in last[:8]) + (", ...]" if len(last) > 8 else "]")
        else:
            text = str(last)
        self.latest_text = text
        max_chars = max(4, int(self.width / (self._size * 0.55)))
        shown = text if len(text) <= max_chars else text[: max_chars - 1] + "\u2026"
        dpg.configure_item(self._latest, text=shown)
        lines = history_lines(
            snap,
            int(self.num("history")),
            with_time=bool(self.prop("timestamps")),
            collapse=bool(self.prop("collapse")),
        )
        dpg.set_value(self.history, "\n".join(lines))


class LedWidget(Widget):
    """A lamp: lit for true, or for a number at or above the threshold; colours configurable."""

    type_name = "led"
    label = "LED"
    description = "Lamp for a bool, or a number against a threshold"
    accepts = frozenset({ValueKind.BOOL, ValueKind.NUMBER})
    properties = (
        Property("threshold", PropKind.NUMBER, 0.5, minimum=-1e12, maximum=1e12),
        Property("invert", PropKind.BOOL, False, label="Invert"),
        Property("on_color", PropKind.COLOR, "#3cdc64ff", label="On colour"),
        Property("off_color", PropKind.COLOR, "#3c414cff", label="Off colour"),
        Property("on_text", PropKind.TEXT, "ON", label="On text"),
        Property("off_text", PropKind.TEXT, "OFF", label="Off text"),
    )
    default_size = (140, 160)
    min_size = (90, 90)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Draw the lamp (off) and its caption."""
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        dl = self.drawlist
        r = max(10.0, min(width / 2 - 14, (height - 36) / 2 - 6))
        cx, cy = width / 2, 8 + r + 6
        self._geom = (cx, cy, r)
        off = self.color("off_color")
        self._glow = [draw_disc(dl, (cx, cy), r + 3 + 3 * i, (0, 0, 0, 0)) for i in range(3, 0, -1)]
        draw_disc(dl, (cx, cy), r + 2, (20, 22, 27, 255), outline=(70, 77, 90, 255), thickness=2)
        self._lamp = draw_disc(dl, (cx, cy), r - 2, off)
        self._shine = draw_disc(dl, (cx - r * 0.3, cy - r * 0.3), r * 0.25, (255, 255, 255, 40))
        self._size = 16.0
        self._caption = draw_centered_text("\u2014", cx, height - 12, self._size, DIM, dl)
        self.lit = False

    past_needed = value_at_cursor_only

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Light or dim the lamp for the latest value."""
        last = snapshots[0].last if snapshots else None
        value = last if isinstance(last, bool | int | float | str) else None
        self.lit = led_on(value, self.num("threshold"), invert=bool(self.prop("invert")))
        color = self.color("on_color") if self.lit else self.color("off_color")
        set_disc_color(self._lamp, color)
        for i, glow in enumerate(self._glow):
            alpha = (20 + 25 * i) if self.lit else 0
            set_disc_color(glow, (color[0], color[1], color[2], alpha))
        text = str(self.prop("on_text") if self.lit else self.prop("off_text"))
        if value is None:
            text = "\u2014"
        elif isinstance(value, float) and math.isnan(value):  # neither on nor off: say so (the lamp is dark)
            text = "NaN"
        w, h = text_size(text, self._size)
        cx, _, _ = self._geom
        dpg.configure_item(
            self._caption,
            text=text,
            pos=(cx - w / 2, self.height - 12 - h / 2),
            color=TEXT if self.lit else DIM,
        )
