"""The canvas and the widgets on it: its Dear PyGui items (toolbox, scrolled area, grid, overlay), window
and canvas coordinates, the widget operations (add, select, delete, change type, ...), and each frame's
widget refresh and chrome. What is on the canvas lives in the headless document (`CanvasDoc`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Binding
from dbglog.viewer._document._canvas_doc import CanvasDoc
from dbglog.viewer._document._dashboard import LoadResult, RawWidget, WidgetConfig
from dbglog.viewer._publishing._publish import PublishService
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._chrome import PAYLOAD_TYPE, CanvasPaint, Toolbox
from dbglog.viewer._ui._frame import TITLE_H, CanvasItem, FrameSnapshots
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._plotnumber import NumberPlan
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer._widgets._geometry import Rect, free_spot, overlaps, snap_rect
from dbglog.viewer.widget_api import TimeRange, Widget, WidgetHost

__all__ = ["REVEAL_MARGIN", "TEXT_ENTRY_TYPES", "Canvas", "reveal_scroll"]

TEXT_ENTRY_TYPES = ("mvInputText", "mvInputInt", "mvInputFloat", "mvInputDouble")
"""Dear PyGui item types that take typed text: while one is being edited, the canvas keys are its own."""
REVEAL_MARGIN = 12.0
"""Pixels kept between a widget scrolled into view and the edge of the view."""


def reveal_scroll(rect: Rect, view: Rect, margin: float = REVEAL_MARGIN) -> tuple[float, float]:
    """Return the scroll offsets (x, y) that bring `rect` into `view` (canvas pixels), moving the least.

    An axis where the rectangle already lies inside keeps its offset; a rectangle larger than the view
    shows its top (left) edge.
    """

    def axis(lo: float, size: float, view_lo: float, view_size: float) -> float:
        if lo >= view_lo and lo + size <= view_lo + view_size:
            return view_lo
        if lo < view_lo or size + 2 * margin > view_size:
            return max(0.0, lo - margin)
        return max(0.0, lo + size + margin - view_size)

    return axis(rect.x, rect.w, view.x, view.w), axis(rect.y, rect.h, view.y, view.h)


class Canvas:
    """The canvas area of one window and the widgets on it.

    Args:
        doc: the dashboard document (widgets, bindings, selection, grid settings).
        registry: the widget types.
        dialogs: the window's dialogs (a widget dropped opens its topic setup; a deleted one's closes).
        say: shows a message in the status bar.
        snaps: the frame's snapshots (each series read once a frame, whoever asks).
        publisher: the controls' publishing service, handed to every widget.
        time_range: the time range the time plots share, handed to every widget.
    """

    def __init__(
        self,
        doc: CanvasDoc[CanvasItem],
        registry: WidgetRegistry,
        dialogs: Dialogs,
        say: Callable[[str], None],
        snaps: FrameSnapshots,
        *,
        publisher: PublishService,
        time_range: TimeRange,
    ) -> None:
        self.doc, self.registry, self.dialogs, self.say = doc, registry, dialogs, say
        self.snaps = snaps
        self.publisher, self.time_range = publisher, time_range
        self.host: WidgetHost | None = None
        """What widgets get besides their series (log stores, the time cursor); set before widgets come."""
        self.window: int | str = 0
        """The scrolled canvas (a child window)."""
        self.pointer_override: tuple[float, float] | None = None
        """When set, used instead of the real mouse position (scripted sessions and tests)."""
        self.drop_handlers: list[Callable[[object, tuple[float, float]], bool]] = []
        """Take a drop of something else than a toolbox button (a tag tree's row) at window pixels; True
        when taken."""
        self._rooms: dict[str, int] = {}
        """The pixels each panel beside the canvas takes from it (`room_for`)."""
        self._reveal: tuple[CanvasItem, int] | None = None
        """A widget to scroll into view, and how many more frames to try (the scroll lands a frame late)."""

    # -- building -------------------------------------------------------------------------------------

    def build(self, height: int) -> None:
        """Create the toolbox and the canvas side by side (inside the window's body group)."""
        self.tools = Toolbox(
            self.registry,
            snap=self.doc.snap,
            grid_size=self.doc.grid_size,
            height=height,
            on_snap=self.set_snap,
            on_grid_size=self.set_grid_size,
        )
        # Scrollbars appear when widgets lie beyond the view; the wheel scrolls it too, but through
        # `PointerInput.apply_wheel` (not Dear ImGui's own wheel scrolling), which leaves the wheel to plots.
        self.window = dpg.add_child_window(
            width=-1,
            height=height,
            border=False,
            horizontal_scrollbar=True,
            no_scroll_with_mouse=True,
            drop_callback=self.on_drop,
            payload_type=PAYLOAD_TYPE,
        )
        # In a group placed at (0, 0), so that the layout cursor it leaves behind does not make the
        # scrolled area taller than the grid (a drawlist ignores `pos` itself).
        self.grid_group = dpg.add_group(parent=self.window, pos=(0, 0))
        self.grid_layer = dpg.add_drawlist(1, 1, parent=self.grid_group)

    def finish(self) -> None:
        """After the window is built: the unfilled themes, the backdrop and the overlay."""
        self.frame_theme = theme.frame_theme()
        self._frame_themes = {
            (False, True): self.frame_theme,
            (False, False): theme.frame_theme(filled=False),
            (True, True): theme.selected_frame_theme(),
            (True, False): theme.selected_frame_theme(filled=False),
        }
        """(selected, filled) -> the theme of a widget frame."""
        unfilled = theme.unfilled_child_theme()
        dpg.bind_item_theme(self.window, unfilled)
        dpg.bind_item_theme(self.tools.window, unfilled)
        self.paint = CanvasPaint(dpg.add_viewport_drawlist(front=False), self.grid_layer)
        self.overlay = dpg.add_viewport_drawlist(front=True)

    # -- coordinates ----------------------------------------------------------------------------------

    def pointer(self) -> tuple[float, float]:
        """The mouse position in window pixels (or `pointer_override`)."""
        if self.pointer_override is not None:
            return self.pointer_override
        x, y = dpg.get_mouse_pos(local=False)
        return float(x), float(y)

    def origin(self) -> tuple[float, float]:
        """The canvas's top-left corner in window pixels."""
        # A child window reports no screen rectangle; its first item, the grid layer at (0, 0), does.
        x, y = dpg.get_item_rect_min(self.grid_layer)
        return float(x), float(y)

    def size(self) -> tuple[int, int]:
        """The canvas's size in pixels."""
        w, h = dpg.get_item_rect_size(self.window)
        return int(w), int(h)

    def to_canvas(self, pos: tuple[float, float]) -> tuple[float, float]:
        """Convert window pixels to canvas pixels."""
        ox, oy = self.origin()
        return pos[0] - ox, pos[1] - oy

    def to_window(self, pos: tuple[float, float]) -> tuple[float, float]:
        """Convert canvas pixels to window pixels."""
        ox, oy = self.origin()
        return pos[0] + ox, pos[1] + oy

    def view_rect(self) -> Rect:
        """The part of the canvas in view, in canvas pixels (scrolling moves it)."""
        w, h = self.size()
        x, y = dpg.get_x_scroll(self.window), dpg.get_y_scroll(self.window)
        bar_w = theme.SCROLLBAR if dpg.get_y_scroll_max(self.window) > 0 else 0
        bar_h = theme.SCROLLBAR if dpg.get_x_scroll_max(self.window) > 0 else 0
        return Rect(float(x), float(y), float(max(1, w - bar_w)), float(max(1, h - bar_h)))

    def room_for(self, panel: str) -> Callable[[int], None]:
        """What `panel` (one beside the canvas) calls to narrow the canvas by so many pixels for itself (0: it
        is hidden); the canvas leaves room for every panel shown."""

        def make_room(pixels: int) -> None:
            self._rooms[panel] = max(0, pixels)
            total = sum(self._rooms.values())
            if self.window:  # (built: the window started)
                dpg.configure_item(self.window, width=-total if total > 0 else -1)

        return make_room

    def trash_rect(self) -> Rect:
        """The delete zone in window pixels."""
        return self.tools.trash_rect()

    # -- adding widgets -------------------------------------------------------------------------------

    def on_drop(self, sender: int | str, app_data: Any, user_data: Any = None) -> None:
        """Drop callback of the canvas: add the dragged widget type (or tree row) where the pointer is."""
        if isinstance(app_data, str):
            self.drop_widget(app_data, self.pointer())
            return
        pos = self.pointer()
        for handler in self.drop_handlers:
            if handler(app_data, pos):
                return

    def drop_widget(self, type_name: str, pos: tuple[float, float]) -> CanvasItem | None:
        """Add a widget of `type_name` at `pos` (window pixels) and open its topic setup."""
        item = self.add_widget(type_name, *self.to_canvas(pos))
        if item is not None:
            self.dialogs.topic(item)
        return item

    def add_widget(self, type_name: str, x: float, y: float, *, name: str | None = None) -> CanvasItem | None:
        """Place a new widget with its top-left corner near (x, y) on the canvas, selected and in view."""
        cls = self.registry.get(type_name)
        if cls is None:
            self.say(f"unknown widget type {type_name!r}")
            return None
        w, h = cls.default_size[0], cls.default_size[1] + TITLE_H
        rect = Rect(max(0.0, x - 20), max(0.0, y - TITLE_H / 2), float(w), float(h))
        doc = self.doc
        if doc.snap:
            rect = snap_rect(rect, doc.grid_size, min_w=cls.min_size[0], min_h=cls.min_size[1] + TITLE_H)
        # Never on top of another widget, nor off the visible canvas: the nearest free grid spot.
        rect = free_spot(
            rect, [i.rect for i in doc.items], self.view_rect(), doc.grid_size if doc.snap else 0
        )
        name = doc.unique_name(cls.label) if name is None else name
        bindings = (Binding(cls.default_topic),) if cls.default_topic else ()  # a console starts on /rosout
        props = cls.default_properties()
        config = WidgetConfig(type_name, name, rect.x, rect.y, rect.w, rect.h, bindings, props)
        item = doc.add(self.make_item(config, cls))
        self.select(item)
        self.reveal(item)
        doc.mark_dirty()
        return item

    def add_config(self, config: WidgetConfig) -> CanvasItem:
        """Place a ready-made widget (bindings and properties set) on the canvas and bind its series."""
        return self.doc.add(self.make_item(config, self.registry.get(config.type)))

    def add_plan(self, plan: NumberPlan) -> CanvasItem | None:
        """Add the widget "Plot this number" asked for, below the selected widget (or where there is room)."""
        near = self.selected.rect if self.selected is not None and self.selected in self.doc.items else None
        x, y = (near.x, near.y + near.h + 10 + TITLE_H / 2) if near is not None else (40.0, 40.0)
        item = self.add_widget(plan.type_name, x + 20, y)
        if item is None:
            return None
        self.doc.set_bindings(item, (plan.binding,))
        if plan.properties:
            item.set_properties(plan.properties)
        self.doc.rename(item, plan.name)
        self.say(f"added {plan.name!r}: {plan.binding.topic} /{plan.binding.regex}/")
        return item

    def open_log_console(self) -> CanvasItem | None:
        """View \u203a Log console: a Log widget on /rosout, in view where there is room."""
        view = self.view_rect()
        item = self.add_widget("log", view.x + 40, view.y + 40)
        if item is not None:
            self.say("a Log console on /rosout: its title's menu \u203a Topic setup for another topic")
        return item

    def load(self, result: LoadResult) -> None:
        """Replace every widget with a loaded dashboard's (the document's file state is the caller's)."""
        self.clear()
        for config in result.dashboard.widgets:
            cls = self.registry.get(config.type) if config.editable is not None else None
            if isinstance(config, RawWidget) and not result.legacy and config.type != "?":
                # The placeholder says what is missing: a plugin that failed to load, or none installed.
                config = RawWidget(config.data, self.registry.missing_reason(config.type))
            self.doc.add(self.make_item(config, cls))

    def make_item(self, config: WidgetConfig | RawWidget, cls: type[Widget] | None) -> CanvasItem:
        """A widget's frame on the canvas, with the window's publisher, host and time range."""
        return CanvasItem(
            config,
            cls,
            self.window,
            self.frame_theme,
            publisher=self.publisher,
            host=self.host,
            time_range=self.time_range,
        )

    def reveal(self, item: CanvasItem) -> None:
        """Scroll the canvas so that `item` is in view (over the next frames: a new widget's room in the
        scrolled area exists only once a frame has laid it out)."""
        self._reveal = (item, 10)

    # -- widget operations ----------------------------------------------------------------------------

    @property
    def selected(self) -> CanvasItem | None:
        """The highlighted widget."""
        return self.doc.selected

    def select(self, item: CanvasItem | None) -> None:
        """Highlight `item` (or nothing)."""
        before = self.doc.selected
        self.doc.selected = item
        for changed in (before, item):
            if changed is not None and changed in self.doc.items:  # the fill stays: `draw` decides it
                self._bind_frame(changed, filled=changed.frame_look[1])

    def bring_to_front(self, item: CanvasItem) -> None:
        """Draw `item` above the others."""
        if self.doc.to_front(item):
            dpg.move_item(item.window, parent=self.window)

    def delete(self, item: CanvasItem) -> None:
        """Remove a widget and release its series."""
        if not self.doc.remove(item):
            return
        self.dialogs.close_of(item)
        item.destroy()
        self.say(f"deleted {item.name!r}")

    def clear(self) -> None:
        """Remove every widget."""
        self.dialogs.close()
        for item in self.doc.clear():
            item.destroy()

    def change_type(self, item: CanvasItem, type_name: str) -> CanvasItem | None:
        """Swap `item` for a widget of another kind with the same name, place and bindings."""
        from dbglog.viewer._document._autodash import retype

        cls = self.registry.get(type_name)
        config = item.config.editable
        if cls is None or config is None or item not in self.doc.items:
            return None
        if type_name == config.type:
            return item
        config = retype(config, cls, min_frame=(cls.min_size[0], cls.min_size[1] + TITLE_H))
        new = self.make_item(config, cls)
        self.doc.replace(item, new)
        self.dialogs.close_of(item)
        item.destroy()
        self.select(new)
        self.say(f"{new.name!r} is now a {cls.label}")
        return new

    def set_snap(self, on: bool) -> None:
        """Switch snap-to-grid on or off."""
        self.doc.set_snap(on)
        self.show_grid_settings()

    def set_grid_size(self, size: int) -> None:
        """Change the grid spacing in pixels (5-400)."""
        self.doc.set_grid_size(size)
        self.show_grid_settings()

    def show_grid_settings(self) -> None:
        """Show the document's grid settings in the toolbox (the View menu shows them itself)."""
        self.tools.show_grid(self.doc.snap, self.doc.grid_size)

    def step_series(self, *, all_widgets: bool = False) -> list[Binding]:
        """The series the arrow keys step through: the selected widget's, or every widget's."""
        selected, items = self.selected, self.doc.items
        if not all_widgets and selected is not None and selected in items and selected.series:
            return list(selected.series)
        return list(dict.fromkeys(b for item in items for b in item.series))

    def step_owner(self) -> str | None:
        """The selected widget's name when it has series (the time keys' messages name it)."""
        selected = self.selected
        return selected.name if selected is not None and selected.series else None

    def typing(self) -> bool:
        """Whether a text field on the canvas (a control's, say) is being edited and so has the keyboard."""
        stack: list[int | str] = [item.window for item in self.doc.items]
        while stack:
            node = stack.pop()
            children = dpg.get_item_children(node, 1) or []
            stack.extend(children)
            kind = dpg.get_item_type(node)
            if kind.endswith(TEXT_ENTRY_TYPES) and dpg.is_item_active(node):
                return not (kind.endswith("mvInputText") and dpg.get_item_configuration(node).get("readonly"))
        return False

    # -- each frame -----------------------------------------------------------------------------------

    def in_view(self) -> list[CanvasItem]:
        """The widgets the canvas shows now, in drawing order: those out of view cost nothing (not read, not
        redrawn) and catch up when scrolled into view, since the timeline holds every series' state."""
        w, h = self.size()
        if w <= 1 or h <= 1:  # no frame rendered yet: no view to go by
            return list(self.doc.items)
        view = self.view_rect()
        return [item for item in self.doc.items if overlaps(view, item.rect)]

    def changed(self, at: float | None) -> bool:
        """Between frames: whether a widget in view changed (each series read once: `FrameSnapshots`)."""
        self.snaps.begin()
        return any(item.changed(self.snaps, paused_at=at) for item in self.in_view())

    def refresh(self, now: float, at: float | None) -> None:
        """Redraw the widgets in view whose series changed; a control that changed its value marks the doc."""
        for item in self.in_view():
            item.refresh(self.snaps, now, paused_at=at)
            if item.edited:  # a control changed its own saved value (a toggle switched, a slider moved)
                item.edited = False
                self.doc.mark_dirty()

    def draw(self, body: int | str, window: int | str, moving: CanvasItem | None) -> None:
        """Fit the window to the viewport, paint around the canvas, draw the grid (each only if changed),
        and scroll a new widget into view.

        Args:
            body: the group that starts with the toolbox (it has a position; the toolbox has none).
            window: the window holding everything.
            moving: the widget being dragged (the grid shows under it).
        """
        self.paint.fit_window(window)
        ox, oy = self.origin()
        w, h = self.size()
        (tx, ty), (tw, th) = dpg.get_item_rect_min(body), dpg.get_item_rect_size(self.tools.window)
        items = self.doc.items
        still = [i for i in items if i is not moving]  # widgets are opaque: no grid under them
        self.paint.draw_grid(
            (w, h),
            [i.rect for i in items],
            tuple(i.rect for i in still),
            self.doc.grid_size,
            self.doc.snap,
            toolbox_area=tw * th,
            settled=moving is None,
        )
        self.paint.draw_backdrop(Rect(ox, oy, w, h), Rect(tx, ty, tw, th))
        bare = {id(i) for i, b in zip(still, self.paint.bare, strict=True) if b}
        for item in items:
            self._bind_frame(item, filled=id(item) not in bare)
        self._scroll_to_reveal()

    def _scroll_to_reveal(self) -> None:
        if self._reveal is None:
            return
        item, tries = self._reveal
        self._reveal = (item, tries - 1) if tries > 1 and item in self.doc.items else None
        view = self.view_rect()
        x, y = reveal_scroll(item.rect, view)
        if (x, y) == (view.x, view.y):
            self._reveal = None
            return
        dpg.set_x_scroll(self.window, x)
        dpg.set_y_scroll(self.window, y)

    def _bind_frame(self, item: CanvasItem, *, filled: bool) -> None:
        """Give `item`'s frame its theme: selected or not, with a fill of its own or none (`CanvasPaint`)."""
        look = (item is self.selected, filled)
        if item.frame_look != look:
            item.frame_look = look
            dpg.bind_item_theme(item.window, self._frame_themes[look])

    # -- the widget commands --------------------------------------------------------------------------

    def register(self, actions: Actions) -> None:
        """Register the commands on the selected widget (the context menu and the Delete key run them)."""

        def on_selected(command: Callable[[CanvasItem], object]) -> Callable[[], None]:
            def run() -> None:
                item = self.selected
                if item is not None and item in self.doc.items:
                    command(item)

            return run

        def delete_key() -> None:
            if self.dialogs.current is None:  # not while a dialog is open
                on_selected(self.delete)()

        add = actions.register

        def known(item: CanvasItem) -> bool:  # a placeholder of a type not installed is kept as it is
            return item.widget_cls is not None

        add(
            "widget.topic_setup",
            "Topic setup\u2026",
            "Choose the widget's topics",
            on_selected(self.dialogs.topic),
            applies=known,
        )
        add(
            "widget.properties",
            "Properties\u2026",
            "The widget's properties",
            on_selected(self.dialogs.properties),
            applies=known,
        )
        add("widget.rename", "Rename\u2026", "Give the widget a new title", on_selected(self.dialogs.rename))
        add(
            "widget.to_front",
            "Bring to front",
            "Draw the widget above the others",
            on_selected(self.bring_to_front),
        )
        add(
            "widget.delete",
            "Delete",
            "Remove the selected widget",
            delete_key,
            keys=("Delete",),
            scope="canvas",  # in a text field, a dialog or a menu, Delete is theirs
        )
        add(
            "view.snap",
            "Snap to grid",
            "Widgets land on the grid when moved or resized",
            lambda: self.set_snap(not self.doc.snap),
            checked=lambda: self.doc.snap,
        )
        add(
            "view.log_console",
            "Log console",
            "A Log widget on /rosout, in view",
            self.open_log_console,
        )
