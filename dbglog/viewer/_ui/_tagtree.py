"""The tag tree: a side panel listing every robot, group, tag and other topic with its type, rate and status,
a filter box (text or glob) and counts; drag a row onto the canvas (or double-click it) to plot it.

Virtual: only the rows in view are Dear PyGui items (a pool, moved and relabelled as the list scrolls), so
2,000 topics cost what 40 do. The tree itself is `TagTreeModel` (plain Python); it is rebuilt when the
robots or topics change, filtered when the filter text changes, and the rates and statuses of the rows in
view are worked out every `LIVE_S`: nothing of it runs per frame.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding, Status
from dbglog.viewer._data._robots import Fleet, RobotState, topic_rate
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._chrome import PAYLOAD_TYPE
from dbglog.viewer._ui._treemodel import (
    DropPlan,
    TagTreeModel,
    TreeNode,
    overlay_problem,
    plan_drop,
    plan_overlay,
    short_type,
)
from dbglog.viewer._widgets._geometry import Rect

__all__ = ["LIVE_S", "ROW_H", "TREE_PAYLOAD", "TREE_W", "TagTreePanel", "TreeCanvas", "rate_text"]

TREE_W = 370
"""The panel's width in pixels."""
ROW_H = 22
"""A row's height: the list scrolls in rows of this many pixels."""
LIVE_S = 1.0
"""How often the rates and statuses of the rows in view are worked out."""
TREE_PAYLOAD = "dbglog-tree"
"""First item of a row's drag data (``(TREE_PAYLOAD, key)``), dropped on the canvas like a toolbox button."""
_INDENT = 14
_COL_INFO = 190
_COL_RATE = 262
_COL_DOT = 316
_COL_BUTTON = 330
_BUTTON_W = 24
_CHAR_W = 7.4
"""About how wide a character of the 15 px font is (to cut long names with an ellipsis)."""
_OPEN, _CLOSED = "\u25be ", "\u25b8 "
_DOT, _NO_DOT = "\u25cf", "\u25cb"


def rate_text(rate: float) -> str:
    """A rate as a row shows it, two significant digits: ``100 Hz``, ``20 Hz``, ``2.5 Hz``, ``0.2 Hz``."""
    if rate <= 0:
        return ""
    if rate >= 10:
        return f"{round(rate, 1 - math.floor(math.log10(rate))):.0f} Hz"
    return f"{rate:.2g} Hz"


class TreeCanvas(Protocol):
    """What the tree needs of the canvas: add a widget, and its coordinates."""

    def add_widget(self, type_name: str, x: float, y: float, *, name: str | None = None) -> object | None:
        """Place a new widget near canvas point (x, y); None when it cannot."""

    def to_canvas(self, pos: tuple[float, float]) -> tuple[float, float]:
        """Window pixels to canvas pixels."""

    def view_rect(self) -> Rect:
        """The part of the canvas in view, in canvas pixels."""


class TreeDoc(Protocol):
    """What the tree needs of the dashboard document: the fleet, and giving a new widget its bindings."""

    @property
    def fleet(self) -> Fleet:
        """The robots seen and the one selected."""

    def set_bindings(self, item: Any, bindings: tuple[Binding, ...]) -> None:
        """Point a widget at new series."""

    def rename(self, item: Any, name: str) -> None:
        """Give a widget a new title."""


@dataclass(eq=False)
class _Row:
    """One pooled row: its Dear PyGui items, and the node it shows (None: unused)."""

    select: int | str
    payload: int | str
    payload_text: int | str
    tip: int | str
    name: int | str
    info: int | str
    rate: int | str
    dot: int | str
    button: int | str
    key: str | None = None
    y: int = -1
    shown: tuple[object, ...] = ()
    live: tuple[object, ...] = ()


class TagTreePanel:
    """The tag tree panel (a column beside the canvas), its filter, and what its rows add to the canvas.

    Args:
        doc: the dashboard document (its fleet: the robots and the topics seen).
        timeline: the window's time cursor over its data source (rates and statuses at the moment shown).
        canvas: where rows dropped or double-clicked become widgets.
        actions: the window's actions (Dear PyGui's callbacks queue their work there).
        say: shows a message in the status bar.
        wake: asks the window for a frame.
        shown: whether the panel starts shown.
        on_show: called with the new state when the panel is shown or hidden (the canvas makes room).
        on_robot: selects a robot (a robot's row double-clicked).
        robot_states: each robot's state as the Robot menu last worked it out (a robot row's status).
        clock: monotonic seconds (tests).
    """

    def __init__(
        self,
        doc: TreeDoc,
        timeline: Timeline,
        canvas: TreeCanvas,
        actions: Actions,
        *,
        say: Callable[[str], None],
        wake: Callable[[], None],
        shown: bool = False,
        on_show: Callable[[bool], None] | None = None,
        on_robot: Callable[[str], None] | None = None,
        robot_states: Callable[[], list[RobotState]] | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.doc, self.timeline, self.canvas, self.actions = doc, timeline, canvas, actions
        self.say, self.wake, self.on_show, self.on_robot, self.clock = say, wake, on_show, on_robot, clock
        self.robot_states = robot_states
        self.model = TagTreeModel()
        self.shown = shown
        self.built = False
        self.selected_key: str | None = None
        """The row last clicked (highlighted)."""
        self.rows: list[_Row] = []
        self.first = 0
        """The first row in view (the list's scroll, in rows)."""
        self.filter_s = 0.0
        """Seconds the last filter took (the benchmark reads it)."""
        self.added: list[DropPlan] = []
        """What the rows added to the canvas (tests read it)."""
        self._fleet_seen = -1
        self._window: tuple[int, int, int] = (-1, -1, -1)
        self._next_live = 0.0
        self._themes: dict[str, int | str] = {}

    @property
    def fleet(self) -> Fleet:
        """The robots and topics seen."""
        return self.doc.fleet

    # -- commands -------------------------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register View \u203a Tag tree and the filter's key."""
        actions.register(
            "view.tag_tree",
            "Tag tree",
            "Show or hide the tree of robots, tags and topics (drag one onto the canvas to plot it)",
            lambda: self.show(not self.shown),
            keys=("Ctrl+T",),
            checked=lambda: self.shown,
        )
        actions.register(
            "view.find_tag",
            "Find a tag\u2026",
            "Show the tag tree with the keyboard in its filter (text, or a glob: robot?:motor/*)",
            self.find,
            keys=("Ctrl+F",),
        )

    def show(self, on: bool) -> None:
        """Show or hide the panel (the canvas takes the room back)."""
        self.shown = on
        self._fleet_seen = -1  # shown again: take what changed meanwhile
        if self.built:
            dpg.configure_item(self.window, show=on)
        if self.on_show is not None:
            self.on_show(on)
        self._window = (-1, -1, -1)
        self.wake()

    def typing(self) -> bool:
        """Whether the filter is being typed in (the canvas's keys then wait: Space, arrows, Delete)."""
        return self.built and dpg.is_item_active(self.filter_input)

    def find(self) -> None:
        """Show the panel and put the keyboard in its filter."""
        if not self.shown:
            self.show(True)
        if self.built:
            dpg.focus_item(self.filter_input)

    # -- building -------------------------------------------------------------------------------------

    def build(self, height: int) -> None:
        """Create the panel (inside the window's body group, after the canvas)."""
        for name, color in (("accent", theme.ACCENT), ("dim", theme.DIM)):
            with dpg.theme() as made, dpg.theme_component(dpg.mvAll):
                dpg.add_theme_color(dpg.mvThemeCol_Text, color, category=dpg.mvThemeCat_Core)
            self._themes[name] = made
        with dpg.theme() as self._button_theme, dpg.theme_component(dpg.mvButton):
            dpg.add_theme_color(dpg.mvThemeCol_Button, theme.NO_FILL, category=dpg.mvThemeCat_Core)
            dpg.add_theme_color(dpg.mvThemeCol_Text, theme.DIM, category=dpg.mvThemeCat_Core)
            dpg.add_theme_style(dpg.mvStyleVar_FrameRounding, 4, category=dpg.mvThemeCat_Core)
        with dpg.theme() as self._list_theme, dpg.theme_component(dpg.mvAll):
            dpg.add_theme_style(dpg.mvStyleVar_ItemSpacing, 0, 0, category=dpg.mvThemeCat_Core)
            dpg.add_theme_style(dpg.mvStyleVar_WindowPadding, 0, 0, category=dpg.mvThemeCat_Core)
            dpg.add_theme_style(dpg.mvStyleVar_FramePadding, 4, 1, category=dpg.mvThemeCat_Core)
            dpg.add_theme_style(dpg.mvStyleVar_SelectableTextAlign, 0.0, 0.5, category=dpg.mvThemeCat_Core)
        with dpg.child_window(
            width=TREE_W, height=height, border=False, no_scrollbar=True, show=self.shown
        ) as self.window:
            with dpg.group(horizontal=True):
                dpg.add_text("TAGS AND TOPICS", color=theme.DIM)
                self.counts = dpg.add_text("", color=theme.DIM)
            self.filter_input = dpg.add_input_text(
                width=-1,
                hint="filter: text, or a glob (robot?:motor/*)",
                callback=lambda s, a: self.actions.call_soon(lambda: self.set_filter(str(a))),
            )
            with dpg.tooltip(self.filter_input):
                dpg.add_text(
                    "Keeps the tags and topics whose name holds the text (robot1:motor/rpm, or the topic);\n"
                    "with * ? or [ ] it is a glob over the whole name: *rpm, robot?:motor/*",
                )
            with dpg.child_window(width=-1, height=-1, border=True, horizontal_scrollbar=False) as self.list:
                # The rows' selectables flow one under the other below a spacer as tall as the rows above the
                # view (a drag cannot start from an item placed with `pos`); their texts are placed over them.
                with dpg.group() as self.flow:
                    self.top = dpg.add_spacer(width=1, height=1, show=False)
                self.end = dpg.add_spacer(width=1, height=1, pos=(0, 0))
            dpg.bind_item_theme(self.list, self._list_theme)
            self.empty = dpg.add_text(
                "", parent=self.list, pos=(8, 8), color=theme.DIM, wrap=TREE_W - 40, show=False
            )
        with dpg.item_handler_registry() as self._clicks:
            dpg.add_item_double_clicked_handler(
                callback=lambda s, a, u: self.actions.call_soon(lambda: self._double(a[1]))
            )
        self.built = True

    def _new_row(self) -> _Row:
        """One more pooled row: a selectable in the flow (a click, a double click, a drag, a tooltip), and
        its texts and overlay button placed over it."""
        parent = self.list
        select = dpg.add_selectable(
            label="",
            parent=self.flow,
            width=_COL_BUTTON - 6,
            height=ROW_H,
            show=False,
            callback=lambda s, a, u: self.actions.call_soon(lambda: self._click(s)),
        )
        dpg.bind_item_handler_registry(select, self._clicks)
        with dpg.drag_payload(parent=select, payload_type=PAYLOAD_TYPE, drag_data=None) as payload:
            payload_text = dpg.add_text("")
        with dpg.tooltip(select):
            tip = dpg.add_text("", wrap=420)
        name = dpg.add_text("", parent=parent, pos=(0, -100))
        info = dpg.add_text("", parent=parent, pos=(0, -100), color=theme.DIM)
        rate = dpg.add_text("", parent=parent, pos=(0, -100), color=theme.DIM)
        dot = dpg.add_text(_DOT, parent=parent, pos=(0, -100))
        button = dpg.add_button(
            label="all",
            parent=parent,
            width=_BUTTON_W,
            height=ROW_H - 4,
            pos=(0, -100),
            show=False,
            callback=lambda s, a, u: self.actions.call_soon(lambda: self._overlay_button(s)),
        )
        dpg.bind_item_theme(button, self._button_theme)
        with dpg.tooltip(button):
            dpg.add_text("One plot of this tag with a series per robot")
        return _Row(select, payload, payload_text, tip, name, info, rate, dot, button)

    # -- each turn of the loop ------------------------------------------------------------------------

    def poll(self) -> None:
        """Frame hook: rebuild when the topics changed, lay out the rows in view, refresh their rates."""
        if not self.built or not self.shown:  # a hidden tree costs nothing: it is built again when shown
            return
        fleet = self.fleet
        if fleet.version != self._fleet_seen:
            self._fleet_seen = fleet.version
            if self.model.update(fleet.infos, fleet.robots, self._held_types()):
                self._window = (-1, -1, -1)
        scroll = float(dpg.get_y_scroll(self.list))
        height = int(dpg.get_item_rect_size(self.list)[1]) or 600
        first = max(0, int(scroll // ROW_H))
        count = height // ROW_H + 2
        window = (first, count, self.model.version)
        now = self.clock()
        if window != self._window:
            self._window = window
            self._layout(first, count)
            self._next_live = 0.0
        if now >= self._next_live:
            self._next_live = now + LIVE_S
            self._refresh_live()

    def _held_types(self) -> dict[str, str]:
        """Topics only the history holds (not on the graph now) with their types: gone robots' tags."""
        store = self._store()
        if store is None:
            return {}
        on_graph = {i.name for i in self.fleet.infos}
        types_of = getattr(self.timeline.source, "held_types", None)
        types: dict[str, str] = types_of() if callable(types_of) else {}
        return {
            name: types.get(name, store.msg_type(name))
            for name in store.topics()
            if name.startswith("/") and name not in on_graph
        }

    def _store(self) -> History | None:
        store = getattr(self.timeline.source, "store", None)
        return store if isinstance(store, History) else None

    def set_filter(self, text: str) -> None:
        """Filter the rows (UI thread; typed into the filter box): back to the top of the list."""
        t0 = time.perf_counter()
        self.model.set_query(text)
        self.filter_s = time.perf_counter() - t0
        if self.built:
            dpg.set_y_scroll(self.list, 0.0)
        self._window = (-1, -1, -1)
        self.wake()

    def _layout(self, first: int, count: int) -> None:
        """Give the pooled rows the nodes from `first` on (`count` of them), and set the list's height."""
        model = self.model
        rows = model.rows
        while len(self.rows) < count:
            self.rows.append(self._new_row())
        dpg.configure_item(self.end, pos=(0, max(1, len(rows) * ROW_H)))
        dpg.configure_item(self.top, height=max(1, first * ROW_H), show=first > 0)
        for i, row in enumerate(self.rows):
            index = first + i
            node = rows[index] if i < count and index < len(rows) else None
            self._show_row(row, node, index * ROW_H)
        self._show_counts()

    def _show_counts(self) -> None:
        model, fleet = self.model, self.fleet
        if model.query:
            text = f"{model.matches:,} of {model.total:,} {'glob' if model.glob else 'match'}"
        else:
            robots = len(fleet.robots)
            text = f"{robots} robot{'' if robots == 1 else 's'} \u00b7 {model.total:,} topics"
        dpg.set_value(self.counts, text)
        if not model.rows:
            empty = (
                f"Nothing matches {model.query!r}."
                if model.query
                else "No topics yet. Tags show here as robots publish them (same ROS_DOMAIN_ID?)."
            )
            dpg.configure_item(self.empty, show=True)
            dpg.set_value(self.empty, empty)
        else:
            dpg.configure_item(self.empty, show=False)

    def _show_row(self, row: _Row, node: TreeNode | None, y: int) -> None:
        if node is None:
            if row.key is not None or row.y != -100:
                row.key, row.y, row.shown, row.live = None, -100, (), ()
                for item in (row.select, row.name, row.info, row.rate, row.dot, row.button):
                    dpg.configure_item(item, show=False)
            return
        model, fleet = self.model, self.fleet
        selected_robot = node.kind == "robot" and node.robot == fleet.selected
        overlay = overlay_problem(node) is None
        picked = node.key == self.selected_key
        shown = (node.key, y, model.is_open(node), node.shown, node.leaves, selected_robot, overlay, picked)
        if shown == row.shown:
            return
        if row.y != y:
            row.y = y
            dpg.configure_item(row.select, show=True)
            dpg.configure_item(row.name, pos=(6 + node.depth * _INDENT, y + 3), show=True)
            dpg.configure_item(row.info, pos=(_COL_INFO, y + 3), show=True)
            dpg.configure_item(row.rate, pos=(_COL_RATE, y + 3), show=True)
            dpg.configure_item(row.dot, pos=(_COL_DOT, y + 2), show=True)
            dpg.configure_item(row.button, pos=(_COL_BUTTON, y + 1))
        elif not row.shown:
            for item in (row.select, row.name, row.info, row.rate, row.dot):
                dpg.configure_item(item, show=True)
        dpg.configure_item(row.name, pos=(6 + node.depth * _INDENT, y + 3))
        row.shown = shown
        if row.key != node.key:
            row.key = node.key
            row.live = ()
        if node.leaf:
            label = node.label
            info = short_type(node.msg_type)
        else:
            label = (_OPEN if model.is_open(node) else _CLOSED) + node.label
            count = f"{node.shown:,} of {node.leaves:,}" if model.query else f"{node.leaves:,}"
            info = f"{count} tag{'' if node.leaves == 1 else 's'}" if node.kind == "robot" else count
        room = int((_COL_INFO - 10 - 6 - node.depth * _INDENT) / _CHAR_W)
        if len(label) > room:
            label = label[: max(1, room - 1)] + "\u2026"
        dpg.set_value(
            row.name, label + ("  \u25c2 selected" if selected_robot and len(label) < room - 10 else "")
        )
        dpg.bind_item_theme(row.name, self._themes["accent"] if selected_robot else 0)
        dpg.set_value(row.info, info)
        dpg.set_value(row.select, picked)
        dpg.configure_item(row.button, show=overlay)
        draggable = node.kind != "robot"
        dpg.configure_item(row.payload, drag_data=(TREE_PAYLOAD, node.key) if draggable else None)
        dpg.set_value(row.payload_text, f"+ {node.path or node.label}")
        dpg.set_value(row.tip, self._tip(node))

    def _tip(self, node: TreeNode) -> str:
        fleet = self.fleet
        if node.kind == "robot":
            who = "the selected robot" if node.robot == fleet.selected else "double-click to select it"
            return f"{node.label}: {node.leaves:,} tags and topics ({who})"
        follows = fleet.namespaced and node.robot == fleet.selected
        where = (
            "follows the selected robot (the Robot menu switches)"
            if follows
            else f"stays on {node.path.split(':')[0]}"
            if node.robot
            else ""
        )
        if node.leaf:
            head = f"{node.path}\n{node.topic}   {node.msg_type or 'type not known yet'}"
        else:
            head = f"{node.label}: {node.leaves:,} tags and topics"
        what = f"a widget that {where}" if where else "a widget of it"
        return f"{head}\nDrag onto the canvas, or double-click: {what}"

    def _refresh_live(self) -> None:
        """The rates and statuses of the rows in view (from the history, at the moment shown)."""
        store = self._store()
        at = self.timeline.cursor
        t = time.time() if at is None else at
        stale = self.timeline.stale_after
        robot_status = (
            {s.robot: s.status for s in self.robot_states()} if self.robot_states is not None else {}
        )
        changed = False
        for row in self.rows:
            node = self.model.node(row.key) if row.key is not None else None
            if node is None:
                continue
            if node.kind == "robot":
                status: Status | None = robot_status.get(node.robot or "")
                rate = ""
            elif node.leaf and store is not None and store.kind(node.topic) is not None:
                hz, last = topic_rate(store, node.topic, t)
                rate = rate_text(hz)
                if last is None:
                    status = Status.WAITING
                else:
                    status = Status.LIVE if t - last <= stale else Status.STALE
            else:
                status, rate = None, ""
            live = (status, rate)
            if live == row.live:
                continue
            row.live = live
            changed = True
            dpg.set_value(row.rate, rate)
            dpg.set_value(row.dot, _DOT if status is not None else (_NO_DOT if node.leaf else ""))
            color = theme.STATUS_COLORS[status] if status is not None else theme.DIM
            dpg.configure_item(row.dot, color=color)
        if changed:
            self.wake()

    # -- what a row does ------------------------------------------------------------------------------

    def _row_of(self, item: int | str) -> _Row | None:
        return next((r for r in self.rows if r.select == item or r.button == item), None)

    def _click(self, item: int | str) -> None:
        """A click on a row: a robot or group opens or closes, a tag is highlighted."""
        row = self._row_of(item)
        if row is None or row.key is None:
            return
        node = self.model.node(row.key)
        if node is None:
            return
        self.selected_key = node.key
        if not node.leaf:
            self.model.toggle(node.key)
        self._window = (-1, -1, -1)
        self.wake()

    def _double(self, item: int | str) -> None:
        """A double click: a robot is selected; a group or tag is added to the canvas where there is room."""
        row = self._row_of(item)
        node = self.model.node(row.key) if row is not None and row.key is not None else None
        if node is None:
            return
        if node.kind == "robot":
            self.model.toggle(node.key)  # the double click's two clicks opened and closed it: keep it open
            self.select_robot(node.robot or "")
            return
        view = self.canvas.view_rect()
        self.add(node.key, (view.x + 40.0, view.y + 40.0))

    def _overlay_button(self, item: int | str) -> None:
        row = self._row_of(item)
        node = self.model.node(row.key) if row is not None and row.key is not None else None
        if node is None:
            return
        plan = plan_overlay(node, self.fleet)
        view = self.canvas.view_rect()
        self._place(plan, (view.x + 40.0, view.y + 40.0))

    def select_robot(self, robot: str) -> None:
        """Select `robot` for the widgets that follow the selected robot (as the Robot menu does)."""
        if self.on_robot is not None:
            self.on_robot(robot)
        self._window = (-1, -1, -1)

    def drop(self, data: object, pos: tuple[float, float]) -> bool:
        """A drop on the canvas (window pixels `pos`): a row dragged from the tree, added at the next frame
        (Dear PyGui's callback thread only queues it); False for other data."""
        if not (isinstance(data, tuple) and len(data) == 2 and data[0] == TREE_PAYLOAD):
            return False
        key = str(data[1])
        self.actions.call_soon(lambda: self.add(key, self.canvas.to_canvas(pos)))
        return True

    def add(self, key: str, at: tuple[float, float]) -> object | None:
        """Add what the row `key` becomes (`plan_drop`) near canvas point `at`."""
        node = self.model.node(key)
        if node is None:
            self.say("that row is gone (its topic left the graph)")
            return None
        fields = self.timeline.source.fields
        return self._place(plan_drop(node, self.fleet, fields), at)

    def _place(self, plan: DropPlan | str, at: tuple[float, float]) -> object | None:
        if isinstance(plan, str):
            self.say(plan)
            return None
        item = self.canvas.add_widget(plan.type_name, at[0], at[1])
        if item is None:
            return None
        self.doc.set_bindings(item, plan.bindings)
        if plan.name:
            self.doc.rename(item, plan.name)
        self.added.append(plan)
        name = getattr(item, "name", plan.name)
        self.say(f"added {name!r}" + (f": {plan.note}" if plan.note else ""))
        self.wake()
        return item
