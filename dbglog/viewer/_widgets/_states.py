"""States: a panel's bools as a row of lamps and its texts (or numbers) as a list of their latest values.

The automatic dashboard gives each panel one (`docs/viewer.md`, automatic dashboard), so sixteen flags and
modes take one widget instead of sixteen. The layout is a plain function (`states_layout`), tested without a
display; the widget only draws what it returns.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import dearpygui.dearpygui as dpg

from dbglog.viewer._widgets._common import (
    DIM,
    TEXT,
    draw_disc,
    nonfinite_text,
    text_size,
    value_at_cursor_only,
)
from dbglog.viewer._widgets._plot import series_label
from dbglog.viewer._widgets._plotfit import short_labels
from dbglog.viewer.widget_api import Property, PropKind, SeriesSnapshot, ValueKind, Widget

__all__ = ["Entry", "Lamp", "Line", "StatesWidget", "entries_of", "states_layout"]

_SMALL, _LARGE = 14.0, 17.0
"""Font sizes: the usual one, and the larger one used when few entries leave room."""
_BIG_LAMPS = 3
"""Up to this many bools, alone in the widget, are drawn as large lamps side by side."""


@dataclass(frozen=True, slots=True)
class Entry:
    """One binding as the widget shows it."""

    label: str
    lamp: bool
    """A bool: a lamp (lit or not); otherwise a line with the value's text."""
    lit: bool = False
    text: str = "\u2014"


@dataclass(frozen=True, slots=True)
class Lamp:
    """A lamp to draw: its centre, radius, its label's top-left corner and whether it is lit."""

    x: float
    y: float
    r: float
    label: str
    label_x: float
    label_y: float
    lit: bool


@dataclass(frozen=True, slots=True)
class Line:
    """A line of the list: the label, and the value drawn from `value_x`."""

    y: float
    label: str
    value: str
    value_x: float


def _value_text(value: object) -> str:
    if value is None:
        return "\u2014"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        odd = nonfinite_text(value)
        return odd if odd is not None else f"{value:.6g}"
    return str(value).replace("\n", " \u21b5 ")


def entries_of(snapshots: Sequence[SeriesSnapshot]) -> list[Entry]:
    """Turn each snapshot into an entry: bools become lamps, everything else a line with its latest value.

    Labels drop the path every binding shares (``robot1:s3/ok``, ``robot1:s3/mode`` read ``ok``, ``mode``).
    """
    labels = short_labels([series_label(s.binding) for s in snapshots])
    out = []
    for label, snap in zip(labels, snapshots, strict=True):
        last = snap.last
        if snap.kind is ValueKind.BOOL or isinstance(last, bool):
            out.append(Entry(label, True, lit=last is True, text="" if last is None else _value_text(last)))
        else:
            out.append(Entry(label, False, text=_value_text(last)))
    return out


def _fit(text: str, width: float, size: float) -> str:
    """Cut `text` with an ellipsis to about `width` pixels at font `size`."""
    chars = max(1, int(width / (size * 0.55)))
    return text if len(text) <= chars else text[: max(0, chars - 1)] + "\u2026"


def states_layout(
    entries: Sequence[Entry], width: float, height: float
) -> tuple[float, list[Lamp], list[Line], int]:
    """Lay out lamps in rows (wrapping) above a list of lines; return (font size, lamps, lines, left out).

    Few entries in a large widget get the larger font and lamps. Lines that do not fit the height are left
    out, the last one shown then saying how many more there are (`left out` counts them).

    Args:
        entries: what to show, in order (lamps keep their order, lines theirs).
        width / height: the body's size in pixels.
    """
    lamps_in = [e for e in entries if e.lamp]
    lines_in = [e for e in entries if not e.lamp]
    if lamps_in and not lines_in and len(lamps_in) <= _BIG_LAMPS:
        return _big_lamps(lamps_in, width, height)
    size = _SMALL
    for candidate in (_LARGE, _SMALL):
        size = candidate
        row_h = size + 8
        x, rows = 4.0, 1 if lamps_in else 0
        for e in lamps_in:
            w = size + 6 + text_size(e.label, size)[0] + 12
            if x > 4 and x + w > width:
                x, rows = 4.0, rows + 1
            x += w
        if rows * row_h + len(lines_in) * row_h + 4 <= height * (0.6 if candidate == _LARGE else 1.0):
            break
    row_h = size + 8
    r = size * 0.45
    lamps: list[Lamp] = []
    x, y = 4.0, 2.0
    for e in lamps_in:
        label = _fit(e.label, width - 8 - (size + 6), size)
        w = size + 6 + text_size(label, size)[0] + 12
        if x > 4 and x + w > width:
            x, y = 4.0, y + row_h
        cy = y + row_h / 2
        lamps.append(Lamp(x + r + 1, cy, r, label, x + 2 * r + 7, cy - size / 2 - 1, e.lit))
        x += w
    top = (y + row_h + 4) if lamps_in else 2.0
    label_w = min(
        max((text_size(e.label, size)[0] for e in lines_in), default=0.0) + 10, max(40.0, width * 0.45)
    )
    lines: list[Line] = []
    room = max(0, int((height - top) // row_h))
    shown = lines_in if len(lines_in) <= room else lines_in[: max(0, room - 1)]
    for i, e in enumerate(shown):
        label = _fit(e.label, label_w - 10, size)
        value = _fit(e.text, width - 4 - label_w - 4, size)
        lines.append(Line(top + i * row_h + 3, label, value, 4 + label_w))
    left = len(lines_in) - len(shown)
    if left:
        lines.append(Line(top + len(shown) * row_h + 3, f"+{left} more", "", 4 + label_w))
    return size, lamps, lines, left


def _big_lamps(
    lamps_in: Sequence[Entry], width: float, height: float
) -> tuple[float, list[Lamp], list[Line], int]:
    """A few bools alone: large lamps side by side, each with its name centred below (as an LED shows one)."""
    size = _LARGE
    n = len(lamps_in)
    r = max(8.0, min(40.0, width / n / 2 - 12, (height - size - 22) / 2))
    cy = 6 + r + 4
    lamps = []
    for i, e in enumerate(lamps_in):
        cx = width * (2 * i + 1) / (2 * n)
        label = _fit(e.label, width / n - 6, size)
        lamps.append(Lamp(cx, cy, r, label, cx - text_size(label, size)[0] / 2, cy + r + 8, e.lit))
    return size, lamps, [], 0


class StatesWidget(Widget):
    """Bools as lamps and texts as a list, several tags in one widget (a panel's flags and modes)."""

    type_name = "states"
    label = "States"
    description = "Bools as a row of lamps, texts and numbers as a list of their latest values"
    accepts = frozenset({ValueKind.BOOL, ValueKind.TEXT, ValueKind.NUMBER})
    max_bindings = 16
    properties = (
        Property("on_color", PropKind.COLOR, "#3cdc64ff", label="Lamp on colour"),
        Property("off_color", PropKind.COLOR, "#3c414cff", label="Lamp off colour"),
    )
    default_size = (240, 160)
    min_size = (120, 60)

    past_needed = value_at_cursor_only

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Make the drawing area (entries are drawn at the first update)."""
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        self.entries: list[Entry] = []
        """What the last update showed (tests read it)."""
        self.left_out = 0
        """Lines that did not fit the last update's height."""
        self._drawn: object = None

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Redraw the lamps and lines when what they show changed."""
        entries = entries_of(snapshots)
        key = (
            tuple(entries),
            self.width,
            self.height,
            self.props.get("on_color"),
            self.props.get("off_color"),
        )
        if key == self._drawn:
            return
        self._drawn = key
        self.entries = entries
        dl = self.drawlist
        dpg.delete_item(dl, children_only=True)
        size, lamps, lines, self.left_out = states_layout(entries, self.width, self.height)
        on, off = self.color("on_color"), self.color("off_color")
        for lamp in lamps:
            fill = on if lamp.lit else off
            if lamp.lit:  # a soft glow around a lit lamp
                glow = (on[0], on[1], on[2], 50)
                draw_disc(dl, (lamp.x, lamp.y), lamp.r + max(3.0, lamp.r * 0.15), glow)
            draw_disc(dl, (lamp.x, lamp.y), lamp.r, fill, outline=(20, 22, 27, 255), thickness=2)
            color = TEXT if lamp.lit else DIM
            dpg.draw_text((lamp.label_x, lamp.label_y), lamp.label, size=size, color=color, parent=dl)
        for line in lines:
            dpg.draw_text((4, line.y), line.label, size=size, color=DIM, parent=dl)
            if line.value:
                dpg.draw_text((line.value_x, line.y), line.value, size=size, color=TEXT, parent=dl)

    def resize(self, width: int, height: int) -> None:
        """Fit the drawing area to the new size and draw again at the next update."""
        self.width, self.height = width, height
        dpg.configure_item(self.drawlist, width=width, height=height)
        self._drawn = None
