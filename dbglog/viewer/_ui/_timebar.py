"""The timeline bar across the bottom of the window: the history's span, LIVE, PAUSED or PLAYING, the cursor.

A click or a drag on the track moves the cursor there (pausing); the round button plays and pauses, the
speed button picks a playback speed, the loop toggle (recordings) plays again from the start at the end,
and the Pause/Live button (live) pauses or returns to live. Parameter changes and the user's markers are
marks on the rail (one a pixel column); the pointer over one shows its label, and a click on it puts the
cursor at its very time. The Log console's warnings and errors are marks above the rail, a run of adjacent
columns of one level drawn as one rectangle, redrawn only when they change. It reads the app's `Timeline`
and draws only when what it shows changed; the maths is `_timescale`.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Protocol

import dearpygui.dearpygui as dpg
import numpy as np
import numpy.typing as npt

from dbglog.viewer._data._model import Status
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._timescale import (
    TimeScale,
    event_columns,
    format_ago,
    format_clock,
    format_offset,
    label_left,
    mark_runs,
)
from dbglog.viewer._widgets._common import text_size
from dbglog.viewer._widgets._geometry import Rect
from dbglog.viewer.widget_api import Color, EventMark

__all__ = [
    "BUTTON_W",
    "CHANGE_COLOR",
    "ICON_W",
    "MARKER_COLOR",
    "PILL_W",
    "SPEED_W",
    "TIMEBAR_H",
    "TimeBar",
    "TimelineEvents",
    "speed_text",
]

TIMEBAR_H = 36
"""Height of the bar in pixels."""
PILL_W = 104
"""Width of the LIVE / PAUSED pill at the left."""
BUTTON_W = 76
"""Width of the Pause / Live button at the right (live only)."""
ICON_W = 34
"""Width of the play/pause and loop buttons (drawn icons)."""
SPEED_W = 56
"""Width of the speed button."""
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
MARK_COLORS: dict[int, Color] = {30: (240, 190, 60, 255), 40: (240, 90, 90, 255), 50: (225, 110, 235, 255)}
"""Timeline marks of log lines: WARN yellow, ERROR red, FATAL magenta (as the Log console colours them)."""
PLAYING: Color = theme.ACCENT
CHANGE_COLOR: Color = (90, 210, 210, 255)
"""A parameter change's mark on the rail (a diamond), and its line on time plots."""
MARKER_COLOR: Color = (246, 160, 60, 255)
"""A user's marker on the rail (a flag), and its line on time plots."""
EVENT_NEAR_PX = 5
"""The pointer this close to an event's mark (pixels) shows its label; a press there seeks to its time."""
ICON_BG: Color = (48, 53, 64, 255)
ICON_HOVER: Color = (62, 92, 130, 255)


class TimelineEvents(Protocol):
    """Where the bar reads the parameter changes and user markers it marks (the app's host)."""

    def event_times(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        """Every event's time, oldest first, and whether each is a user's marker (cheap: cached)."""
        ...

    def events(self, t0: float, t1: float) -> Sequence[EventMark]:
        """The events from `t0` to `t1`, oldest first (a few: those under the pointer)."""
        ...


def speed_text(speed: float) -> str:
    """Return a playback speed as the speed button shows it: 1, 0.25, 10 and a multiplication sign."""
    return f"{speed:g}\u00d7"


class TimeBar:
    """The bar's items (built where it is created, inside the main window) and its mouse handling.

    Args:
        timeline: the app's time cursor (read only: moves go through `on_seek`).
        span: returns the (oldest, newest) source time to show, None while nothing is held.
        on_seek: moves the cursor to a time (a click or drag on the track).
        on_toggle: the Pause/Live button's action (called on Dear PyGui's callback thread: queue it).
        on_play: the play/pause button's action (a click on it, seen by `poll` on the UI thread).
        on_speed: a speed chosen in the speed menu (called by `poll`, on the UI thread).
        on_loop: the loop toggle's action (seen by `poll` on the UI thread).
        marks: the log lines to mark on the track for a scale (the Log console's warnings and errors): the
            pixel columns holding one, in increasing order, and the worst level of each.
        keys: the keys that move the cursor, as the track's tooltip lists them.
        events: the parameter changes and user markers to mark on the rail.
    """

    def __init__(
        self,
        timeline: Timeline,
        span: Callable[[], tuple[float, float] | None],
        on_seek: Callable[[float], None],
        on_toggle: Callable[[], None],
        *,
        on_play: Callable[[], None] = lambda: None,
        on_speed: Callable[[float], None] = lambda _speed: None,
        on_loop: Callable[[], None] = lambda: None,
        marks: Callable[[TimeScale], tuple[npt.NDArray[np.intp], npt.NDArray[np.uint8]]] | None = None,
        keys: str = "",
        events: TimelineEvents | None = None,
    ) -> None:
        self.timeline = timeline
        self._events = events
        self.event_marks: tuple[tuple[int, bool], ...] = ()
        """The events' marks as last laid out: (pixel in the track, is a user's marker), one a column."""
        self.events_marked = 0
        """How many events those marks stand for (the tests time a change's way to the screen by it)."""
        self._event_key: object = None
        self.hovered_event: tuple[float, str] | None = None
        """The event mark under the pointer: (its pixel in the track, its label), else None."""
        self._snapped_at: float | None = None
        """The pointer's x where a press snapped the cursor to an event (dragging on seeks again)."""
        self._on_speed = on_speed
        self._speed_chosen: float | None = None
        """A speed chosen in the speed menu (its callback thread), taken by the next `poll`."""
        self._marks = marks
        """Log lines to mark on the track: the columns with a WARN/ERROR/FATAL line, the worst of each."""
        self._marked: tuple[tuple[int, int, int], ...] = ()
        """The log marks as runs of adjacent columns of one level: (first pixel, last pixel, level)."""
        self._marks_drawn: tuple[tuple[int, int, int], ...] | None = None
        """The runs the marks' layer shows (it is redrawn only when they change)."""
        self._span = span
        self._on_seek = on_seek
        self._on_play = on_play
        self._on_loop = on_loop
        self._hover: str | None = None
        """The icon button under the mouse ("play", "loop"), drawn highlighted."""
        self._pressed: str | None = None
        """The icon button the left button went down on (it acts when let go over it)."""
        self.scale: TimeScale | None = None
        """The track's time <-> pixel mapping as last drawn (None: nothing held yet)."""
        self.dragging = False
        """Whether the left button went down on the track and is still held."""
        self._left_down = False
        self._key: tuple[object, ...] | None = None
        self._controls_key: tuple[object, ...] | None = None
        """What the pill, the play and loop buttons, the speed and the Live button were drawn for."""
        self._loop_shown: bool | None = None
        self._width = 0
        with dpg.group(horizontal=True) as self.group:
            self.pill = dpg.add_drawlist(PILL_W, TIMEBAR_H)
            with dpg.group() as play_group:
                self.play = dpg.add_drawlist(ICON_W, TIMEBAR_H)
            with dpg.group() as track_group:
                self.track = dpg.add_drawlist(400, TIMEBAR_H)
                # Bottom to top: the rail, ticks and labels; the log marks; the knob, events, hovered label.
                self._rail_layer = dpg.add_draw_layer(parent=self.track)
                self._marks_layer = dpg.add_draw_layer(parent=self.track)
                self._top_layer = dpg.add_draw_layer(parent=self.track)
            with dpg.group():
                dpg.add_spacer(height=int(MID_Y - 14))
                self.speed = dpg.add_button(
                    label=speed_text(timeline.speed), width=SPEED_W, callback=lambda *_: self._ask_speed()
                )
            with dpg.group(show=timeline.recording) as self.loop_group:
                self.loop = dpg.add_drawlist(ICON_W, TIMEBAR_H)
            with dpg.group(show=not timeline.recording) as self.button_group:
                dpg.add_spacer(height=int(MID_Y - 14))
                self.button = dpg.add_button(label="Pause", width=BUTTON_W, callback=lambda *_: on_toggle())
        with dpg.tooltip(track_group, delay=0.6, hide_on_activity=True):  # not over the cursor while dragging
            dpg.add_text("Click or drag to look back in time (pauses)")
            if keys:
                dpg.add_text(keys, color=theme.DIM)
        with dpg.tooltip(self.button):
            self.button_tip = dpg.add_text("")
        with dpg.tooltip(play_group, delay=0.4):
            self.play_tip = dpg.add_text("")
        with dpg.tooltip(self.speed, delay=0.4):
            dpg.add_text("Playback speed")
        with dpg.tooltip(self.loop_group, delay=0.4):
            self.loop_tip = dpg.add_text("")
        # The speed menu: a popup above the speed button (opened on the UI thread by `open_speed_menu`).
        with dpg.window(
            popup=True,
            show=False,
            no_title_bar=True,
            no_move=True,
            no_resize=True,
            autosize=True,
            no_saved_settings=True,
            min_size=(SPEED_W + 20, 20),
        ) as self.speed_menu:
            self.speed_entries: dict[float, int | str] = {}
            """Speed -> its entry in the speed menu."""
            for speed in Timeline.SPEEDS:
                self.speed_entries[speed] = dpg.add_selectable(
                    label=speed_text(speed), callback=lambda *_, v=speed: self._choose_speed(v)
                )
        self._speed_asked = False

    # -- geometry -----------------------------------------------------------------------------------

    def track_rect(self) -> Rect:
        """The track drawlist in window pixels."""
        (x, y), (w, h) = dpg.get_item_rect_min(self.track), dpg.get_item_rect_size(self.track)
        return Rect(float(x), float(y), float(w), float(h))

    def icon_rect(self, which: str) -> Rect:
        """The round button ``play`` or the ``loop`` toggle, in window pixels (its drawn face)."""
        dl = self.play if which == "play" else self.loop
        (x, y) = dpg.get_item_rect_min(dl)
        return Rect(float(x) + 3, float(y) + MID_Y - 14, ICON_W - 6.0, 28.0)

    def fit(self, window_w: int) -> None:
        """Make the track fill the window's width between the pill and play button and the controls."""
        recording = self.timeline.recording
        right = SPEED_W + (ICON_W if recording else BUTTON_W)
        spacing = 8 * 4 + 10 * 2  # the group's item spacing, the window's padding
        width = max(120, window_w - PILL_W - ICON_W - right - spacing)
        if width != self._width:
            self._width = width
            dpg.configure_item(self.track, width=width)
        if self._loop_shown is None:
            self._loop_shown = bool(dpg.is_item_shown(self.loop_group))
        if self._loop_shown != recording:
            self._loop_shown = recording
            dpg.configure_item(self.loop_group, show=recording)
            dpg.configure_item(self.button_group, show=not recording)

    # -- the speed menu -----------------------------------------------------------------------------

    def _ask_speed(self) -> None:
        # Dear PyGui's callback thread: `open_speed_menu` opens it on the UI thread (at the next `poll`).
        self._speed_asked = True

    def _choose_speed(self, speed: float) -> None:
        # Dear PyGui's callback thread: `poll` closes the menu and sets the speed on the UI thread.
        self._speed_chosen = speed

    def open_speed_menu(self) -> None:
        """Show the speed menu above the speed button, the current speed highlighted."""
        for speed, entry in self.speed_entries.items():
            dpg.set_value(entry, math.isclose(speed, self.timeline.speed))
        (x, y) = dpg.get_item_rect_min(self.speed)
        height = len(self.speed_entries) * 26 + 12
        dpg.configure_item(self.speed_menu, pos=(int(x) - 10, max(0, int(y) - height - 4)), show=True)

    def close_speed_menu(self) -> None:
        """Hide the speed menu."""
        dpg.hide_item(self.speed_menu)

    @property
    def speed_menu_open(self) -> bool:
        """Whether the speed menu is shown."""
        return bool(dpg.is_item_shown(self.speed_menu))

    # -- the mouse ----------------------------------------------------------------------------------

    def poll(self, pos: tuple[float, float], left: bool, *, blocked: bool) -> bool:
        """Once a frame: a press on the track (not `blocked`) moves the cursor there, a drag follows.

        Returns whether the cursor moved.
        """
        pressed = left and not self._left_down
        released = self._left_down and not left
        self._left_down = left
        if self._speed_asked:
            self._speed_asked = False
            self.open_speed_menu()
        chosen, self._speed_chosen = self._speed_chosen, None
        if chosen is not None:
            self.close_speed_menu()
            self._on_speed(chosen)
        blocked = blocked or self.speed_menu_open
        self._hover = None
        for which in ("play", "loop") if not blocked else ():
            if (which == "play" or self.timeline.recording) and self.icon_rect(which).contains(*pos):
                self._hover = which
        if pressed:
            self._pressed = self._hover
        elif released:
            if self._pressed is not None and self._pressed == self._hover:
                (self._on_play if self._pressed == "play" else self._on_loop)()
            self._pressed = None
        near = self._event_near(pos) if not blocked and not self.dragging else None
        self.hovered_event = None if near is None else (near[0], near[2])
        if pressed and not blocked and self.scale is not None and self.track_rect().contains(*pos):
            self.dragging = True
            if near is not None:  # a press on an event's mark: the cursor at its very time
                self._snapped_at = pos[0]
                self._on_seek(near[1])
                return True
        if not left:
            self.dragging, self._snapped_at = False, None
        if not self.dragging or self.scale is None:
            return False
        if self._snapped_at is not None and abs(pos[0] - self._snapped_at) < 1:
            return False
        self._snapped_at = None
        x0 = self.track_rect().x
        t = self.scale.t_of(pos[0] - x0)
        if t == self.timeline.cursor:
            return False
        self._on_seek(t)
        return True

    def _event_near(self, pos: tuple[float, float]) -> tuple[float, float, str] | None:
        """The event mark within `EVENT_NEAR_PX` of the pointer over the track: (its pixel, the time of its
        newest event, its label: the newest event's, with how many more the column holds)."""
        scale = self.scale
        if self._events is None or scale is None or not self.event_marks:
            return None
        rect = self.track_rect()
        if not rect.contains(*pos):
            return None
        x = pos[0] - rect.x
        best = min(self.event_marks, key=lambda m: abs(m[0] - x))
        if abs(best[0] - x) > EVENT_NEAR_PX:
            return None
        half = 0.5 * scale.seconds / max(1.0, scale.x1 - scale.x0)
        t = scale.t_of(best[0])
        found = list(self._events.events(t - half, t + half))
        if not found:
            return None
        newest = found[-1]
        more = f"  (+{len(found) - 1} more)" if len(found) > 1 else ""
        return float(best[0]), newest.time, newest.label + more

    # -- drawing ------------------------------------------------------------------------------------

    def _layout(self) -> tuple[TimeScale | None, tuple[object, ...]]:
        """The scale to draw and what the picture depends on (whole pixels and label texts, not times)."""
        span = self._span()
        timeline = self.timeline
        cursor = timeline.cursor
        width = self._width or 400
        controls = (
            timeline.playing,
            timeline.speed,
            timeline.loop,
            timeline.recording,
            self._hover,
            self._pressed,
        )
        if span is None:
            return None, (width, cursor is None, controls)
        scale = TimeScale.of(span, PAD_X, width - PAD_X)
        key: tuple[object, ...] = (
            width,
            format_clock(scale.oldest, millis=False),
            tuple(round(x) for x, _ in scale.ticks()),
            None if cursor is None else (round(scale.x_of(cursor)), cursor, round(scale.newest - cursor, 1)),
            controls,
            self._marked_for(scale),
            self._event_marks_for(scale),
            self.hovered_event,
        )
        return scale, key

    def _marked_for(self, scale: TimeScale) -> tuple[tuple[int, int, int], ...]:
        """The log marks' runs for `scale` (kept for `_draw_track`; part of what the picture depends on)."""
        self._marked = mark_runs(*self._marks(scale)) if self._marks is not None else ()
        return self._marked

    def _event_marks_for(self, scale: TimeScale) -> tuple[tuple[int, bool], ...]:
        """The events' marks for `scale` (kept for `_draw_track`), laid out again when the events or the
        scale's pixels changed."""
        if self._events is None:
            return ()
        times, markers = self._events.event_times()
        key = (id(times), len(times), round(scale.x_of(scale.oldest)), scale.oldest, scale.newest, scale.x1)
        if key != self._event_key:
            self._event_key = key
            self.event_marks = tuple(event_columns(times, markers, scale))
            self.events_marked = int(np.count_nonzero((times >= scale.oldest) & (times <= scale.newest)))
        return self.event_marks

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
        timeline = self.timeline
        cursor = timeline.cursor
        width = self._width or 400
        self._draw_track(scale, cursor, width)
        controls = (
            cursor is None,
            timeline.recording,
            timeline.playing,
            timeline.loop,
            timeline.speed,
            self._hover,
            self._pressed,
        )
        if controls == self._controls_key:
            return  # the cursor moved: the track alone changed
        self._controls_key = controls
        self._draw_pill(cursor is None and not timeline.recording, timeline.playing)
        self._draw_play()
        if timeline.recording:
            self._draw_loop()
        dpg.configure_item(self.speed, label=speed_text(timeline.speed))
        label = "Pause" if cursor is None else "Live"
        dpg.configure_item(self.button, label=label)
        tip = "Pause: hold the dashboard at this moment (Space)" if cursor is None else "Back to live (End)"
        dpg.set_value(self.button_tip, tip)

    def _icon_face(self, dl: int | str, which: str, *, on: bool = False) -> tuple[float, float]:
        """Draw an icon button's rounded face (hovered, pressed or switched on); return its centre."""
        cx, cy = ICON_W / 2, MID_Y
        fill = ICON_HOVER if self._hover == which else ICON_BG
        if self._pressed == which and self._hover == which:
            fill = (70, 120, 180, 255)
        border = PLAYING if on else fill
        dpg.draw_rectangle(
            (cx - 14, cy - 13),
            (cx + 14, cy + 13),
            color=border,
            fill=fill,
            rounding=6,
            thickness=1,
            parent=dl,
        )
        return cx, cy

    def _draw_play(self) -> None:
        """The play/pause button: a triangle to play, two bars while playing."""
        dl = self.play
        dpg.delete_item(dl, children_only=True)
        timeline = self.timeline
        cx, cy = self._icon_face(dl, "play")
        usable = timeline.recording or timeline.cursor is not None or timeline.playing
        color = theme.TEXT if usable else theme.DIM
        if timeline.playing:
            for dx in (-3.5, 3.5):
                dpg.draw_rectangle(
                    (cx + dx - 2, cy - 6), (cx + dx + 2, cy + 6), color=NONE, fill=color, parent=dl
                )
            tip = "Pause playback (Space)"
        else:
            p1, p2, p3 = (cx - 4.5, cy - 7), (cx - 4.5, cy + 7), (cx + 7.5, cy)
            dpg.draw_triangle(p1, p2, p3, color=color, fill=color, parent=dl)
            if timeline.recording:
                tip = "Play from the cursor (Space)" + (
                    "; at the end: from the start" if timeline.loop else ""
                )
            elif usable:
                tip = "Play from the cursor: the dashboard replays its history, then goes live"
            else:
                tip = "Play back the history: pause or click on the timeline first"
        dpg.set_value(self.play_tip, tip)

    def _draw_loop(self) -> None:
        """The loop toggle: two arrows chasing each other round a circle; blue while on."""
        dl = self.loop
        dpg.delete_item(dl, children_only=True)
        on = self.timeline.loop
        cx, cy = self._icon_face(dl, "loop", on=on)
        color = PLAYING if on else theme.DIM
        r = 6.5
        for start in (0.25, 1.25):  # two arcs of ~130 degrees, each ending in an arrowhead
            angles = [math.pi * (start + 0.72 * k / 12) for k in range(13)]
            points = [(cx + r * math.cos(a), cy + r * math.sin(a)) for a in angles]
            dpg.draw_polyline(points, color=color, thickness=1.8, parent=dl)
            a = angles[-1]
            tip = (cx + r * math.cos(a), cy + r * math.sin(a))
            tangent = (-math.sin(a), math.cos(a))
            normal = (math.cos(a), math.sin(a))
            head = (tip[0] + 3.5 * tangent[0], tip[1] + 3.5 * tangent[1])
            wing1 = (tip[0] + 3 * normal[0], tip[1] + 3 * normal[1])
            wing2 = (tip[0] - 3 * normal[0], tip[1] - 3 * normal[1])
            dpg.draw_triangle(head, wing1, wing2, color=color, fill=color, parent=dl)
        dpg.set_value(
            self.loop_tip, "Loop: play again from the start at the end (on)" if on else "Loop (off)"
        )

    def _draw_pill(self, live: bool, playing: bool = False) -> None:
        dl = self.pill
        dpg.delete_item(dl, children_only=True)
        color = LIVE if live else PLAYING if playing else PAUSED
        y0, y1 = MID_Y - 12, MID_Y + 12
        x0, x1 = 10.0, PILL_W - 6.0
        fill = (color[0], color[1], color[2], 48)
        dpg.draw_rectangle((x0, y0), (x1, y1), color=color, fill=fill, rounding=12, parent=dl)
        if live:
            dpg.draw_circle((x0 + 15, MID_Y), 4.5, color=color, fill=color, parent=dl)
            text = "LIVE"
        elif playing:
            bx = x0 + 15
            dpg.draw_triangle(
                (bx - 3.5, MID_Y - 5),
                (bx - 3.5, MID_Y + 5),
                (bx + 5, MID_Y),
                color=color,
                fill=color,
                parent=dl,
            )
            text = "PLAYING"
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
        dl = self._rail_layer
        dpg.delete_item(dl, children_only=True)
        dpg.delete_item(self._top_layer, children_only=True)
        self._draw_marks(self._marked if scale is not None else ())
        x0, x1 = float(PAD_X), float(width - PAD_X)
        top, bottom = RAIL_Y - 3, RAIL_Y + 3
        dpg.draw_rectangle((x0, top), (x1, bottom), color=NONE, fill=RAIL, rounding=3, parent=dl)
        label_y = LABEL_Y
        if scale is None:
            text = "no history yet: the timeline fills as data arrives"
            dpg.draw_text((x0, label_y), text, size=LABEL_SIZE, color=theme.DIM, parent=dl)
            return
        live = cursor is None
        recording = self.timeline.recording
        color = LIVE if live and not recording else PLAYING if self.timeline.playing else PAUSED
        knob_x = scale.x_of(scale.newest if cursor is None else cursor)
        held = (86, 166, 240, 150) if not live else (LIVE[0], LIVE[1], LIVE[2], 110)
        dpg.draw_rectangle((x0, top), (knob_x, bottom), color=NONE, fill=held, rounding=3, parent=dl)
        # Paused: the cursor's time in the label row, under the knob; the labels it would cover give way.
        taken: list[tuple[float, float]] = []
        if cursor is not None:
            into = (
                format_offset(cursor - scale.oldest, precise=True)
                if recording
                else format_ago(scale.newest - cursor, precise=True)
            )
            text = f"{format_clock(cursor)}   {into}"
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

        # The ends: the oldest moment held (its clock time), and the newest ("now"; a recording's length).
        end = format_offset(scale.seconds) if recording else "now"
        for text, left in (
            (format_clock(scale.oldest, millis=False), x0 - 4),
            (end, x1 + 2 - text_size(end, LABEL_SIZE)[0]),
        ):
            right = left + text_size(text, LABEL_SIZE)[0]
            if free(left, right):
                dpg.draw_text((left, label_y), text, size=LABEL_SIZE, color=theme.DIM, parent=dl)
            taken.append((left - 10, right + 10))
        ticks = scale.ticks_from_start() if recording else scale.ticks()
        for x, ago in ticks:
            dpg.draw_line((x, bottom + 1), (x, bottom + 4), color=theme.BORDER, parent=dl)
            label = format_offset(ago) if recording else format_ago(ago)
            lw = text_size(label, LABEL_SIZE)[0]
            if free(x - lw / 2, x + lw / 2):
                dpg.draw_text((x - lw / 2, label_y), label, size=LABEL_SIZE, color=theme.DIM, parent=dl)
        dl = self._top_layer  # the knob, then the events' marks over it (the newest sits at the live knob)
        dpg.draw_circle((knob_x, RAIL_Y), 6.5, color=(20, 22, 27, 255), fill=color, thickness=2, parent=dl)
        self._draw_events(dl)
        hovered = self.hovered_event
        if hovered is not None:  # the label of the event under the pointer, in the label row
            text = hovered[1]
            tw = text_size(text, LABEL_SIZE)[0] + 12
            left = label_left(hovered[0], tw, 0, width)
            box = (30, 33, 40, 255)
            dpg.draw_rectangle(
                (left, LABEL_Y - 1.5),
                (left + tw, LABEL_Y + 14),
                color=CHANGE_COLOR,
                fill=box,
                rounding=4,
                parent=dl,
            )
            dpg.draw_text((left + 6, LABEL_Y - 0.5), text, size=LABEL_SIZE, color=theme.TEXT, parent=dl)

    def _draw_marks(self, runs: tuple[tuple[int, int, int], ...]) -> None:
        """The Log console's warnings and errors above the rail: a rectangle a run (a column is 2 px wide)."""
        if runs == self._marks_drawn:
            return
        self._marks_drawn = runs
        dl = self._marks_layer
        dpg.delete_item(dl, children_only=True)
        top = RAIL_Y - 3
        for first, last, level in runs:
            mark = MARK_COLORS.get(level, MARK_COLORS[50] if level > 50 else MARK_COLORS[30])
            dpg.draw_rectangle((first - 1, top - 9), (last + 1, top - 1), color=NONE, fill=mark, parent=dl)

    def _draw_events(self, dl: int | str) -> None:
        """Parameter changes as small diamonds on the rail, user markers as flags above it."""
        for x, marker in self.event_marks:
            if marker:
                dpg.draw_line((x, RAIL_Y + 3), (x, 0.5), color=MARKER_COLOR, thickness=2, parent=dl)
                dpg.draw_triangle(
                    (x, 0.5), (x + 6, 2.75), (x, 5), color=MARKER_COLOR, fill=MARKER_COLOR, parent=dl
                )
            else:
                d = 4.0
                points = [(x, RAIL_Y - d), (x + d, RAIL_Y), (x, RAIL_Y + d), (x - d, RAIL_Y), (x, RAIL_Y - d)]
                dpg.draw_polygon(points, color=(20, 22, 27, 255), fill=CHANGE_COLOR, thickness=1, parent=dl)
