"""The auto-dashboard inside the viewer: polls the graph about once a second and adds suggested widgets.

Runs on the UI thread as a frame hook of `ViewerApp`; the choices and the layout are the pure logic of
`dbglog.viewer._document._autodash`. It only ever adds widgets: what is on the canvas (and where the
user moved it) is never moved; new widgets go to free cells.
"""

from __future__ import annotations

import json
import math
import os
import time
from pathlib import Path
from typing import Any

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Binding, Status, TopicInfo
from dbglog.viewer._document._autodash import AutoLayout, is_array_type, suggest
from dbglog.viewer._ui._app import ViewerApp
from dbglog.viewer._ui._frame import CanvasItem
from dbglog.viewer._widgets._geometry import Rect, overlaps

__all__ = ["AutoDashboard", "all_live", "json_value", "widget_report", "write_report"]

INFRASTRUCTURE = frozenset({"/rosout", "/parameter_events", "/clock"})
"""Topics `--all` leaves out: every ROS node has them and they are not values to watch."""
ARRAY_WAIT_S = 5.0
"""How long a new array tag may take to deliver its first message (its length) before it is placed anyway."""


class AutoDashboard:
    """Adds a suggested widget for every new ``/rosdashboard/`` tag (or any topic, with `all_topics`).

    Args:
        app: the started viewer.
        all_topics: also offer topics that are not dbglog tags (their numeric fields).
        period: seconds between two looks at the graph.
    """

    def __init__(self, app: ViewerApp, *, all_topics: bool = False, period: float = 1.0) -> None:
        self.app = app
        self.all_topics = all_topics
        self.period = period
        self.enabled = True
        self.layout = AutoLayout()
        self.added = 0
        """Widgets added so far (tests read this)."""
        self._last = -math.inf
        self._probes: dict[str, tuple[Binding, float]] = {}
        """Array topics waiting for their first message: topic -> (probe binding, deadline)."""
        self._known: set[int] = set()
        self._menu_item: int | str | None = None

    def install(self) -> None:
        """Hook into the app's frame loop and add a View menu switch."""
        self.app.frame_hooks.append(self.tick)
        # Tags can outnumber what fits the window: let the canvas scroll (its scrollbar, not the wheel,
        # which plots use to zoom).
        dpg.configure_item(self.app.canvas.window, no_scrollbar=False)
        self._menu_item = dpg.add_menu_item(
            label="Auto-add new tags",
            check=True,
            default_value=self.enabled,
            parent=self.app.menus.menus["View"],
            callback=lambda s, a: self.set_enabled(bool(a)),
        )
        self.app.set_status("auto-dashboard: adding a widget for every tag as it is first published")

    def set_enabled(self, on: bool) -> None:
        """Switch auto-adding on or off; switched back on, it continues below what is on the canvas."""
        if on and not self.enabled:
            self._restart()
        if not on:
            self._drop_probes()
        self.enabled = on
        if self._menu_item is not None:
            dpg.set_value(self._menu_item, on)

    @property
    def pending(self) -> bool:
        """Whether new array tags are still waiting for their first message (their length) to be placed."""
        return bool(self._probes)

    def tick(self) -> None:
        """Frame hook: about once per `period`, add widgets for topics that appeared."""
        now = time.monotonic()
        if not self.enabled or now - self._last < self.period:
            return
        self._last = now
        try:
            if self._replaced():
                self.set_enabled(False)
                self.app.set_status("auto-dashboard off (another dashboard is open): View \u203a Auto-add")
                return
            self.poll(now)
        except Exception as exc:  # the auto-dashboard must never stop the render loop
            self.app.set_status(f"auto-dashboard error: {exc!r}")
        self._known = {id(i) for i in self.app.items}

    def poll(self, now: float | None = None) -> int:
        """Look at the graph once and add widgets for new topics; return how many were added."""
        now = time.monotonic() if now is None else now
        w, _h = self.app.canvas.size()
        if w > 0 and not self.added:
            self.layout.fit_columns(w - 16)  # room for the scrollbar
        before = self.added
        for info in self.app.source.topics():
            if self._wanted(info) and not self.layout.seen(info.name):
                self._offer(info, now)
        return self.added - before

    def _wanted(self, info: TopicInfo) -> bool:
        if not info.types or info.publishers <= 0:
            return False
        if info.tag is not None:
            return bool(info.tag)
        hidden = any(part.startswith("_") for part in info.name.split("/"))
        return self.all_topics and info.name not in INFRASTRUCTURE and not hidden

    def _offer(self, info: TopicInfo, now: float) -> None:
        source = self.app.source
        length: int | None = None
        if is_array_type(info.types[0]):
            probe, deadline = self._probes.get(info.name, (Binding(info.name, "data"), now + ARRAY_WAIT_S))
            if info.name not in self._probes:
                self._probes[info.name] = (probe, deadline)
                self.app.doc.bind(probe)
            last = source.snapshot(probe).last
            if isinstance(last, tuple):
                length = len(last)
            elif now < deadline:
                return
            self._probes.pop(info.name)
            self.app.doc.unbind(probe)
        elif info.tag is None and not source.fields(info.name):
            return  # the type is not known yet: try again next time
        suggestions = suggest(info, array_length=lambda _t: length, fields=source.fields)
        for config in self.layout.add(suggestions, info.name, free=self._free):
            self.app.canvas.add_config(config)
            self.added += 1

    def _free(self, x: float, y: float, w: float, h: float) -> bool:
        rect = Rect(x, y, w, h)
        return not any(overlaps(rect, item.rect) for item in self.app.items)

    def _replaced(self) -> bool:
        """Whether the whole canvas was swapped (File, Open or New) since the last look."""
        if len(self._known) < 2:
            return False
        return not any(id(i) in self._known for i in self.app.items)

    def _restart(self) -> None:
        self.layout = AutoLayout()
        self.added = 0
        for item in self.app.items:
            for b in item.bindings:
                self.layout.add([], b.topic)  # marks the topic as seen: it already has a widget
        bottom = max((item.rect.y + item.rect.h for item in self.app.items), default=0.0)
        if bottom > 0:
            self.layout.origin = (self.layout.origin[0], bottom + self.layout.gap)
        self._last = -math.inf

    def _drop_probes(self) -> None:
        for probe, _deadline in self._probes.values():
            self.app.doc.unbind(probe)
        self._probes.clear()


def all_live(app: ViewerApp) -> bool:
    """Whether the canvas has widgets and every one of them is live."""
    return bool(app.items) and all(item.status is Status.LIVE for item in app.items)


def widget_report(app: ViewerApp, *, cursor_from: float | None = None) -> dict[str, Any]:
    """Return every widget's name, type, status (and why) and bindings, with the dashboard as saved.

    Also the recording replayed (its path, None for live data), the time cursor (epoch seconds, None while
    live), the span of source times held (oldest, newest)
    and, per widget, `values`: the value each binding
    shows at the cursor (live: the latest), and `samples`: how many samples of it the history holds (the
    source's `samples_held`, else the live series' length); both None for a control's publish targets.
    `cursor_from`: the newest source time a cursor given in seconds before it counted back from.
    """
    return {
        "file": str(app.doc.path) if app.doc.path is not None else None,
        "modified": app.doc.dirty,
        "replay": str(getattr(app.source, "name", "")) if app.timeline.recording else None,
        "cursor": app.timeline.cursor,
        "cursor_from": cursor_from,
        "span": list(span) if (span := app.time.time_span()) is not None else None,
        "widgets": [
            {
                "name": item.name,
                "type": item.config.type,
                "status": item.status.value,
                "reason": item.reason,
                "bindings": [{"topic": b.topic, "field": b.field, "regex": b.regex} for b in item.bindings],
                **_shown(app, item),
            }
            for item in app.items
        ],
        "dashboard": app.doc.dashboard().to_dict(),
    }


def _shown(app: ViewerApp, item: CanvasItem) -> dict[str, list[Any]]:
    """The value each binding of `item` shows at the cursor, and the samples held of it."""
    if not item.series:
        return {"values": [None] * len(item.bindings), "samples": [None] * len(item.bindings)}
    held = getattr(app.source, "samples_held", None)
    return {
        "values": [json_value(s.last) for s in item.snapshots(app.timeline)],
        "samples": [
            int(held(b)) if callable(held) else len(app.source.snapshot(b).times) for b in item.series
        ],
    }


def json_value(value: object) -> Any:
    """Return a shown value as JSON has it: a number, a string, a bool, a list (arrays) or None (NaN too)."""
    if isinstance(value, bool | str) or value is None:
        return value
    if isinstance(value, int):
        return value
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, tuple | list):
        return [json_value(v) for v in value]
    return str(value)


def write_report(app: ViewerApp, path: str | os.PathLike[str], *, cursor_from: float | None = None) -> Path:
    """Write `widget_report` as JSON to `path` and return the path."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    report = widget_report(app, cursor_from=cursor_from)
    target.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return target
