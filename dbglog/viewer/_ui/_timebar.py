"""The timeline bar across the bottom of the window: the history's span, LIVE or PAUSED, the time cursor.

A click or a drag on the track moves the cursor there (pausing); the button pauses, or returns to live.
It reads the app's `Timeline` and draws only when what it shows changed; the maths is `_timescale`.
"""

from __future__ import annotations

from collections.abc import Callable

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Status
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._timescale import TimeScale, format_ago, format_clock, label_left
from dbglog.viewer._widgets._common import text_size
from dbglog.viewer._widgets._geometry import Rect
from dbglog.viewer.widget_api import Color

__all__ = ["BUTTON_W", "PILL_W", "TIMEBAR_H", "TimeBar"]

TIMEBAR_H = 36
"""Height of the bar in pixels."""
PILL_W = 104
"""Width of the LIVE / PAUSED pill at the left."""
BUTTON_W = 76
"""Width of the Pause / Live button at the right."""
PAD_X = 14
"""Pixels between the track's ends and its drawlist's edges (room for the knob and end labels)."""
RAIL_Y = 11.0
"""The rail's centre line in the track drawlist; the labels (ticks, ends, the cursor's time) go below."""
LABEL_Y = 20.0
LABEL_SIZE = 13.0
MID_Y = TIMEBAR_H / 2
"""The pill and the button are centred on the bar."""

LIVE: Color = theme.STATUS_COLORS[Status.LIVE]
PAUSED: Color = (240, 176, 64, 255)
RAIL: Color = (52, 57, 68, 255)
NONE: Color = (0, 0, 0, 0)


class TimeBar:
    """The bar's items (built where it is created, inside the main window) and its mouse handling.

    Args:
        timeline: the app's time cursor (read only: moves go through `on_seek`).
        span: returns the (oldest, newest) source time to show, None while nothing is held.
        on_seek: moves the cursor to a time (a click or drag on the track).
        on_toggle: the button's action (queued by the app, run on the UI thread).
    """

    def __init__(
        self,
        timeline: Timeline,
        span: Callable[[], tuple[float, float] | None],
        on_seek: Callable[[float], None],
        on_toggle: Callable[[], None],
    ) -> None:
        self.timeline = timeline
        self._span = span
        self._on_seek = on_seek
        self.scale: TimeScale | None = None
        """The track's time <-> pixel mapping as last drawn (None: nothing held yet)."""
        self.dragging = False
        """Whether the left button went down on the track and is still held."""
        self._left_down = False
        self._key: tuple[object, ...] | None = None
        self._width = 0
        with dpg.group(horizontal=True) as self.group:
            self.pill = dpg.add_drawlist(PILL_W, TIMEBAR_H)
            with dpg.group() as track_group:
                self.track = dpg.add_drawlist(400, TIMEBAR_H)
            with dpg.group():
                dpg.add_spacer(height=int(MID_Y - 14))
                self.button = dpg.add_button(label="Pause", width=BUTTON_W, callback=lambda *_: on_toggle())
        with dpg.tooltip(track_group, delay=0.6, hide_on_activity=True):  # not over the cursor while dragging
            dpg.add_text("Click or drag to look back in time (pauses)")
            dpg.add_text(
                "Space pause/resume \u00b7 \u2190/\u2192 previous/next message \u00b7 "
                "Shift+\u2190/\u2192 \u00b11 s \u00b7 End live",
                color=theme.DIM,
            )
        with dpg.tooltip(self.button):
            self.button_tip = dpg.add_text("")

    # -- geometry -----------------------------------------------------------------------------------

    def track_rect(self) -> Rect:
        """The track drawlist in window pixels."""
        (x, y), (w, h) = dpg.get_item_rect_min(self.track), dpg.get_item_rect_size(self.track)
        return Rect(float(x), float(y), float(w), float(h))

    def fit(self, window_w: int) -> None:
        """Make the track fill the window's width between the pill and the button."""
        spacing = 8 * 2 + 10 * 2  # the group's item spacing, the window's padding
        width = max(120, window_w - PILL_W - BUTTON_W - spacing)
        if width != self._width:
            self._width = width
            dpg.configure_item(self.track, width=width)

    # -- the mouse ----------------------------------------------------------------------------------

    def poll(self, pos: tuple[float, float], left: bool, *, blocked: bool) -> bool:
        """Once a frame: a press on the track (not `blocked`) moves the cursor there, a drag follows.

        Returns whether the cursor moved.
        """
        pressed = left and not self._left_down
        self._left_down = left
        if pressed and not blocked and self.scale is not None and self.track_rect().contains(*pos):
            self.dragging = True
        if not left:
            self.dragging = False
        if not self.dragging or self.scale is None:
            return False
        x0 = self.track_rect().x
        t = self.scale.t_of(pos[0] - x0)
        if t == self.timeline.cursor:
            return False
        self._on_seek(t)
        return True

    # -- drawing ------------------------------------------------------------------------------------

    def _layout(self) -> tuple[TimeScale | None, tuple[object, ...]]:
        """The scale to draw and what the picture depends on (whole pixels and label texts, not times)."""
        span = self._span()
        cursor = self.timeline.cursor
        width = self._width or 400
        if span is None:
            return None, (width, cursor is None)
        scale = TimeScale.of(span, PAD_X, width - PAD_X)
        key: tuple[object, ...] = (
            width,
            format_clock(scale.oldest, millis=False),
            tuple(round(x) for x, _ in scale.ticks()),
            None if cursor is None else (round(scale.x_of(cursor)), cursor, round(scale.newest - cursor, 1)),
        )
        return scale, key

    def stale(self) -> bool:
        """Whether the bar would look different if drawn now (the history grew, the cursor moved)."""
        return self._layout()[1] != self._key

    def draw(self) -> None:
        """Redraw the pill, the track and the button if what they show changed."""
        scale, key = self._layout()
        self.scale = scale
        if key == self._key:
            return
        self._key = key
        cursor = self.timeline.cursor
        width = self._width or 400
        self._draw_pill(cursor is None)
        self._draw_track(scale, cursor, width)
        label = "Pause" if cursor is None else "Live"
        dpg.configure_item(self.button, label=label)
        tip = "Pause: hold the dashboard at this moment (Space)" if cursor is None else "Back to live (End)"
        dpg.set_value(self.button_tip, tip)

    def _draw_pill(self, live: bool) -> None:
        dl = self.pill
        dpg.delete_item(dl, children_only=True)
        color = LIVE if live else PAUSED
        y0, y1 = MID_Y - 12, MID_Y + 12
        x0, x1 = 10.0, PILL_W - 6.0
        fill = (color[0], color[1], color[2], 48)
        dpg.draw_rectangle((x0, y0), (x1, y1), color=color, fill=fill, rounding=12, parent=dl)
        if live:
            dpg.draw_circle((x0 + 15, MID_Y), 4.5, color=color, fill=color, parent=dl)
            text = "LIVE"
        else:
            for dx in (-3.0, 3.0):  # a pause sign
                bx = x0 + 15 + dx
                corners = (bx - 1.6, MID_Y - 5), (bx + 1.6, MID_Y + 5)
                dpg.draw_rectangle(*corners, color=NONE, fill=color, parent=dl)
            text = "PAUSED"
        tw = text_size(text, 14)[0]
        left = x0 + 26 + max(0.0, (x1 - x0 - 30 - tw) / 2)
        dpg.draw_text((left, MID_Y - 8.5), text, size=14, color=theme.TEXT, parent=dl)

    def _draw_track(self, scale: TimeScale | None, cursor: float | None, width: int) -> None:
        dl = self.track
        dpg.delete_item(dl, children_only=True)
        x0, x1 = float(PAD_X), float(width - PAD_X)
        top, bottom = RAIL_Y - 3, RAIL_Y + 3
        dpg.draw_rectangle((x0, top), (x1, bottom), color=NONE, fill=RAIL, rounding=3, parent=dl)
        label_y = LABEL_Y
        if scale is None:
            text = "no history yet: the timeline fills as data arrives"
            dpg.draw_text((x0, label_y), text, size=LABEL_SIZE, color=theme.DIM, parent=dl)
            return
        live = cursor is None
        color = LIVE if live else PAUSED
        knob_x = scale.x_of(scale.newest if cursor is None else cursor)
        held = (86, 166, 240, 150) if not live else (LIVE[0], LIVE[1], LIVE[2], 110)
        dpg.draw_rectangle((x0, top), (knob_x, bottom), color=NONE, fill=held, rounding=3, parent=dl)
        # Paused: the cursor's time in the label row, under the knob; the labels it would cover give way.
        taken: list[tuple[float, float]] = []
        if cursor is not None:
            text = f"{format_clock(cursor)}   {format_ago(scale.newest - cursor, precise=True)}"
            tw = text_size(text, LABEL_SIZE)[0] + 12
            left = label_left(knob_x, tw, 0, width)
            taken.append((left - 8, left + tw + 8))
            dpg.draw_line((knob_x, bottom), (knob_x, label_y - 1.5), color=color, thickness=2, parent=dl)
            box = (30, 33, 40, 255)
            dpg.draw_rectangle(
                (left, label_y - 1.5), (left + tw, label_y + 14), color=color, fill=box, rounding=4, parent=dl
            )
            dpg.draw_text((left + 6, label_y - 0.5), text, size=LABEL_SIZE, color=theme.TEXT, parent=dl)

        def free(a: float, b: float) -> bool:
            return all(b <= lo or a >= hi for lo, hi in taken)

        # The ends: the oldest moment held (its clock time), and the newest ("now").
        for text, left in (
            (format_clock(scale.oldest, millis=False), x0 - 4),
            ("now", x1 + 2 - text_size("now", LABEL_SIZE)[0]),
        ):
            right = left + text_size(text, LABEL_SIZE)[0]
            if free(left, right):
                dpg.draw_text((left, label_y), text, size=LABEL_SIZE, color=theme.DIM, parent=dl)
            taken.append((left - 10, right + 10))
        for x, ago in scale.ticks():
            dpg.draw_line((x, bottom + 1), (x, bottom + 4), color=theme.BORDER, parent=dl)
            label = format_ago(ago)
            lw = text_size(label, LABEL_SIZE)[0]
            if free(x - lw / 2, x + lw / 2):
                dpg.draw_text((x - lw / 2, label_y), label, size=LABEL_SIZE, color=theme.DIM, parent=dl)
        dpg.draw_circle((knob_x, RAIL_Y), 6.5, color=(20, 22, 27, 255), fill=color, thickness=2, parent=dl)
