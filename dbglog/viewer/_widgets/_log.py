"""The Log console: a log topic's lines, filtered, on the timeline; right-click a number to plot it.

It reads the viewer's `LogStore` of its topic (``/rosout`` by default, any ``rcl_interfaces/msg/Log`` or
``std_msgs/msg/String`` topic) through the widget API's host, and draws only the rows in view: a fixed pool
of rows in one drawlist, re-filled as it scrolls. The store's worker thread decodes the lines and answers
the console's filter (a `LogReader`); each frame the console takes the newest answer and reads the rows in
view, so its work on the UI thread does not grow with the line rate. Dear PyGui callbacks only record what
the user did; the rest happens in `update` on the UI thread. The layout maths are plain functions at the top.
"""

from __future__ import annotations

import contextlib
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import dearpygui.dearpygui as dpg
import numpy as np
import numpy.typing as npt

from dbglog.viewer._widgets._common import DIM, TEXT, clock_text
from dbglog.viewer.widget_api import (
    LogFilter,
    LogReader,
    LogStore,
    Property,
    PropKind,
    SeriesSnapshot,
    Shown,
    Status,
    ValueKind,
    Widget,
    level_name,
    level_of,
)

__all__ = [
    "Columns",
    "LogWidget",
    "columns",
    "copy_text",
    "row_at",
    "thumb",
    "top_for",
    "top_from_thumb",
]

LOG_TYPES = ("rcl_interfaces/msg/Log", "std_msgs/msg/String")
ROW_H = 18
"""Height of a row in pixels."""
FONT = 14.0
HEADER_H = 20
TOOLBAR_H = 26
STATUS_H = 20
BAR_W = 10
"""Width of the scrollbar at the right of the rows."""
DRAWN_BYTES = 400
"""At most this much of a message is drawn in its row (the rest is past the widget's edge anyway)."""
TIP_CHARS = 2000
"""At most this much of a message is shown in the tooltip."""
COPY_LINES = 10_000
"""Copy with nothing selected copies at most this many of the shown lines (the newest)."""
SYNC_LINES = 20_000
"""A store without a worker: lines decoded per update (a long history back-fills over a few frames)."""
FILTER_BUDGET_S = 0.03
"""A store without a worker: time a new filter may take per update; the newest lines are answered first."""
WHEEL_LINES = 3
LEVEL_CHOICES = ("any", "debug", "info", "warn", "error", "fatal")
LEVEL_COLORS: dict[int, tuple[int, int, int, int]] = {
    10: DIM,
    20: TEXT,
    30: (240, 190, 60, 255),
    40: (240, 90, 90, 255),
    50: (225, 110, 235, 255),
}
"""Debug dim, info plain, warn yellow, error red, fatal magenta (as ``dbglog logs`` prints them)."""
NODE_COLOR = (120, 170, 225, 255)
SELECTED = (62, 92, 130, 160)
CURSOR = (240, 176, 64, 255)
NONE = (0, 0, 0, 0)


# --- layout maths (no display needed) -------------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class Columns:
    """Where each column starts in a row, and the widths of the node and message columns (pixels)."""

    time_x: float
    level_x: float
    node_x: float
    node_w: float
    message_x: float
    message_w: float


def columns(width: float) -> Columns:
    """Lay out time, level, node and message across a row of `width` pixels (the scrollbar excluded)."""
    usable = max(60.0, width - BAR_W - 4)
    time_x = 4.0
    level_x = time_x + 92
    node_x = level_x + 50
    node_w = max(40.0, min(170.0, usable * 0.18))
    message_x = node_x + node_w + 8
    return Columns(time_x, level_x, node_x, node_w, message_x, max(10.0, usable - message_x))


def row_at(y: float, rows: int) -> int | None:
    """The row (0 = the top one) at `y` pixels from the drawlist's top, or None (the header, below)."""
    if y < HEADER_H:
        return None
    row = int((y - HEADER_H) // ROW_H)
    return row if 0 <= row < rows else None


def top_for(total: int, rows: int, top: int | None) -> int:
    """The index of the first row shown: `top` kept within range; None follows the end."""
    last = max(0, total - rows)
    return last if top is None else max(0, min(top, last))


def thumb(total: int, rows: int, top: int, track: float) -> tuple[float, float]:
    """The scrollbar thumb's top and bottom (pixels within a track of height `track`)."""
    if total <= rows or track <= 0:
        return 0.0, track
    size = max(16.0, track * rows / total)
    y0 = (track - size) * top / max(1, total - rows)
    return y0, y0 + size


def top_from_thumb(y: float, grab: float, total: int, rows: int, track: float) -> int:
    """The first row for a thumb dragged so that the point grabbed (`grab` below its top) is at `y`."""
    if total <= rows:
        return 0
    y0, y1 = thumb(total, rows, 0, track)
    free = track - (y1 - y0)
    if free <= 0:
        return 0
    return top_for(total, rows, round((y - grab) / free * (total - rows)))


def copy_text(lines: Sequence[tuple[float, int, str, str]]) -> str:
    """Lines as ``dbglog logs`` prints them: ``HH:MM:SS.mmm LEVEL [node] message`` (plain text)."""
    out = []
    for t, level, node, message in lines:
        head = f"{clock_text(t)} {level_name(level) or '-':5}"
        if node:
            head += f" [{node}]"
        out.append(f"{head} {message}".replace("\n", "\n    "))
    return "\n".join(out) + ("\n" if out else "")


# --- the widget ------------------------------------------------------------------------------------------


@dataclass(slots=True)
class _Row:
    """The items of one pooled row, and what they show (to skip unchanged ones)."""

    bg: int | str
    time: int | str
    level: int | str
    node: int | str
    message: int | str
    shown: tuple[object, ...] = ()


class LogWidget(Widget):
    """A log console: time, level, node and message of each line, filtered, at the newest or the cursor."""

    type_name = "log"
    label = "Log"
    description = "Log console: /rosout (or any Log or String topic), filtered, on the timeline"
    accepts = frozenset({ValueKind.TEXT, ValueKind.NUMBER, ValueKind.BOOL, ValueKind.ARRAY})
    properties = (
        Property(
            "max_lines",
            PropKind.NUMBER,
            100_000.0,
            label="Lines kept",
            minimum=100,
            maximum=1_000_000,
            integer=True,
            help="The oldest lines go beyond this many.",
        ),
        Property("level", PropKind.CHOICE, "any", label="Minimum level", choices=LEVEL_CHOICES),
        Property("include", PropKind.TEXT, "", help="RE2: show only lines whose message contains a match."),
        Property("exclude", PropKind.TEXT, "", help="RE2: hide lines whose message contains a match."),
        Property(
            "hidden_nodes", PropKind.TEXT, "", label="Hidden nodes", help="Logger names, comma separated."
        ),
        Property("follow", PropKind.BOOL, True, help="Keep the newest line in view."),
    )
    default_size = (760, 320)
    min_size = (420, 150)
    default_topic = "/rosout"

    def __init__(self, props: dict[str, float | str | bool] | None = None) -> None:
        super().__init__(props)
        self.store: LogStore | None = None
        self.reader: LogReader | None = None
        """The console's reader of `store`: the filter asked, the answer given."""
        self._shown: Shown | None = None
        """The answer the rows show (taken in `update`)."""
        self.topic = ""
        self.shown_ids: npt.NDArray[np.int64] = np.zeros(0, dtype=np.int64)
        """The ids of the lines the filters show (up to the cursor while paused)."""
        self.top = 0
        """Index in `shown_ids` of the first row drawn."""
        self.selected: set[int] = set()
        """Ids of the selected lines (what Copy copies)."""
        self.complete = True
        self.error = ""
        self.search = ""
        self.follow = bool(self.prop("follow"))
        self._anchor: int | None = None
        """The top line's id while not following (the view stays on it as lines arrive)."""
        self._events: list[tuple[object, ...]] = []
        self._lock = threading.Lock()
        self._version = 0
        self._wheel = 0.0
        self._mouse = (-1.0, -1.0)
        self._left = self._right = self._ckey = False
        self._drag: float | None = None
        """While the scrollbar's thumb is dragged: where it was grabbed, below its top."""
        self._hover: int | None = None
        self._last_click: int | None = None
        self._keep_top: int | None = None
        """Set by a click that moves the cursor: the view stays where it was."""
        self._paused: float | None = None
        self._snap: SeriesSnapshot | None = None
        self._busy = 0
        self._node_boxes: dict[str, int | str] = {}
        self._registry: int | str = 0
        self._menu: int | str = 0
        self.nodes_popup: int | str = 0

    # -- what the widget records from Dear PyGui's callback thread (no Dear PyGui calls there) --

    def _bump(self, *event: object) -> None:
        with self._lock:
            if event:
                self._events.append(event)
            self._version += 1

    def _on_wheel(self, _sender: object, delta: object) -> None:
        if isinstance(delta, int | float):
            with self._lock:
                self._wheel += float(delta)

    # -- building ---------------------------------------------------------------------------------------

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the toolbar, the pooled rows with their scrollbar, the status line and the line menu."""
        self.follow = bool(self.prop("follow"))
        self._cols = columns(width)
        with dpg.group(horizontal=True, parent=parent):
            self.level_combo = dpg.add_combo(
                LEVEL_CHOICES,
                default_value=str(self.prop("level")),
                width=70,
                callback=lambda _s, v: self._bump("prop", "level", v),
            )
            field = max(60, (width - 70 - 90 - 64 - 56 - 40) // 3)
            self.search_input = dpg.add_input_text(
                hint="search",
                width=field,
                default_value=self.search,
                callback=lambda _s, v: self._bump("search", v),
            )
            self.include_input = dpg.add_input_text(
                hint="include RE2",
                width=field,
                default_value=str(self.prop("include")),
                callback=lambda _s, v: self._bump("prop", "include", v),
            )
            self.exclude_input = dpg.add_input_text(
                hint="exclude RE2",
                width=field,
                default_value=str(self.prop("exclude")),
                callback=lambda _s, v: self._bump("prop", "exclude", v),
            )
            self.nodes_button = dpg.add_button(
                label="Nodes", width=90, callback=lambda *_: self._bump("nodes_menu")
            )
            self.follow_box = dpg.add_checkbox(
                label="Follow",
                default_value=self.follow,
                callback=lambda _s, v: self._bump("follow", bool(v)),
            )
            self.copy_button = dpg.add_button(label="Copy", width=48, callback=lambda *_: self._bump("copy"))
        with dpg.window(
            popup=True,
            show=False,
            no_title_bar=True,
            autosize=True,
            no_saved_settings=True,
            min_size=(180, 40),
        ) as self.nodes_popup:
            dpg.add_text("Show lines of", color=DIM)
            with dpg.group(horizontal=True):
                dpg.add_button(label="All", callback=lambda *_: self._bump("nodes", "all"))
                dpg.add_button(label="None", callback=lambda *_: self._bump("nodes", "none"))
            self.nodes_list = dpg.add_group()
        self._node_boxes = {}
        body_h = max(HEADER_H + ROW_H, height - TOOLBAR_H - STATUS_H - 4)
        self.rows_n = max(1, (body_h - HEADER_H) // ROW_H)
        # In a group: a tooltip cannot hang on a drawlist itself.
        self.rows_group = dpg.add_group(parent=parent)
        self.drawlist = dpg.add_drawlist(width, body_h, parent=self.rows_group)
        dl = self.drawlist
        dpg.draw_rectangle((0, 0), (width, HEADER_H), color=NONE, fill=(36, 40, 49, 255), parent=dl)
        cols = self._cols
        for x, text in (
            (cols.time_x, "time"),
            (cols.level_x, "level"),
            (cols.node_x, "node"),
            (cols.message_x, "message"),
        ):
            dpg.draw_text((x, 2), text, size=FONT - 1, color=DIM, parent=dl)
        self._rows: list[_Row] = []
        for r in range(self.rows_n):
            y = HEADER_H + r * ROW_H
            bg = dpg.draw_rectangle((0, y), (width - BAR_W - 2, y + ROW_H), color=NONE, fill=NONE, parent=dl)
            items = [
                dpg.draw_text((x, y + 1.5), "", size=FONT, color=TEXT, parent=dl)
                for x in (cols.time_x, cols.level_x, cols.node_x, cols.message_x)
            ]
            self._rows.append(_Row(bg, *items))
        self._empty = dpg.draw_text((cols.message_x, HEADER_H + 6), "", size=FONT, color=DIM, parent=dl)
        track_x = width - BAR_W
        self._track = (track_x, HEADER_H, width - 1, body_h - 1)
        dpg.draw_rectangle(self._track[:2], self._track[2:], color=NONE, fill=(40, 44, 53, 255), parent=dl)
        self._thumb = dpg.draw_rectangle(
            self._track[:2], self._track[2:], color=NONE, fill=(90, 98, 114, 255), parent=dl
        )
        with dpg.tooltip(self.rows_group, delay=0.3) as self.tooltip:
            self.tip_text = dpg.add_text("", wrap=600)
        self.status_text = dpg.add_text("", parent=parent, color=DIM)
        with dpg.window(
            popup=True,
            show=False,
            no_title_bar=True,
            autosize=True,
            no_saved_settings=True,
            min_size=(160, 20),
        ) as self._menu:
            self._menu_items = dpg.add_group()
        with dpg.handler_registry() as self._registry:
            dpg.add_mouse_wheel_handler(callback=self._on_wheel)
        self._drawn_key: tuple[object, ...] = ()
        self._thumb_shown: tuple[float, float] = (-1.0, -1.0)

    def destroy(self) -> None:
        """Delete the widget's items, its line menu and its wheel handler."""
        super().destroy()
        for item in (self._menu, self._registry, self.nodes_popup):
            if item and dpg.does_item_exist(item):
                dpg.delete_item(item)
        self._menu = self._registry = self.nodes_popup = 0

    # -- the mouse, polled on the UI thread each turn of the render loop ---------------------------------

    def _rows_rect(self) -> tuple[float, float, float, float]:
        (x, y), (w, h) = dpg.get_item_rect_min(self.drawlist), dpg.get_item_rect_size(self.drawlist)
        return float(x), float(y), float(w), float(h)

    def owns_pointer(self, x: float, y: float) -> bool:
        """The rows and the scrollbar keep the wheel and the right click (the toolbar does not)."""
        if not self.drawlist or not dpg.does_item_exist(self.drawlist):
            return False
        rx, ry, rw, rh = self._rows_rect()
        return rx <= x < rx + rw and ry <= y < ry + rh

    def redraw_key(self) -> object:
        """Poll the mouse over the rows; redraw when the user acted, lines arrived or the hover moved."""
        if getattr(self, "drawlist", None) is None or not dpg.does_item_exist(self.drawlist):
            return None
        self._poll()
        store = self.store
        arrived = (store.added + store.pending, store.evicted, store.published) if store is not None else None
        return (self._version, self._hover, arrived, self._busy)

    def _poll(self) -> None:
        mx, my = (float(v) for v in dpg.get_mouse_pos(local=False))
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        right = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Right))
        ckey = bool(dpg.is_key_down(dpg.mvKey_C)) and bool(dpg.is_key_down(dpg.mvKey_ModCtrl))
        rx, ry, rw, _ = self._rows_rect()
        over = bool(dpg.is_item_hovered(self.drawlist))
        lx, ly = mx - rx, my - ry
        with self._lock:
            wheel, self._wheel = self._wheel, 0.0
        if over and wheel:
            self._bump("scroll", -round(wheel * WHEEL_LINES))
        in_bar = lx >= rw - BAR_W - 1
        if left and not self._left and over:
            if in_bar:
                y0, y1 = self._thumb_shown
                track_y = ly - HEADER_H
                if y0 <= track_y <= y1:
                    self._drag = track_y - y0
                else:
                    self._bump("page", -1 if track_y < y0 else 1)
            else:
                row = row_at(ly, self.rows_n)
                shift = bool(dpg.is_key_down(dpg.mvKey_ModShift))
                if row is not None:
                    self._bump("click", row, shift)
        if left and self._drag is not None and (mx, my) != self._mouse:
            self._bump("drag", ly - HEADER_H - self._drag)
        if not left:
            self._drag = None
        if right and not self._right and over and not in_bar:
            row = row_at(ly, self.rows_n)
            if row is not None:
                self._bump("menu", row, lx, mx, my)
        if ckey and not self._ckey and over:
            self._bump("copy")
        self._left, self._right, self._ckey, self._mouse = left, right, ckey, (mx, my)
        hover = row_at(ly, self.rows_n) if over and not in_bar else None
        if hover is not None and self.top + hover >= len(self.shown_ids):
            hover = None
        self._hover = hover

    # -- the widget's own status (the series of a Log topic is the console's, not a value) -------------

    def status(self) -> tuple[Status, str] | None:
        """Live with the line count; the series' own status while its topic waits."""
        snap = self._snap
        if snap is None or (snap.status is Status.WAITING and snap.msg_type is None):
            return None
        if snap.msg_type is not None and snap.msg_type not in LOG_TYPES:
            return Status.ERROR, (
                f"the Log console reads rcl_interfaces/msg/Log or std_msgs/msg/String; "
                f"{snap.binding.topic} is {snap.msg_type}"
            )
        store = self.store
        if store is None:
            return Status.WAITING, "this data source keeps no log lines"
        if not len(store):
            return Status.WAITING, f"subscribed; no line on {self.topic} yet"
        return Status.LIVE, f"{len(store):,} lines held"

    # -- drawing --------------------------------------------------------------------------------------

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Take the newest answer to the filter, apply what the user did, and re-fill the rows in view."""
        self._snap = snapshots[0] if snapshots else None
        topic = snapshots[0].binding.topic if snapshots else ""
        host = self.context.host
        store = host.log_store(topic) if host is not None and topic else None  # (a recording opened: its own)
        if topic != self.topic or store is not self.store:
            self.topic, self.store = topic, store
            self.reader = store.reader() if store is not None else None
            self._shown = None
            self.selected.clear()
            self._anchor = None
        store = self.store
        with self._lock:
            events, self._events = self._events, []
        for event in events:
            self._apply(event)
        self._refresh_nodes()
        filt = self._filter()
        cursor_moved = self.paused_at != self._paused
        self._paused = self.paused_at
        if store is None or self.reader is None:
            self.shown_ids = np.zeros(0, dtype=np.int64)
            self.error = "" if topic else "no topic: right-click the title \u203a Topic setup"
        else:
            store.capacity = int(self.num("max_lines"))
            self.reader.ask(filt)
            store.step(SYNC_LINES, FILTER_BUDGET_S)  # with a worker: only takes its newest answer
            shown = self._shown = self.reader.shown()
            ids = shown.ids if shown is not None else np.zeros(0, dtype=np.int64)
            if self.paused_at is not None and len(ids):
                last = store.index_at(self.paused_at)
                ids = ids[: int(np.searchsorted(ids, -1 if last is None else last, side="right"))]
            self.shown_ids = ids
            self.complete = shown is not None and shown.complete and shown.filt == filt
            self.error = shown.error if shown is not None else ""
            if store.pending or not self.complete:
                self._busy += 1  # more to come: the next turn of the loop updates again
        total = len(self.shown_ids)
        if self.paused_at is not None and cursor_moved:
            if self._keep_top is not None:  # the user clicked a line: it stays under the mouse
                self.top = self._clamp(self._keep_top)
            else:
                self.top = top_for(total, self.rows_n, None)  # the line at the cursor at the bottom
            self._keep_top = None
        elif self.follow and self.paused_at is None:
            self.top = top_for(total, self.rows_n, None)
        elif self._anchor is not None:
            self.top = self._clamp(int(np.searchsorted(self.shown_ids, self._anchor)))
        else:
            self.top = self._clamp(self.top)
        if not self.follow and self.top < total:
            self._anchor = int(self.shown_ids[self.top])
        self._draw_rows()
        self._draw_status(store, total)

    def _clamp(self, top: int) -> int:
        """A first row in range; paused, rows below the cursor's line may stay empty (nothing came yet)."""
        total = len(self.shown_ids)
        if self.paused_at is not None:
            return max(0, min(top, total - 1))
        return top_for(total, self.rows_n, top)

    def _filter(self) -> LogFilter:
        hidden = frozenset(n.strip() for n in str(self.prop("hidden_nodes")).split(",") if n.strip())
        level = str(self.prop("level"))
        return LogFilter(
            min_level=0 if level == "any" else level_of(level),
            hidden=hidden,
            include=str(self.prop("include")),
            exclude=str(self.prop("exclude")),
            text=self.search,
        )

    def _apply(self, event: tuple[object, ...]) -> None:
        """One thing the user did (recorded by a callback or the mouse poll), done on the UI thread."""
        kind = event[0]
        total = len(self.shown_ids)
        if kind == "prop":
            name, value = str(event[1]), event[2]
            if isinstance(value, str) and self.prop(name) != value:
                self.save_property(name, value)
        elif kind == "search":
            self.search = str(event[1])
        elif kind == "follow":
            self._set_follow(bool(event[1]))
        elif kind == "scroll" and isinstance(event[1], int):
            self._scroll_to(self.top + event[1])
        elif kind == "page" and isinstance(event[1], int):
            self._scroll_to(self.top + event[1] * max(1, self.rows_n - 1))
        elif kind == "drag" and isinstance(event[1], float):
            track = self._track[3] - self._track[1]
            self._scroll_to(top_from_thumb(event[1], 0.0, total, self.rows_n, track))
        elif kind == "click" and isinstance(event[1], int):
            self._click(event[1], bool(event[2]))
        elif kind == "menu" and isinstance(event[1], int):
            with contextlib.suppress(IndexError):  # the line was evicted since it was drawn
                self._open_menu(event[1], float(event[2]), float(event[3]), float(event[4]))  # type: ignore[arg-type]
        elif kind == "plot" and isinstance(event[1], int) and isinstance(event[2], int):
            host = self.context.host
            if host is not None and self.store is not None and self.store.has(event[1]):
                host.plot_number(self.topic, event[1], event[2])
        elif kind == "copy_line" and isinstance(event[1], int):
            if self.store is not None and self.store.has(event[1]):
                dpg.set_clipboard_text(copy_text(self._full([event[1]])))
        elif kind == "copy":
            self._copy()
        elif kind == "nodes_menu":
            x, y = dpg.get_item_rect_min(self.nodes_button)
            h = dpg.get_item_rect_size(self.nodes_button)[1]
            dpg.configure_item(self.nodes_popup, pos=(int(x), int(y + h + 2)), show=True)
        elif kind == "nodes":
            nodes = self.store.nodes() if self.store is not None else []
            self.save_property("hidden_nodes", "" if event[1] == "all" else ",".join(nodes))
            for box in self._node_boxes.values():
                dpg.set_value(box, event[1] == "all")
        elif kind == "node" and isinstance(event[1], str):
            hidden = [n for n in str(self.prop("hidden_nodes")).split(",") if n and n != event[1]]
            if not event[2]:
                hidden.append(event[1])
            self.save_property("hidden_nodes", ",".join(hidden))

    def _set_follow(self, on: bool) -> None:
        self.follow = on
        self._anchor = None
        if self.prop("follow") != on:
            self.save_property("follow", on)
        if dpg.get_value(self.follow_box) != on:
            dpg.set_value(self.follow_box, on)

    def _scroll_to(self, top: int) -> None:
        total = len(self.shown_ids)
        self.top = top_for(total, self.rows_n, top)  # (scrolling paused, too, fills the rows again)
        at_end = self.top >= max(0, total - self.rows_n)
        if self.paused_at is None and at_end != self.follow:
            self._set_follow(at_end)  # scrolled up: stop following; back at the end: follow again
        self._anchor = int(self.shown_ids[self.top]) if not self.follow and self.top < total else None

    def _click(self, row: int, shift: bool) -> None:
        """Select the line and move the dashboard's cursor to its time; Shift selects the range from the line
        clicked last (the cursor stays)."""
        index = self.top + row
        if not (0 <= index < len(self.shown_ids)) or self.store is None:
            return
        line_id = int(self.shown_ids[index])
        if shift and self._last_click is not None:
            lo, hi = sorted((int(np.searchsorted(self.shown_ids, self._last_click)), index))
            self.selected = {int(i) for i in self.shown_ids[lo : hi + 1]}
            self.selected.add(self._last_click)
            return
        self.selected = {line_id}
        self._last_click = line_id
        host = self.context.host
        if host is not None and self.store.has(line_id):
            self._keep_top = self.top
            host.seek(float(self.store.times([line_id])[0]))

    def _open_menu(self, row: int, x: float, mx: float, my: float) -> None:
        """Right click on a line: on a number, "plot this number" at once; elsewhere a menu of the line."""
        index = self.top + row
        if not (0 <= index < len(self.shown_ids)) or self.store is None:
            return
        line_id = int(self.shown_ids[index])
        spans = self._number_spans(line_id)
        for k, (x0, x1) in enumerate(spans):
            if x0 - 2 <= x <= x1 + 2:
                self._bump("plot", line_id, k)
                return
        dpg.delete_item(self._menu_items, children_only=True)
        numbers = self.store.numbers(line_id)
        dpg.add_menu_item(
            label="Copy line", parent=self._menu_items, callback=lambda *_: self._bump("copy_line", line_id)
        )
        if self.selected:
            dpg.add_menu_item(
                label="Copy selected lines", parent=self._menu_items, callback=lambda *_: self._bump("copy")
            )
        for k, number in enumerate(numbers[:20]):
            dpg.add_menu_item(
                label=f"Plot {number.text}{number.unit} (number {k + 1})",
                parent=self._menu_items,
                callback=lambda *_, k=k: self._bump("plot", line_id, k),
            )
        if not numbers:
            dpg.add_text("no number in this line", parent=self._menu_items, color=DIM)
        dpg.configure_item(self._menu, pos=(int(mx), int(my)), show=True)

    def _number_spans(self, line_id: int) -> list[tuple[float, float]]:
        """Where each number of a line is drawn in its row (pixels from the drawlist's left)."""
        assert self.store is not None
        message = self.store.line(line_id).message
        scale = FONT / max(1.0, float(dpg.get_text_size("M")[1] or FONT))
        out = []
        for n in self.store.numbers(line_id):
            before = message[: n.start].replace("\n", " \u21b5 ")
            x0 = (
                self._cols.message_x + float(dpg.get_text_size(before)[0]) * scale
                if before
                else self._cols.message_x
            )
            x1 = x0 + float(dpg.get_text_size(n.text)[0]) * scale
            out.append((x0, x1))
        return out

    def _full(self, ids: Sequence[int] | npt.NDArray[np.int64]) -> list[tuple[float, int, str, str]]:
        assert self.store is not None
        out = []
        for i in ids:
            try:
                line = self.store.line(int(i))
            except IndexError:  # evicted meanwhile
                continue
            out.append((line.time, line.level, line.node, line.message))
        return out

    def _copy(self) -> None:
        """Copy the selected lines, or (none selected) the newest shown lines."""
        if self.store is None:
            return
        ids = [i for i in self.shown_ids.tolist() if i in self.selected] or self.shown_ids[
            -COPY_LINES:
        ].tolist()
        dpg.set_clipboard_text(copy_text(self._full(ids)))

    def _refresh_nodes(self) -> None:
        """One toggle per logger, added as loggers first appear."""
        if self.store is None:
            return
        hidden = {n for n in str(self.prop("hidden_nodes")).split(",") if n}
        nodes = self.store.nodes()
        for name in nodes:
            if name not in self._node_boxes:
                self._node_boxes[name] = dpg.add_checkbox(
                    label=name or "(none)",
                    default_value=name not in hidden,
                    parent=self.nodes_list,
                    user_data=name,  # Dear PyGui passes it as the third argument
                    callback=lambda _s, v, name: self._bump("node", name, bool(v)),
                )
        shown = sum(1 for n in nodes if n not in hidden)
        label = f"Nodes {shown}/{len(nodes)}" if hidden else f"Nodes ({len(nodes)})"
        if dpg.get_item_label(self.nodes_button) != label:
            dpg.configure_item(self.nodes_button, label=label)

    def _draw_rows(self) -> None:
        store, answer = self.store, self._shown
        ids = self.shown_ids[self.top : self.top + self.rows_n]
        lines = store.window(answer, ids, DRAWN_BYTES) if store is not None and answer is not None else []
        if lines is None:  # the store changed under the answer (a late batch merged in): the next one
            self._busy += 1
            return
        cursor_id = int(self.shown_ids[-1]) if self.paused_at is not None and len(self.shown_ids) else None
        node_chars = max(4, int(self._cols.node_w / (FONT * 0.5)))
        width = self._track[0] - 2
        for r, row in enumerate(self._rows):
            if r < len(lines):
                line_id = int(ids[r])
                t, level, node, message = lines[r]
                color = LEVEL_COLORS.get(level, TEXT) if level else TEXT
                fill = (
                    SELECTED if line_id in self.selected else (48, 53, 64, 255) if r == self._hover else NONE
                )
                outline = CURSOR if line_id == cursor_id else NONE
                node_text = node if len(node) <= node_chars else node[: node_chars - 1] + "\u2026"
                shown: tuple[object, ...] = (t, level, node_text, message, fill, outline, color)
            else:
                shown = ()
            if shown == row.shown:
                continue
            row.shown = shown
            if not shown:
                for item in (row.time, row.level, row.node, row.message):
                    dpg.configure_item(item, text="")
                dpg.configure_item(row.bg, fill=NONE, color=NONE)
                continue
            y = HEADER_H + r * ROW_H
            dpg.configure_item(row.bg, fill=fill, color=outline, pmin=(0, y), pmax=(width, y + ROW_H))
            dpg.configure_item(row.time, text=clock_text(t), color=DIM)
            dpg.configure_item(row.level, text=level_name(level), color=color)
            dpg.configure_item(row.node, text=node_text, color=NODE_COLOR)
            dpg.configure_item(row.message, text=message, color=color if level not in (20, 0) else TEXT)
        empty = ""
        if not lines:
            if store is not None and answer is None:
                empty = "reading the lines\u2026"
            elif store is None or not len(store):
                empty = f"no line on {self.topic} yet" if self.topic else "no topic set"
            else:
                empty = "no line matches the filters" + (
                    " before the cursor" if self.paused_at is not None else ""
                )
        dpg.configure_item(self._empty, text=empty)
        total = len(self.shown_ids)
        track = self._track[3] - self._track[1]
        y0, y1 = thumb(total, self.rows_n, self.top, track)
        if (y0, y1) != self._thumb_shown:
            self._thumb_shown = (y0, y1)
            x0, top, x1, _ = self._track
            dpg.configure_item(self._thumb, pmin=(x0 + 1, top + y0), pmax=(x1 - 1, top + y1))
        self._draw_tooltip()

    def _draw_tooltip(self) -> None:
        hover = self._hover
        index = None if hover is None else self.top + hover
        if self.store is None or index is None or index >= len(self.shown_ids):
            dpg.configure_item(self.tooltip, show=False)
            return
        try:
            line = self.store.line(int(self.shown_ids[index]))
        except IndexError:  # evicted since the answer
            dpg.configure_item(self.tooltip, show=False)
            return
        head = f"{clock_text(line.time)}  {level_name(line.level)}  {line.node}".strip()
        site = line.site or "(no source location)"
        message = line.message if len(line.message) <= TIP_CHARS else line.message[:TIP_CHARS] + "\u2026"
        cut = f"\n\u2026 {line.cut:,} more bytes were not kept" if line.cut else ""
        dpg.set_value(self.tip_text, f"{head}\n{site}\n\n{message}{cut}")
        dpg.configure_item(self.tooltip, show=True)

    def _draw_status(self, store: LogStore | None, total: int) -> None:
        if self.error:
            text, color = f"{self.error} (left out)", LEVEL_COLORS[40]
        elif store is None:
            text, color = "", DIM
        else:
            held = len(store)
            first = self.top + 1 if total else 0
            last = min(total, self.top + self.rows_n)
            text = f"{first:,}-{last:,} of {total:,} shown" + ("" if self.complete else "\u2026 (filtering)")
            text += f" \u00b7 {held:,} lines held"
            if store.pending:
                text += f" \u00b7 {store.pending:,} to read"
            if self.selected:
                text += f" \u00b7 {len(self.selected):,} selected"
            if self.paused_at is not None:
                text += f" \u00b7 up to {clock_text(self.paused_at)}"
            color = DIM
        dpg.set_value(self.status_text, text)
        dpg.configure_item(self.status_text, color=color)
