"""Pointer interaction on the canvas: select, move and resize by the title and grip, delete zone, menu, wheel.

The window (`ViewerApp`) owns the Dear PyGui items; this reads the mouse once per frame and edits the
document through the window's widget operations.
"""

from __future__ import annotations

import threading
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._frame import GRIP, TITLE_H, CanvasItem
from dbglog.viewer._widgets._geometry import Part, Rect, scroll_target, snap_rect

if TYPE_CHECKING:
    from dbglog.viewer._ui._app import ViewerApp

__all__ = ["WHEEL_STEP", "Drag", "PointerInput"]

WHEEL_STEP = 60.0
"""Pixels the canvas scrolls per notch of the mouse wheel."""


@dataclass
class Drag:
    """A move (by the title) or a resize (by the grip) under way."""

    item: CanvasItem
    part: Part
    start: tuple[float, float]
    rect: Rect
    target: Rect


class PointerInput:
    """The mouse on the canvas: presses, drags, releases, the context menu and the wheel."""

    def __init__(self, app: ViewerApp) -> None:
        self.app = app
        self.drag: Drag | None = None
        """The move or resize under way, if any."""
        self._left_down = False
        self._right_down = False
        self._menu_item: CanvasItem | None = None
        self._menu_shown = False
        """Whether the context menu was open at the last poll (ImGui closes it before a click is seen)."""
        self._wheel_lock = threading.Lock()
        self._wheel = 0.0
        """Mouse wheel turns not yet applied (the wheel handler adds them, the next frame scrolls)."""
        self._scroll_set: dict[int, tuple[int, float]] = {}
        """Axis (0 x, 1 y) -> (frames rendered when the wheel set it, the offset set)."""
        self.menu: int | str = 0
        """The widgets' context menu (`build_menu`)."""
        self.type_entries: dict[str, int | str] = {}
        """Widget type -> its entry in the context menu (the widget's own type is shown selected)."""

    def build_menu(self) -> None:
        """Create the widgets' context menu (hidden until a right click)."""
        app = self.app
        # A real popup: Dear ImGui keeps its submenu part of it (a click there is a click in the menu), and
        # closes the whole menu on a click outside it.
        with dpg.window(
            popup=True,
            show=False,
            no_title_bar=True,
            no_move=True,
            no_resize=True,
            autosize=True,
            no_saved_settings=True,
            min_size=(170, 20),
        ) as menu:
            self.menu = menu
            on_item = self.menu_action
            dpg.add_menu_item(
                label="Topic setup\u2026",
                callback=lambda *_: on_item(app.open_topic_dialog),
            )
            dpg.add_menu_item(
                label="Properties\u2026",
                callback=lambda *_: on_item(app.open_properties_dialog),
            )
            dpg.add_menu_item(
                label="Rename\u2026",
                callback=lambda *_: on_item(app.open_rename_dialog),
            )
            dpg.add_menu_item(
                label="Bring to front",
                callback=lambda *_: on_item(app.bring_to_front),
            )
            with dpg.menu(label="Change widget type"):
                for cls in app.registry:
                    self.type_entries[cls.type_name] = dpg.add_selectable(
                        label=cls.label,
                        callback=lambda *_, t=cls.type_name: on_item(lambda i: app.change_type(i, t)),
                    )
            dpg.add_separator()
            dpg.add_menu_item(
                label="Delete",
                shortcut="Del",
                callback=lambda *_: on_item(app.delete_item),
            )

    def over_canvas(self, pos: tuple[float, float]) -> bool:
        """Whether `pos` (window pixels) is over the visible canvas and nothing covers it there."""
        app = self.app
        # The visible part of the canvas: its origin moves up and left as it scrolls.
        ox, oy = app.canvas_origin()
        sx, sy = dpg.get_x_scroll(app.canvas), dpg.get_y_scroll(app.canvas)
        w, h = app.canvas_size()
        if not Rect(ox + sx, oy + sy, w, h).contains(*pos):
            return False
        if app.pointer_override is not None:
            return True
        return bool(dpg.is_item_hovered(app.canvas) or any(dpg.is_item_hovered(i.window) for i in app.items))

    def poll(self) -> None:
        """Once a frame: turn the buttons' changes into a press, a drag, a release or the context menu."""
        app = self.app
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        right = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Right))
        if app.pointer_override is None:
            pos = app.pointer()
            if left and not self._left_down:
                self._on_left_press(pos)
            elif left and self.drag is not None:
                self.drag_to(pos)
            elif not left and self._left_down and self.drag is not None:
                self.release(pos)
            pressed = right and not self._right_down and app.dialog is None
            # A widget may keep its right clicks (a console's line menu); its title strip always opens this.
            if pressed and self.over_canvas(pos) and not self.widget_owns(pos):
                self.context_menu(pos)
        self._left_down, self._right_down = left, right
        self._menu_shown = bool(dpg.is_item_shown(app.menu))

    def _on_left_press(self, pos: tuple[float, float]) -> None:
        if self._menu_shown or dpg.is_item_shown(self.app.menu):
            return  # a click in the context menu, or one that closes it, is not a click on the canvas
        if self.app.dialog is not None or not self.over_canvas(pos):
            return
        self.press(pos)

    def press(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Press the left button at `pos` (window pixels): select, and start a move or resize on a handle."""
        app = self.app
        cx, cy = app.to_canvas(pos)
        hit = app.doc.hit(cx, cy, title_h=TITLE_H, corner=GRIP + 4)
        if hit is None:
            app.select(None)
            return None
        item, part = hit
        app.select(item)
        app.bring_to_front(item)
        if part in (Part.TITLE, Part.CORNER):
            self.drag = Drag(item, part, (cx, cy), item.rect, item.rect)
        return item

    def drag_to(self, pos: tuple[float, float]) -> None:
        """Move the pointer with the button held: the widget follows, the outline shows where it will land."""
        drag, app = self.drag, self.app
        if drag is None:
            return
        cx, cy = app.to_canvas(pos)
        dx, dy = cx - drag.start[0], cy - drag.start[1]
        mw, mh = drag.item.min_size
        if drag.part is Part.TITLE:
            rect = drag.rect.moved(dx, dy)
            drag.item.place(rect, rebuild=False)
        else:
            rect = drag.rect.resized(dx, dy, mw, mh)
            dpg.configure_item(drag.item.window, width=int(rect.w), height=int(rect.h))
        drag.target = snap_rect(rect, app.doc.grid_size, min_w=mw, min_h=mh) if app.doc.snap else rect
        over_trash = drag.part is Part.TITLE and app.trash_rect().contains(*pos)
        app.tools.hot(over_trash)
        dpg.delete_item(app.overlay, children_only=True)
        if not over_trash:
            ox, oy = app.canvas_origin()
            t = drag.target
            dpg.draw_rectangle(
                (ox + t.x, oy + t.y),
                (ox + t.x + t.w, oy + t.y + t.h),
                color=theme.ACCENT,
                fill=(86, 166, 240, 28),
                thickness=2,
                rounding=6,
                parent=app.overlay,
            )

    def release(self, pos: tuple[float, float]) -> None:
        """Let go: the widget lands on the outline, or is deleted over the delete zone."""
        drag, app = self.drag, self.app
        if drag is None:
            return
        self.drag_to(pos)
        self.drag = None
        dpg.delete_item(app.overlay, children_only=True)
        app.tools.hot(False)
        if drag.part is Part.TITLE and app.trash_rect().contains(*pos):
            app.delete_item(drag.item)
            return
        if drag.target != drag.rect:
            drag.item.place(drag.target, rebuild=True)
            app.doc.mark_dirty()
        else:
            drag.item.place(drag.rect, rebuild=drag.part is Part.CORNER)

    def widget_owns(self, pos: tuple[float, float]) -> bool:
        """Whether the widget body under `pos` (window pixels) keeps the mouse (`Widget.owns_pointer`)."""
        app = self.app
        hit = app.doc.hit(*app.to_canvas(pos), title_h=TITLE_H, corner=0)
        if hit is None or hit[1] is not Part.BODY:
            return False
        widget = hit[0].widget
        if widget is None or hit[0].failed:
            return False
        try:
            return bool(widget.owns_pointer(*pos))
        except Exception:  # a widget's bug never takes the canvas's mouse away
            return False

    def context_menu(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Open the widget's context menu at `pos` (right click)."""
        app = self.app
        hit = app.doc.hit(*app.to_canvas(pos), title_h=TITLE_H, corner=0)
        if hit is None:
            return None
        item = hit[0]
        app.select(item)
        self._menu_item = item
        for type_name, entry in self.type_entries.items():
            dpg.set_value(entry, type_name == item.config.type)
        dpg.configure_item(app.menu, pos=(int(pos[0]), int(pos[1])), show=True)
        return item

    def menu_action(self, action: Callable[[CanvasItem], object]) -> None:
        """A context menu entry: close the menu and apply `action` to the widget it was opened on."""
        dpg.hide_item(self.app.menu)
        if self._menu_item is not None and self._menu_item in self.app.items:
            action(self._menu_item)

    def on_wheel(self, delta: float) -> None:
        """Mouse wheel handler: keep the turn; the next frame scrolls the canvas with it (`apply_wheel`)."""
        with self._wheel_lock:
            self._wheel += float(delta)

    def apply_wheel(self) -> None:
        """Scroll the canvas by the wheel turns since the last frame when the pointer is over its background.

        Over a plot's body the wheel is the plot's (its zoom); in a dialog or menu it is theirs. Shift turns
        it sideways.
        """
        app = self.app
        with self._wheel_lock:
            turns, self._wheel = self._wheel, 0.0
        if not turns or app.files.request is not None or dpg.is_item_shown(app.menu):
            return
        pos = app.pointer()
        if not self.over_canvas(pos):
            return
        hit = app.doc.hit(*app.to_canvas(pos), title_h=TITLE_H, corner=0)
        if hit is not None and hit[1] is Part.BODY and hit[0].config.type == "plot":
            return
        if self.widget_owns(pos):
            return
        axis = 0 if app.held(dpg.mvKey_ModShift) else 1
        get, top, put = (
            (dpg.get_x_scroll, dpg.get_x_scroll_max, dpg.set_x_scroll),
            (dpg.get_y_scroll, dpg.get_y_scroll_max, dpg.set_y_scroll),
        )[axis]
        # Dear ImGui applies a scroll a frame after it is set, and reports it a frame later still: go on
        # from the offset set last, not from the one reported, until it shows.
        pending = self._scroll_set.get(axis)
        now = float(get(app.canvas))
        if pending is not None and now != pending[1] and app.rendered - pending[0] <= 10:
            now = pending[1]
        target = scroll_target(now, turns, top(app.canvas), WHEEL_STEP)
        put(app.canvas, target)
        self._scroll_set[axis] = (app.rendered, target)
