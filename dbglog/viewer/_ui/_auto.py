"""The automatic dashboard inside the viewer: watches the graph and carries out what `AutoPlan` decides.

Runs on the UI thread as a frame hook of `ViewerApp`; the choices and the layout are the pure logic of
`dbglog.viewer._document._autodash`. Every new tag is bound at once (its values tell its magnitude, and its
widget is live the moment it appears), placed in its panel once the graph is quiet, and never moved: tags
seen later join their panel's widgets, and what the user moved or changed is left as it is. The panels'
titled frames are drawn under the widgets; `--report-json` names each widget's panel and bindings.
"""

from __future__ import annotations

import collections
import json
import math
import os
import time
from pathlib import Path
from typing import Any

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer._data._model import Binding, Status, TopicInfo, ValueKind
from dbglog.viewer._data._robots import robot_name
from dbglog.viewer._document._autodash import (
    PANEL_TITLE_H,
    Action,
    AddWidget,
    AutoPlan,
    AutoTag,
    Observed,
    Panel,
    TagKind,
    classify,
    is_array_type,
)
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._app import ViewerApp
from dbglog.viewer._ui._frame import CanvasItem
from dbglog.viewer._widgets._geometry import Rect, overlaps

__all__ = ["AutoDashboard", "PanelFrames", "all_live", "json_value", "widget_report", "write_report"]

INFRASTRUCTURE = frozenset({"/rosout", "/parameter_events", "/clock"})
"""Topics `--all` leaves out: every ROS node has them and they are not values to watch."""
ADDS_PER_FRAME = 12
"""Widgets added in one frame at most: a fleet's hundred widgets come over a few frames, not one long one."""
FRAME_COLOR = (64, 70, 84, 255)
"""A panel's frame: a little brighter than the grid, darker than a widget's border."""


class PanelFrames:
    """The panels' titled frames, drawn on the canvas under the widgets (a drawlist of the canvas window)."""

    def __init__(self) -> None:
        self.layer: int | str = 0
        self.drawn: list[tuple[str, Rect]] = []
        """The (title, rectangle) of each frame drawn last (tests read it)."""

    def build(self, canvas: int | str) -> None:
        """Create the drawlist at the canvas's origin (a group keeps its position: a drawlist ignores pos)."""
        group = dpg.add_group(parent=canvas, pos=(0, 0))
        self.layer = dpg.add_drawlist(1, 1, parent=group)

    def draw(self, panels: list[tuple[Panel, int]]) -> None:
        """Draw each panel's frame and title (with how many tags it shows); none when `panels` is empty."""
        if not self.layer:
            return
        drawn = [(p.title, p.rect) for p, _n in panels]
        if drawn == self.drawn:
            return
        self.drawn = drawn
        layer = self.layer
        dpg.delete_item(layer, children_only=True)
        right = max((r.x + r.w for _t, r in drawn), default=1.0)
        bottom = max((r.y + r.h for _t, r in drawn), default=1.0)
        dpg.configure_item(layer, width=int(right) + 1, height=int(bottom) + 1)
        for panel, count in panels:
            r = panel.rect
            dpg.draw_rectangle(
                (r.x, r.y), (r.x + r.w, r.y + r.h), color=FRAME_COLOR, rounding=8, thickness=1, parent=layer
            )
            dpg.draw_text((r.x + 10, r.y + 5), panel.title, size=16, color=theme.TEXT, parent=layer)
            note = f"{count} tag{'' if count == 1 else 's'}"
            width = len(note) * 13 * 0.55
            y = r.y + (PANEL_TITLE_H - 13) / 2
            dpg.draw_text((r.x + r.w - 10 - width, y), note, size=13, color=theme.DIM, parent=layer)

    def clear(self) -> None:
        """Draw no frames."""
        self.draw([])


class AutoDashboard:
    """Builds the dashboard from the graph's ``/rosdashboard/`` tags (or every topic, with `all_topics`).

    Args:
        app: the started viewer.
        all_topics: also offer topics that are not dbglog tags (their numeric fields).
        period: seconds between two looks at the graph.
    """

    def __init__(self, app: ViewerApp, *, all_topics: bool = False, period: float = 0.5) -> None:
        self.app = app
        self.all_topics = all_topics
        self.period = period
        self.enabled = True
        self.plan = self._new_plan()
        self.added = 0
        """Widgets added so far (tests read this)."""
        self.frames = PanelFrames()
        self._last = -math.inf
        self._probes: dict[str, Binding] = {}
        self._infos: dict[str, TopicInfo] = {}
        """Topic -> what the graph said of it when it was offered."""
        """Topic -> the binding that holds its series until its widget binds it (its values: magnitude)."""
        self._items: dict[int, CanvasItem] = {}
        """The plan's widget key -> the widget on the canvas."""
        self._given: dict[int, tuple[Binding, ...]] = {}
        """The plan's widget key -> the bindings the plan last gave it (one changed since is left alone)."""
        self._queue: collections.deque[Action] = collections.deque()
        self._queued: set[int] = set()
        self._told: tuple[int, int, int] = (0, 0, 0)
        """The panels, waiting and placed tags the status bar last said."""
        self._known: set[int] = set()
        self._menu_item: int | str | None = None

    def install(self) -> None:
        """Hook into the frame loop, draw the panels' frames under the widgets, add a View menu switch."""
        self.app.frame_hooks.append(self.tick)
        # Tags can outnumber what fits the window: let the canvas scroll (its scrollbar, not the wheel,
        # which plots use to zoom).
        dpg.configure_item(self.app.canvas.window, no_scrollbar=False)
        self.frames.build(self.app.canvas.window)
        self._menu_item = dpg.add_menu_item(
            label="Auto-add new tags",
            check=True,
            default_value=self.enabled,
            parent=self.app.menus.menus["View"],
            callback=lambda s, a: self.set_enabled(bool(a)),
        )
        self.app.set_status(
            "auto-dashboard: a panel per robot and namespace; every tag as it is first published"
        )

    def set_enabled(self, on: bool) -> None:
        """Switch auto-adding on or off; switched back on, it continues below what is on the canvas."""
        if on and not self.enabled:
            self._restart()
        if not on:
            self._drop_probes()
            self._queue.clear()
            self._queued.clear()
        self.enabled = on
        if self._menu_item is not None:
            dpg.set_value(self._menu_item, on)

    @property
    def pending(self) -> bool:
        """Whether tags still wait to be placed (for their values, a quiet graph) or widgets to be added."""
        return self.enabled and bool(self.plan.waiting or self._queue)

    def tick(self) -> None:
        """Frame hook: add the widgets decided (a few a frame); about once per `period`, look at the graph."""
        if not self.enabled:
            return
        try:
            if self._queue:
                self._run_queue()
            now = time.monotonic()
            if now - self._last < self.period:
                return
            self._last = now
            if self._replaced():
                self.set_enabled(False)
                self.frames.clear()
                self.app.set_status("auto-dashboard off (another dashboard is open): View \u203a Auto-add")
                return
            self.poll(now)
        except Exception as exc:  # the auto-dashboard must never stop the render loop
            self.app.set_status(f"auto-dashboard error: {exc!r}")
        self._known = {id(i) for i in self.app.items}

    def poll(self, now: float | None = None) -> int:
        """Look at the graph once: offer new topics, place what is ready; return the widgets added."""
        now = time.monotonic() if now is None else now
        before = self.added
        w, _h = self.app.canvas.size()
        if w > 0 and not self.plan.panels and not self.plan.waiting:
            self.plan.fit_width(w - theme.SCROLLBAR - 2)  # room for the scrollbar
        source = self.app.source
        for info in source.topics():
            if self._wanted(info) and not self.plan.known(info.name):
                self._offer(info, now)
        for tag in self.plan.waiting:  # an array's length came: its plot shows that many elements
            seen = self._observe(tag) if tag.kind is TagKind.ARRAY else None
            if seen is not None and seen.length is not None:
                better = classify(self._infos[tag.topic], array_length=seen.length)
                if better is not None and better != tag:
                    self.plan.retag(better)
        actions = self.plan.step(now, self._observe, alive=self._alive, free=self._free)
        self._say()
        for action in actions:
            self._queue.append(action)
            if isinstance(action, AddWidget):
                self._queued.add(action.key)
        self._run_queue()
        self._draw_frames()
        return self.added - before

    def _say(self) -> None:
        """Say in the status bar how many tags wait for discovery to settle, then how many were placed."""
        panels, waiting = len(self.plan.panels), len(self.plan.waiting)
        placed = len({b.topic for p in self.plan.panels for w in p.widgets for b in w.bindings})
        told = (panels, waiting, placed)
        if told == self._told or not (panels or waiting):
            return
        self._told = told
        if not panels:
            self.app.set_status(
                f"auto-dashboard: {waiting} tags found; their panels come once discovery settles"
            )
        else:
            self.app.set_status(
                f"auto-dashboard: {placed} tags in {panels} panels; tags seen later join their panel"
            )

    def _wanted(self, info: TopicInfo) -> bool:
        if not info.types or info.publishers <= 0:
            return False
        if info.tag is not None:
            return bool(info.tag)
        hidden = any(part.startswith("_") for part in info.name.split("/"))
        return self.all_topics and info.name not in INFRASTRUCTURE and not hidden

    def _offer(self, info: TopicInfo, now: float) -> None:
        source = self.app.source
        if info.tag is None and not source.fields(info.name):
            return  # the type is not known yet: try again next time
        tag = classify(info, fields=source.fields)
        if tag is None:
            self.plan.mark_known(info.name)  # nothing to show of it
            return
        if tag.kind is not TagKind.FIELDS:
            probe = Binding(info.name, "data") if is_array_type(info.types[0]) else Binding(info.name)
            self._probes[info.name] = probe
            self.app.doc.bind(probe)
        self._infos[info.name] = info
        self.plan.offer(tag, now)

    def _observe(self, tag: AutoTag) -> Observed | None:
        """What a waiting tag's series says: its samples, largest absolute value, an array's length."""
        probe = self._probes.get(tag.topic)
        if probe is None:
            return None
        snap = self.app.source.snapshot(probe)
        last = snap.last
        length = len(last) if isinstance(last, tuple) else None
        extent = None
        if snap.kind in (ValueKind.NUMBER, ValueKind.BOOL) and len(snap.values):
            finite = np.abs(snap.values[np.isfinite(snap.values)])
            extent = float(finite.max()) if len(finite) else None
        return Observed(snap.count, extent, length)

    def _alive(self, key: int, bindings: tuple[Binding, ...]) -> bool:
        """Whether widget `key` is on the canvas (or about to be) with the bindings the plan gave it."""
        if key in self._queued:
            return True
        item = self._items.get(key)
        return item is not None and item in self.app.items and item.bindings == self._given.get(key)

    def _free(self, rect: Rect) -> bool:
        return not any(overlaps(rect, item.rect) for item in self.app.items)

    def _run_queue(self) -> None:
        """Carry out the queued actions, at most `ADDS_PER_FRAME` new widgets this frame."""
        added = 0
        while self._queue and added < ADDS_PER_FRAME:
            action = self._queue.popleft()
            if isinstance(action, AddWidget):
                self._queued.discard(action.key)
                config = action.config
                item = self.app.canvas.add_config(config)
                self._items[action.key] = item
                self._given[action.key] = config.bindings
                self.added += 1
                added += 1
                bindings = config.bindings
            else:
                item_or_none = self._items.get(action.key)
                if item_or_none is None or item_or_none not in self.app.items:
                    continue
                self._set_bindings(item_or_none, action.bindings)
                self._given[action.key] = action.bindings
                bindings = action.bindings
            for topic in {b.topic for b in bindings}:  # its widget holds the series now
                probe = self._probes.pop(topic, None)
                if probe is not None:
                    self.app.doc.unbind(probe)

    def _set_bindings(self, item: CanvasItem, bindings: tuple[Binding, ...]) -> None:
        """Give a widget the plan's bindings (a tag joined it): bound before the old ones are released.

        Not an edit of the user's: the dashboard stays unmodified, as for the widgets added.
        """
        doc = self.app.doc
        old = item.series
        item.set_bindings(bindings)
        for b in item.series:
            doc.bind(b)
        for b in old:
            doc.unbind(b)

    def _draw_frames(self) -> None:
        """Draw the frames of the panels that still hold a widget."""
        alive = {id(i) for i in self.app.items}
        shown = []
        for panel in self.plan.panels:
            items = [self._items.get(w.key) for w in panel.widgets]
            if any(i is not None and id(i) in alive for i in items) or any(
                w.key in self._queued for w in panel.widgets
            ):
                topics = {b.topic for w in panel.widgets for b in w.bindings}
                shown.append((panel, len(topics)))
        self.frames.draw(shown)

    def panel_of(self, item: CanvasItem) -> str | None:
        """The title of the panel `item` was placed in (None: a widget the plan did not make)."""
        for key, mine in self._items.items():
            if mine is item:
                panel = self.plan.panel_of(key)
                return panel.title if panel is not None else None
        return None

    def panels(self) -> list[dict[str, Any]]:
        """Each panel drawn: its title, robot, group path, frame and its widgets on the canvas (names)."""
        alive = set(map(id, self.app.items))
        out = []
        for panel in self.plan.panels:
            names = [
                item.name
                for w in panel.widgets
                if (item := self._items.get(w.key)) is not None and id(item) in alive
            ]
            if not names:
                continue
            r = panel.rect
            out.append(
                {
                    "title": panel.title,
                    "robot": panel.group.robot,
                    "group": panel.group.path,
                    "rect": [r.x, r.y, r.w, r.h],
                    "widgets": names,
                }
            )
        return out

    def _replaced(self) -> bool:
        """Whether the whole canvas was swapped (File, Open or New) since the last look."""
        if len(self._known) < 2:
            return False
        return not any(id(i) in self._known for i in self.app.items)

    def _restart(self) -> None:
        self._drop_probes()
        self.plan = self._new_plan(graph_known=True)
        self.added = 0
        self._items.clear()
        self._given.clear()
        self.frames.clear()
        for item in self.app.items:
            for b in item.bindings:
                self.plan.mark_known(b.topic)  # it already has a widget
        w, _h = self.app.canvas.size()
        if w > 0:
            self.plan.fit_width(w - theme.SCROLLBAR - 2)
        bottom = max((item.rect.y + item.rect.h for item in self.app.items), default=0.0)
        if bottom > 0:
            self.plan.skip_to(bottom + self.plan.gap)
        self._last = -math.inf

    def _new_plan(self, *, graph_known: bool = False) -> AutoPlan:
        """A plan for this viewer: a recording's topics are all there at once (no quiet graph to wait for);
        a live graph is given the discovery horizon first, unless it is known already (switched back on)."""
        if self.app.timeline.recording:
            return AutoPlan(quiet_s=0.0, first_wait_s=0.0)
        return AutoPlan(first_wait_s=0.0) if graph_known else AutoPlan()

    def _drop_probes(self) -> None:
        for probe in self._probes.values():
            self.app.doc.unbind(probe)
        self._probes.clear()


def all_live(app: ViewerApp) -> bool:
    """Whether the canvas has widgets and every one of them is live now (in view or not)."""
    return bool(app.items) and all(item.current_status(app.timeline)[0] is Status.LIVE for item in app.items)


def widget_report(
    app: ViewerApp, *, cursor_from: float | None = None, auto: AutoDashboard | None = None
) -> dict[str, Any]:
    """Return every widget's name, type, status (and why) and bindings, with the dashboard as saved.

    Also the recording replayed (its path, None for live data), the time cursor (epoch seconds, None while
    live), the span of source times held (oldest, newest)
    and, per widget, `values`: the value each binding
    shows at the cursor (live: the latest), and `samples`: how many samples of it the history holds (the
    source's `samples_held`, else the live series' length); both None for a control's publish targets.
    A widget's status is its series' now, whether it is in view or not (one out of view is not redrawn).
    Each binding names the robot it follows (``$selected``, ``$every``) if any, `series` the topics it
    resolved to (one per robot for an overlay), and `robot` the robot selected.
    With the automatic dashboard (`auto`), `panels` lists its panels and each widget names its `panel`.
    `cursor_from`: the newest source time a cursor given in seconds before it counted back from.
    """
    widgets = []
    for item in app.items:
        status, reason = item.current_status(app.timeline)
        entry: dict[str, Any] = {
            "name": item.name,
            "type": item.config.type,
            "status": status.value,
            "reason": reason,
            "bindings": [_binding(b) for b in item.bindings],
            "series": [b.topic for b in item.series],
            **_shown(app, item),
        }
        if auto is not None:
            entry["panel"] = auto.panel_of(item)
        widgets.append(entry)
    report: dict[str, Any] = {
        "file": str(app.doc.path) if app.doc.path is not None else None,
        "modified": app.doc.dirty,
        "replay": str(getattr(app.source, "name", "")) if app.timeline.recording else None,
        "cursor": app.timeline.cursor,
        "cursor_from": cursor_from,
        "robot": robot_name(app.fleet.selected),
        "span": list(span) if (span := app.time.time_span()) is not None else None,
        "widgets": widgets,
        "dashboard": app.doc.dashboard().to_dict(),
    }
    if auto is not None:
        report["panels"] = auto.panels()
    return report


def _binding(binding: Binding) -> dict[str, str]:
    """A binding as the report names it: its topic, field and regex, and the robot it follows if any."""
    out = {"topic": binding.topic, "field": binding.field, "regex": binding.regex}
    if binding.robot:
        out["robot"] = binding.robot
    return out


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


def write_report(
    app: ViewerApp,
    path: str | os.PathLike[str],
    *,
    cursor_from: float | None = None,
    auto: AutoDashboard | None = None,
) -> Path:
    """Write `widget_report` as JSON to `path` and return the path."""
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    report = widget_report(app, cursor_from=cursor_from, auto=auto)
    target.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return target
