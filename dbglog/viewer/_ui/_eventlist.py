"""The Events list panel (View \u203a Events list, Ctrl+E) and the marker command (File \u203a Add marker…,
Ctrl+M).

The panel lists the parameter changes (time, node, name, old → new) and the user's markers of the data
source's events store, newest first; a click on one puts the time cursor at it (pausing), and the row at
or before the cursor is highlighted. It stands at the right of the canvas while shown. Its per-frame work
(`poll`, a frame hook) only redraws rows when the store changed, adding the new ones on top.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Final, Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._events import CHANGES, Event, EventKind, EventStore, ParamChange, event_kind
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._dialogs import MarkerDialog
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._timescale import format_clock
from dbglog.viewer.widget_api import Color

__all__ = ["MAX_ROWS", "PANEL_W", "EventsPanel", "EventsWindow", "event_row"]

PANEL_W: Final = 420
"""The panel's width in pixels."""
MAX_ROWS: Final = 500
"""Rows the list holds at most: the newest events (the timeline bar marks every one)."""
CHANGE_TEXT: Color = (150, 220, 220, 255)
MARKER_TEXT: Color = (246, 176, 96, 255)


class EventsWindow(Protocol):
    """What the panel needs of the window: its events and the time cursor (the app's host)."""

    def event_store(self) -> EventStore | None:
        """The data source's events store (None: it keeps none)."""
        ...

    def seek(self, t: float) -> None:
        """Pause the dashboard at source time `t` (a click on a row)."""

    def cursor(self) -> float | None:
        """The time cursor (None: live)."""
        ...

    def marker_time(self) -> tuple[float, str]:
        """Where a marker added now goes, and how to say it: the cursor, or live, now (a recording: its
        end)."""
        ...


def event_row(event: Event) -> tuple[str, str, str, str]:
    """A row of the list: time (clock, milliseconds), node, name, and ``old → new`` (``(deleted, was
    1.25)``; a marker: ``marker``, its note)."""
    when = format_clock(event.time)
    if isinstance(event, ParamChange):
        old = "?" if event.old is None else event.old.text
        if event.kind is EventKind.DELETED:
            change = f"deleted (was {old})"
        elif event.kind is EventKind.DECLARED:
            change = f"= {'' if event.new is None else event.new.text} (declared)"
        else:
            change = f"{old} \u2192 {'' if event.new is None else event.new.text}"
        return when, event.node, event.name, change
    return when, "marker", "", event.note


class EventsPanel:
    """View \u203a Events list beside the canvas, and File \u203a Add marker….

    Args:
        window: the window's events and time cursor (`EventsWindow`).
        dialogs: the window's dialogs (the marker's note).
        say: shows a message in the status bar.
        call_soon: runs a command on the UI thread at the next frame (Dear PyGui's callbacks use it).
        make_room: narrows the canvas by so many pixels for the panel (0: its whole width again).
    """

    def __init__(
        self,
        window: EventsWindow,
        dialogs: Dialogs,
        say: Callable[[str], None],
        call_soon: Callable[[Callable[[], object]], None],
        make_room: Callable[[int], None],
    ) -> None:
        self.window, self.dialogs, self.say, self.call_soon = window, dialogs, say, call_soon
        self.make_room = make_room
        self.shown = False
        """Whether the panel is shown."""
        self.panel: int | str = 0
        self.table: int | str = 0
        self.rows: list[tuple[Event, int | str, int | str]] = []
        """The rows shown, newest first: (event, its row, its selectable)."""
        self._store: EventStore | None = None
        self._version = -1
        self._selected: int | str | None = None
        self._total = 0
        """How many events the store held at the last fill (more by as many as are new: only appended)."""
        self._cursor_key: object = None

    def build(self, height: int) -> None:
        """Create the panel (hidden) in the body group, after the canvas."""
        with dpg.child_window(width=PANEL_W, height=height, show=False, border=True) as self.panel:
            with dpg.group(horizontal=True):
                dpg.add_text("Events", color=theme.TEXT)
                self.count = dpg.add_text("", color=theme.DIM)
            dpg.add_button(
                label="Add marker\u2026",
                callback=lambda *_: self.call_soon(self.add_marker),
            )
            self.empty = dpg.add_text(
                "No parameter change or marker yet.", color=theme.DIM, wrap=PANEL_W - 20, show=False
            )
            self.table = dpg.add_table(
                header_row=True,
                row_background=True,
                scrollY=True,
                freeze_rows=1,
                height=-1,
                policy=dpg.mvTable_SizingStretchProp,
            )
            for label, weight in (("time", 1.1), ("node", 1.2), ("name", 0.8), ("old \u2192 new", 1.5)):
                dpg.add_table_column(label=label, parent=self.table, init_width_or_weight=weight)

    # -- commands -------------------------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register View \u203a Events list (Ctrl+E) and File \u203a Add marker… (Ctrl+M)."""
        actions.register(
            "view.events",
            "Events list",
            "The parameter changes and markers; click one to put the cursor there",
            self.toggle,
            keys=("Ctrl+E",),
            scope="canvas",
            repeat=False,
            checked=lambda: self.shown,
        )
        actions.register(
            "events.add_marker",
            "Add marker\u2026",
            "A note at the cursor (live: now), on the timeline and saved with recordings",
            self.add_marker,
            keys=("Ctrl+M",),
            scope="canvas",
            repeat=False,
        )

    def toggle(self) -> None:
        """Show or hide the panel."""
        self.shown = not self.shown
        dpg.configure_item(self.panel, show=self.shown)
        self.make_room(PANEL_W + 8 if self.shown else 0)
        self._version = -1  # filled at the next poll
        self.poll()

    def add_marker(self) -> MarkerDialog | None:
        """Ask for a note, then add a marker at the cursor (live: now) to the events (published live)."""
        store = self.window.event_store()
        if store is None:
            self.say("this data source keeps no events: no marker can be added")
            return None
        at, where = self.window.marker_time()

        def add(note: str) -> str:
            current = self.window.event_store()
            if current is None:
                return "this data source keeps no events any more"
            current.add_marker(note, at)
            self.say(f"marker added at {format_clock(at)}: {note}")
            return ""

        self.dialogs.close()
        return self.dialogs.open(MarkerDialog(f"{format_clock(at)}, {where}", add, self.dialogs.closed))

    # -- each frame -----------------------------------------------------------------------------------

    def poll(self) -> None:
        """A frame hook: new events become rows (on top), and the row at the cursor is highlighted."""
        if not self.shown:
            return
        store = self.window.event_store()
        version = -2 if store is None else store.version
        if store is not self._store or version != self._version:
            self._fill(store)
            self._store, self._version = store, version
            self._cursor_key = None
        cursor = self.window.cursor()
        key = (cursor, len(self.rows), self.rows[0][1] if self.rows else None)
        if key != self._cursor_key:
            self._cursor_key = key
            self._highlight(cursor)

    def _fill(self, store: EventStore | None) -> None:
        """Show the newest `MAX_ROWS` events: the ones after the newest row go on top (the oldest rows past
        the limit leave from the bottom); another store, or a change among older events, fills it anew."""
        everything = store.all(kinds=CHANGES) if store is not None else []
        events = everything[-MAX_ROWS:]
        newest = self.rows[0][0] if self.rows else None
        at = next((i for i in range(len(events) - 1, -1, -1) if events[i] is newest), None)
        appended = at is not None and len(everything) - self._total == len(events) - 1 - at
        self._total = len(everything)
        if store is not self._store or not appended:  # another store, or one placed among older events
            dpg.delete_item(self.table, children_only=True, slot=1)
            self.rows = []
            fresh = events
        else:
            fresh = events[at + 1 :] if at is not None else events
        for event in fresh:
            self._add_row(event)
        while len(self.rows) > MAX_ROWS:
            _event, row, _pick = self.rows.pop()
            dpg.delete_item(row)
        dpg.set_value(self.count, f"{len(self.rows)}" + (" (newest)" if len(self.rows) >= MAX_ROWS else ""))
        dpg.configure_item(self.empty, show=not self.rows)

    def _add_row(self, event: Event) -> None:
        """Add `event`'s row on top."""
        before = self.rows[0][1] if self.rows else 0
        when, node, name, change = event_row(event)
        color = MARKER_TEXT if event_kind(event) is EventKind.MARKER else CHANGE_TEXT
        with dpg.table_row(parent=self.table, before=before) as row:
            pick = dpg.add_selectable(
                label=when,
                span_columns=True,
                callback=lambda *_, t=event.time: self.call_soon(lambda: self._picked(t)),
            )
            dpg.add_text(node.lstrip("/"), color=theme.TEXT)
            dpg.add_text(name, color=theme.TEXT)
            dpg.add_text(change, color=color)
        self.rows.insert(0, (event, row, pick))

    def _picked(self, t: float) -> None:
        """A row was clicked: the cursor there."""
        self.window.seek(t)
        self._cursor_key = None

    def _highlight(self, cursor: float | None) -> None:
        """Highlight the newest row at or before the cursor (none while live)."""
        chosen: int | str | None = None
        if cursor is not None:
            chosen = next((pick for event, _row, pick in self.rows if event.time <= cursor), None)
        before = self._selected
        if before is not None and before != chosen and dpg.does_item_exist(before):
            dpg.set_value(before, False)
        if chosen is not None:
            dpg.set_value(chosen, True)  # (a click toggles a row: set it again)
        self._selected = chosen
