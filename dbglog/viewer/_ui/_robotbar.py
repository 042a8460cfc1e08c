"""The robot switcher in the menu bar: every robot seen with its live status, and the one the dashboard's
robot-relative widgets follow; switching rebinds them all (their past too), and a plot overlays a tag across
robots in one click (*Overlay across robots*)."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Generic, TypeVar

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import EVERY_ROBOT
from dbglog.viewer._data._robots import Fleet, RobotState, is_relative, robot_name, robot_of
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._document._canvas_doc import CanvasDoc, DocItem
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._actions import Actions

__all__ = ["DISCOVER_S", "STATUS_S", "RobotSwitcher", "robot_line"]

DISCOVER_S = 0.5
"""How often the switcher looks for new robots and topics (the graph, the history)."""
STATUS_S = 1.0
"""How often each robot's live status is worked out again (not every frame)."""
_DOT = "\u25cf"
_ENTRY_W = 150
"""Width of a robot's entry in the Robot menu (its status follows on the same line)."""


ItemT = TypeVar("ItemT", bound=DocItem)


def robot_line(state: RobotState) -> str:
    """What the switcher's menu says of a robot beside its name: ``live · 12 tags``."""
    tags = f"{state.tags} tag{'' if state.tags == 1 else 's'}"
    return f"{state.status.value} \u00b7 {tags}"


class RobotSwitcher(Generic[ItemT]):
    """The robots the viewer has seen (a menu in the menu bar) and the selected one.

    Looks for robots every `DISCOVER_S` (the data source's topics, and those its history still holds) and
    works out each robot's status every `STATUS_S`, from its tags' newest samples at the moment shown (the
    cursor's, paused). Selecting a robot resolves every robot-relative binding again
    (`CanvasDoc.sync_robots`): the widgets show the new robot's data at once, its past included (the history
    holds every robot's tags).

    Args:
        doc: the dashboard document (its `Fleet` is the robots and the selection).
        timeline: the window's time cursor over its data source.
        say: shows a message in the status bar.
        wake: asks the window for a frame (something shown changed).
        clock: monotonic seconds (tests).
    """

    def __init__(
        self,
        doc: CanvasDoc[ItemT],
        timeline: Timeline,
        *,
        say: Callable[[str], None],
        wake: Callable[[], None],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.doc, self.timeline, self.say, self.wake, self.clock = doc, timeline, say, wake, clock
        self.states: list[RobotState] = []
        """Each robot's state, as last worked out."""
        self.menu: int | str = 0
        self.dot: int | str = 0
        self.entries: dict[str, int | str] = {}
        """Robot -> its menu entry (a selectable: a click selects the robot and closes the menu)."""
        self.lines: dict[str, int | str] = {}
        """Robot -> the text beside its entry: its status (in the status colour) and tags."""
        self._actions = Actions()
        """The window's actions (`register`): the menu's command entries run them."""
        self._next_discover = 0.0
        self._next_status = 0.0
        self._shown: tuple[object, ...] = ()
        self._listed: tuple[str, ...] | None = None

    @property
    def fleet(self) -> Fleet:
        """The robots seen and the one selected."""
        return self.doc.fleet

    # -- commands -------------------------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register the robot commands: the next or previous robot, and the overlay of the selected plot."""
        self._actions = actions
        add = actions.register
        add(
            "robot.next",
            "Next robot",
            "Show the next robot in the widgets that follow the selected robot",
            lambda: self.step(1),
            keys=("Ctrl+Down",),
            scope="canvas",
        )
        add(
            "robot.previous",
            "Previous robot",
            "Show the previous robot in the widgets that follow the selected robot",
            lambda: self.step(-1),
            keys=("Ctrl+Up",),
            scope="canvas",
        )
        add(
            "robot.overlay",
            "Overlay across robots",
            "The selected plot shows its tags for every robot, one series each",
            self.overlay_selected,
            applies=lambda item: item.config.type == "plot",  # the context menu offers it on plots only
        )

    def select(self, robot: str) -> None:
        """Select `robot`: every widget that follows the selected robot shows it, its past included."""
        changed = self.fleet.select(robot)
        moved = self.doc.sync_robots()
        if changed:
            self.say(f"robot {robot_name(robot)}: {moved} widget{'' if moved == 1 else 's'} show it")
        self._next_status = 0.0
        self.wake()

    def step(self, direction: int) -> None:
        """Select the next (+1) or previous (-1) robot."""
        robots = self.fleet.robots
        if not robots:
            self.say("no robots seen yet")
            return
        at = robots.index(self.fleet.selected) if self.fleet.selected in robots else -direction
        self.select(robots[(at + direction) % len(robots)])

    def overlay_selected(self) -> None:
        """Make the selected plot show each of its robot topics for every robot (one series per robot)."""
        item = self.doc.selected
        if item is None or item not in self.doc.items:
            self.say("select a plot first (click its title)")
            return
        self.overlay(item)

    def overlay(self, item: ItemT) -> bool:
        """Bind `item`'s robot topics for every robot; False (with a message) when it cannot."""
        config = item.config.editable
        if config is None or config.type != "plot":
            self.say("only a plot overlays robots: one series per robot")
            return False
        fleet = self.fleet
        new = []
        for b in config.bindings:
            if b.robot == EVERY_ROBOT:
                new.append(b)
            elif is_relative(b) or robot_of(b.topic, fleet.robots) in fleet.robots:
                new.append(fleet.relative(fleet.shown(b), EVERY_ROBOT))
            else:
                new.append(b)
        bindings = tuple(dict.fromkeys(new))
        if bindings == config.bindings:
            done = any(b.robot == EVERY_ROBOT for b in new)
            self.say(f"{item.name!r} " + ("already shows every robot" if done else "has no robot topic"))
            return False
        self.doc.set_bindings(item, bindings)
        self.say(f"{item.name!r} shows every robot: {len(item.series)} series")
        self.wake()
        return True

    # -- the menu -------------------------------------------------------------------------------------

    def build(self, menu_bar: int | str) -> None:
        """Add the Robot menu and its status dot to the window's menu bar."""
        self.menu = dpg.add_menu(label=self._title(), parent=menu_bar)
        self.dot = dpg.add_text(_DOT, parent=menu_bar, color=theme.DIM)
        with dpg.tooltip(self.dot):
            self.dot_tip = dpg.add_text("no robots seen yet")
        self._list()

    def _title(self) -> str:
        if not self.fleet.robots and not self.fleet.chosen:
            return "Robot: none yet"
        return f"Robot: {robot_name(self.fleet.selected)}"

    def _list(self) -> None:
        """Fill the menu: a checked entry per robot (its status and tags at the right), then the commands."""
        robots = tuple(self.fleet.robots)
        if robots == self._listed:
            return
        self._listed = robots
        dpg.delete_item(self.menu, children_only=True)
        self.entries.clear()
        self.lines.clear()
        for robot in robots:
            with dpg.group(horizontal=True, parent=self.menu):
                self.entries[robot] = dpg.add_selectable(
                    label=robot_name(robot), width=_ENTRY_W, callback=lambda *_, r=robot: self._pick(r)
                )
                self.lines[robot] = dpg.add_text("", color=theme.DIM)
        if not robots:
            dpg.add_text(
                "No robots seen yet: dbglog tags in a namespace\n(/robot1/rosdashboard/\u2026) show here.",
                color=theme.DIM,
                parent=self.menu,
            )
        dpg.add_separator(parent=self.menu)
        for name in ("robot.previous", "robot.next", "robot.overlay"):
            dpg.add_menu_item(
                label=self._actions[name].label,
                shortcut=self._actions[name].shortcut,
                parent=self.menu,
                callback=lambda *_, n=name: self._actions.soon(n),
            )
        self._shown = ()

    def _pick(self, robot: str) -> None:
        """A robot's menu entry (Dear PyGui's callback thread): select it at the next frame."""
        self._actions.call_soon(lambda: self.select(robot))

    # -- each turn of the loop ------------------------------------------------------------------------

    def poll(self) -> None:
        """Frame hook: look for robots now and then, work out their status, and show what changed."""
        now = self.clock()
        if now >= self._next_discover:
            self._next_discover = now + DISCOVER_S
            self.discover()
        if now >= self._next_status:
            self._next_status = now + STATUS_S
            self.states = self.fleet.states(self._store(), self.timeline.cursor, self.timeline.stale_after)
        if self.menu:
            self._show()

    def discover(self) -> bool:
        """Take the data source's topics and its history's into the fleet; rebind what that changes."""
        source = self.timeline.source
        store = self._store()
        held = store.topics() if store is not None else ()
        changed = self.fleet.observe(source.topics(), held)
        if changed:
            self.doc.sync_robots()
            self._next_status = 0.0
            self.wake()
        return changed

    def _store(self) -> History | None:
        store = getattr(self.timeline.source, "store", None)
        return store if isinstance(store, History) else None

    def _show(self) -> None:
        fleet = self.fleet
        self._list()
        states = {s.robot: s for s in self.states}
        shown = (fleet.selected, tuple((s.robot, s.status, s.tags) for s in self.states), self._title())
        if shown == self._shown:
            return
        self._shown = shown
        dpg.configure_item(self.menu, label=self._title())
        for robot, entry in self.entries.items():
            state = states.get(robot)
            dpg.set_value(entry, robot == fleet.selected)
            if state is not None:
                dpg.set_value(self.lines[robot], f"{_DOT} {robot_line(state)}")
                dpg.configure_item(self.lines[robot], color=theme.STATUS_COLORS[state.status])
        selected = states.get(fleet.selected)
        color = theme.STATUS_COLORS[selected.status] if selected is not None else theme.DIM
        dpg.configure_item(self.dot, color=color)
        if selected is not None:
            tip = f"{selected.name}: {robot_line(selected)}"
        elif fleet.robots or fleet.chosen:
            tip = f"{robot_name(fleet.selected)}: no tags seen"
        else:
            tip = "no robots seen yet"
        dpg.set_value(self.dot_tip, tip)
        self.wake()
