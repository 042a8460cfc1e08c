"""Pointer interaction on the canvas: select, move and resize by the title and grip, delete zone, menu, wheel.

The canvas (`Canvas`) owns the Dear PyGui items; this reads the mouse once per frame and edits the
document through the canvas's widget operations. Who the wheel is for is `WheelRoute`, plain logic.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._canvas import Canvas
from dbglog.viewer._ui._frame import GRIP, TITLE_H, CanvasItem
from dbglog.viewer._ui._menus import CONTEXT_MENU
from dbglog.viewer._widgets._geometry import Part, Rect, scroll_target, snap_rect

__all__ = ["LATCH_S", "MOVE_PX", "WHEEL_STEP", "Drag", "PointerInput", "WheelRoute"]

WHEEL_STEP = 60.0
"""Pixels the canvas scrolls per notch of the mouse wheel."""
LATCH_S = 1.0
"""A scroll of the canvas goes on for this long after its last notch (a plot sliding under the pointer
does not take the wheel meanwhile), unless the mouse moves."""
MOVE_PX = 4.0
"""A mouse move this long (pixels) ends a scroll of the canvas: the wheel is for what is under it again."""


class WheelRoute:
    """Who the wheel is for: the canvas scrolls, except over a plot, which zooms.

    As browsers and editors latch a scroll gesture, a scroll of the canvas stays the canvas's while the
    wheel keeps turning: a plot that slides under the pointer takes the wheel only once the wheel rested
    for `LATCH_S` or the mouse moved (`MOVE_PX`). Ctrl over a plot always zooms it.
    """

    def __init__(self, latch_s: float = LATCH_S, move_px: float = MOVE_PX) -> None:
        self.latch_s, self.move_px = latch_s, move_px
        self._scrolled_at = -math.inf
        self._scrolled_from = (math.nan, math.nan)

    def scrolled(self, now: float, pos: tuple[float, float]) -> None:
        """The wheel scrolled the canvas at `now` with the mouse at `pos` (window pixels)."""
        self._scrolled_at, self._scrolled_from = now, pos

    def latched(self, now: float, pos: tuple[float, float]) -> bool:
        """Whether a scroll of the canvas is under way (the wheel turned lately, the mouse kept still)."""
        moved = math.dist(pos, self._scrolled_from) if not math.isnan(self._scrolled_from[0]) else math.inf
        return now - self._scrolled_at < self.latch_s and moved < self.move_px

    def to_plot(self, now: float, pos: tuple[float, float], *, ctrl: bool) -> bool:
        """Whether a plot under the pointer at `pos` takes the wheel now (zooms) rather than the canvas."""
        return ctrl or not self.latched(now, pos)


@dataclass
class Drag:
    """A move (by the title) or a resize (by the grip) under way."""

    item: CanvasItem
    part: Part
    start: tuple[float, float]
    rect: Rect
    target: Rect


class PointerInput:
    """The mouse on the canvas: presses, drags, releases, the context menu and the wheel.

    Args:
        canvas: the canvas and its widgets.
        actions: the window's actions (the context menu's entries run them).
        dialog_open: whether a dialog is open (the canvas takes no clicks then).
        file_open: whether the file dialog is open (nor the wheel).
        held: whether a modifier key is down (Shift turns the wheel sideways, Ctrl zooms a plot).
        rendered: frames rendered so far.
        clock: monotonic seconds.
    """

    def __init__(
        self,
        canvas: Canvas,
        actions: Actions,
        *,
        dialog_open: Callable[[], bool],
        file_open: Callable[[], bool],
        held: Callable[[int], bool],
        rendered: Callable[[], int],
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.canvas, self.actions = canvas, actions
        self._dialog_open, self._file_open = dialog_open, file_open
        self._held, self._rendered, self._clock = held, rendered, clock
        self.drag: Drag | None = None
        """The move or resize under way, if any."""
        self._left_down = False
        self._right_down = False
        self._menu_shown = False
        """Whether the context menu was open at the last poll (ImGui closes it before a click is seen)."""
        self._wheel_lock = threading.Lock()
        self._wheel = 0.0
        """Mouse wheel turns not yet applied (the wheel handler adds them, the next frame scrolls)."""
        self._scroll_set: dict[int, tuple[int, float]] = {}
        """Axis (0 x, 1 y) -> (frames rendered when the wheel set it, the offset set)."""
        self.route = WheelRoute()
        self._under_key: tuple[object, ...] = ()
        self._under: CanvasItem | None = None
        """The plot under the pointer, as last looked for (`_under_key`: what it depends on)."""
        self._recheck_at: float | None = None
        """When a scroll of the canvas ends by itself (`wheel_due`)."""
        self.wheel_plot: CanvasItem | None = None
        """The plot the wheel zooms at the next frame (`WheelRoute`); None: the wheel scrolls the canvas."""
        self.menu: int | str = 0
        """The widgets' context menu (`build_menu`)."""
        self.type_entries: dict[str, int | str] = {}
        """Widget type -> its entry in the context menu (the widget's own type is shown selected)."""
        self.entries: dict[str, int | str] = {}
        """Action name -> its entry in the context menu (shown only on a widget the action applies to)."""

    def build_menu(self) -> None:
        """Create the widgets' context menu (hidden until a right click)."""
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
            for name in CONTEXT_MENU:
                self._menu_entry(name)
            with dpg.menu(label="Change widget type"):
                for cls in self.canvas.registry:
                    self.type_entries[cls.type_name] = dpg.add_selectable(
                        label=cls.label,
                        callback=lambda *_, t=cls.type_name: self.actions.call_soon(
                            lambda: self.menu_action(lambda: self._change_type(t))
                        ),
                    )
            dpg.add_separator()
            self._menu_entry("widget.delete")

    def _menu_entry(self, name: str) -> None:
        action = self.actions[name]
        self.entries[name] = dpg.add_menu_item(
            label=action.label,
            shortcut=action.shortcut,
            callback=lambda *_: self.actions.call_soon(lambda: self.menu_action(action.run)),
        )

    def _change_type(self, type_name: str) -> None:
        item = self.canvas.selected
        if item is not None:
            self.canvas.change_type(item, type_name)

    def hide_menu(self) -> None:
        """Close the context menu."""
        if dpg.does_item_exist(self.menu):
            dpg.hide_item(self.menu)

    def menu_shown(self) -> bool:
        """Whether the context menu is open."""
        return bool(dpg.is_item_shown(self.menu))

    def menu_action(self, action: Callable[[], object]) -> None:
        """A context menu entry (UI thread): close the menu and act on the widget it was opened on."""
        dpg.hide_item(self.menu)
        action()

    def over_canvas(self, pos: tuple[float, float]) -> bool:
        """Whether `pos` (window pixels) is over the visible canvas and nothing covers it there."""
        canvas = self.canvas
        # The visible part of the canvas: its origin moves up and left as it scrolls.
        ox, oy = canvas.origin()
        sx, sy = dpg.get_x_scroll(canvas.window), dpg.get_y_scroll(canvas.window)
        w, h = canvas.size()
        if not Rect(ox + sx, oy + sy, w, h).contains(*pos):
            return False
        if canvas.pointer_override is not None:
            return True
        return bool(
            dpg.is_item_hovered(canvas.window) or any(dpg.is_item_hovered(i.window) for i in canvas.doc.items)
        )

    def poll(self) -> None:
        """Once a frame: turn the buttons' changes into a press, a drag, a release or the context menu."""
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        right = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Right))
        if self.canvas.pointer_override is None:
            pos = self.canvas.pointer()
            if left and not self._left_down:
                self._on_left_press(pos)
            elif left and self.drag is not None:
                self.drag_to(pos)
            elif not left and self._left_down and self.drag is not None:
                self.release(pos)
            pressed = right and not self._right_down and not self._dialog_open()
            # A widget may keep its right clicks (a console's line menu); its title strip always opens this.
            if pressed and self.over_canvas(pos) and not self.widget_owns(pos):
                self.context_menu(pos)
        self._left_down, self._right_down = left, right
        self._menu_shown = self.menu_shown()

    def _on_left_press(self, pos: tuple[float, float]) -> None:
        if self._menu_shown or self.menu_shown():
            return  # a click in the context menu, or one that closes it, is not a click on the canvas
        if self._dialog_open() or not self.over_canvas(pos):
            return
        self.press(pos)

    def press(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Press the left button at `pos` (window pixels): select, and start a move or resize on a handle."""
        canvas = self.canvas
        cx, cy = canvas.to_canvas(pos)
        hit = canvas.doc.hit(cx, cy, title_h=TITLE_H, corner=GRIP + 4)
        if hit is None:
            canvas.select(None)
            return None
        item, part = hit
        canvas.select(item)
        canvas.bring_to_front(item)
        if part in (Part.TITLE, Part.CORNER):
            self.drag = Drag(item, part, (cx, cy), item.rect, item.rect)
        return item

    def drag_to(self, pos: tuple[float, float]) -> None:
        """Move the pointer with the button held: the widget follows, the outline shows where it will land."""
        drag, canvas = self.drag, self.canvas
        if drag is None:
            return
        cx, cy = canvas.to_canvas(pos)
        dx, dy = cx - drag.start[0], cy - drag.start[1]
        mw, mh = drag.item.min_size
        if drag.part is Part.TITLE:
            rect = drag.rect.moved(dx, dy)
            drag.item.place(rect, rebuild=False)
        else:
            rect = drag.rect.resized(dx, dy, mw, mh)
            dpg.configure_item(drag.item.window, width=int(rect.w), height=int(rect.h))
        doc = canvas.doc
        drag.target = snap_rect(rect, doc.grid_size, min_w=mw, min_h=mh) if doc.snap else rect
        over_trash = drag.part is Part.TITLE and canvas.trash_rect().contains(*pos)
        canvas.tools.hot(over_trash)
        dpg.delete_item(canvas.overlay, children_only=True)
        if not over_trash:
            ox, oy = canvas.origin()
            t = drag.target
            dpg.draw_rectangle(
                (ox + t.x, oy + t.y),
                (ox + t.x + t.w, oy + t.y + t.h),
                color=theme.ACCENT,
                fill=(86, 166, 240, 28),
                thickness=2,
                rounding=6,
                parent=canvas.overlay,
            )

    def release(self, pos: tuple[float, float]) -> None:
        """Let go: the widget lands on the outline, or is deleted over the delete zone."""
        drag, canvas = self.drag, self.canvas
        if drag is None:
            return
        self.drag_to(pos)
        self.drag = None
        dpg.delete_item(canvas.overlay, children_only=True)
        canvas.tools.hot(False)
        if drag.part is Part.TITLE and canvas.trash_rect().contains(*pos):
            canvas.delete(drag.item)
            return
        if drag.target != drag.rect:
            drag.item.place(drag.target, rebuild=True)
            canvas.doc.mark_dirty()
        else:
            drag.item.place(drag.rect, rebuild=drag.part is Part.CORNER)

    def _body_hit(self, pos: tuple[float, float]) -> CanvasItem | None:
        """The working widget whose body is under `pos` (window pixels), or None."""
        hit = self.canvas.doc.hit(*self.canvas.to_canvas(pos), title_h=TITLE_H, corner=0)
        if hit is None or hit[1] is not Part.BODY or hit[0].widget is None or hit[0].failed:
            return None
        return hit[0]

    def widget_owns(self, pos: tuple[float, float]) -> bool:
        """Whether the widget body under `pos` (window pixels) keeps the mouse (`Widget.owns_pointer`)."""
        item = self._body_hit(pos)
        if item is None or item.widget is None:
            return False
        try:
            return bool(item.widget.owns_pointer(*pos))
        except Exception:  # a widget's bug never takes the canvas's mouse away
            return False

    def context_menu(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Open the widget's context menu at `pos` (right click)."""
        canvas = self.canvas
        hit = canvas.doc.hit(*canvas.to_canvas(pos), title_h=TITLE_H, corner=0)
        if hit is None:
            return None
        item = hit[0]
        canvas.select(item)
        for type_name, entry in self.type_entries.items():
            dpg.set_value(entry, type_name == item.config.type)
        for name, entry in self.entries.items():
            applies = self.actions[name].applies
            dpg.configure_item(entry, show=applies is None or bool(applies(item)))
        dpg.configure_item(self.menu, pos=(int(pos[0]), int(pos[1])), show=True)
        return item

    # -- the wheel ------------------------------------------------------------------------------------

    def on_wheel(self, delta: float) -> None:
        """Mouse wheel handler: keep the turn; the next frame scrolls the canvas with it (`apply_wheel`)."""
        with self._wheel_lock:
            self._wheel += float(delta)

    def _zoomable(self, pos: tuple[float, float]) -> CanvasItem | None:
        """The plot (a widget that takes the wheel: ``allow_wheel``) whose area is under `pos`, or None."""
        item = self._body_hit(pos)
        widget = item.widget if item is not None else None
        if item is None or widget is None or not callable(getattr(widget, "allow_wheel", None)):
            return None
        try:
            return item if widget.owns_pointer(*pos) else None
        except Exception:  # a widget's bug never takes the canvas's mouse away
            return None

    def wheel_due(self, now: float) -> bool:
        """Whether a frame is due to hand the wheel back to the plot under a still pointer: a scroll of the
        canvas just ended (`LATCH_S` without a notch), which no input shows."""
        if self._recheck_at is None or now < self._recheck_at:
            return False
        self._recheck_at = None
        return True

    def apply_wheel(self) -> None:
        """Scroll the canvas by the wheel turns since the last frame, unless a plot took them (`WheelRoute`);
        then tell the plot under the pointer whether the wheel is its own at the next frame.

        Over another widget that keeps the mouse (a console's rows) the wheel is the widget's; in a dialog or
        menu it is theirs. Shift turns it sideways.
        """
        with self._wheel_lock:
            turns, self._wheel = self._wheel, 0.0
        now = self._clock()
        pos = self.canvas.pointer()
        blocked = self._file_open() or self.menu_shown()
        # What lies under the pointer changes only when it moves, the canvas scrolls or widgets come and go.
        key = (pos, self.canvas.origin(), tuple(map(id, self.canvas.doc.items)))
        if turns or key != self._under_key:
            self._under_key, self._under = key, self._zoomable(pos)
        plot = None if blocked else self._under
        ctrl = plot is not None and self._held(dpg.mvKey_ModCtrl)
        take = plot if plot is not None and self.route.to_plot(now, pos, ctrl=ctrl) else None
        # Turns the plot took (it was told last frame), or that are its own now, never scroll the canvas.
        scrolls = turns and not blocked and self.wheel_plot is None and take is None and self.over_canvas(pos)
        if scrolls and (plot is not None or not self.widget_owns(pos)):
            self._scroll(turns)
            self.route.scrolled(now, pos)
            self._recheck_at = now + self.route.latch_s
        if take is not self.wheel_plot:
            for item, on in ((self.wheel_plot, False), (take, True)):
                allow = getattr(item.widget, "allow_wheel", None) if item is not None else None
                if callable(allow) and item is not None and item in self.canvas.doc.items:
                    with contextlib.suppress(Exception):  # a widget's bug never takes the canvas's wheel
                        allow(on)
            self.wheel_plot = take

    def _scroll(self, turns: float) -> None:
        canvas = self.canvas.window
        axis = 0 if self._held(dpg.mvKey_ModShift) else 1
        get, top, put = (
            (dpg.get_x_scroll, dpg.get_x_scroll_max, dpg.set_x_scroll),
            (dpg.get_y_scroll, dpg.get_y_scroll_max, dpg.set_y_scroll),
        )[axis]
        # Dear ImGui applies a scroll a frame after it is set, and reports it a frame later still: go on
        # from the offset set last, not from the one reported, until it shows.
        pending = self._scroll_set.get(axis)
        now = float(get(canvas))
        rendered = self._rendered()
        if pending is not None and now != pending[1] and rendered - pending[0] <= 10:
            now = pending[1]
        target = scroll_target(now, turns, top(canvas), WHEEL_STEP)
        put(canvas, target)
        self._scroll_set[axis] = (rendered, target)
