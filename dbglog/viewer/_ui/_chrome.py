"""The window's fixed parts: the toolbox (widget buttons, layout settings, delete zone) and the canvas's
backdrop and grid, each redrawn only when what it shows changed."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer._widgets._geometry import (
    Rect,
    canvas_extent,
    corner_fans,
    overlapped,
    panels_on_clear,
    rects_outside,
    uncovered,
)

__all__ = ["PAYLOAD_TYPE", "TOOLBOX_W", "CanvasPaint", "Toolbox"]

PAYLOAD_TYPE = "dbglog-widget"
"""Drag payload type of the toolbox buttons; the canvas accepts only this."""
TOOLBOX_W = 190


def _corners(r: Rect) -> tuple[float, float, float, float]:
    return r.x, r.y, r.w, r.h


def _fill(r: Rect, color: tuple[int, int, int, int], parent: int | str) -> None:
    dpg.draw_rectangle((r.x, r.y), (r.x + r.w, r.y + r.h), color=theme.NO_FILL, fill=color, parent=parent)


class Toolbox:
    """The toolbox column: a button per widget type to drag onto the canvas, the grid settings, the trash.

    Built where it is created (inside the window's body group).
    """

    def __init__(
        self,
        registry: WidgetRegistry,
        *,
        snap: bool,
        grid_size: int,
        height: int,
        on_snap: Callable[[bool], None],
        on_grid_size: Callable[[int], None],
    ) -> None:
        with dpg.child_window(width=TOOLBOX_W, height=height, border=False, no_scrollbar=True) as self.window:
            dpg.add_text("WIDGETS", color=theme.DIM)
            self.buttons: dict[str, int | str] = {}
            """Widget type -> its button."""
            for cls in registry:
                button = dpg.add_button(label=cls.label, width=-1, height=32)
                with dpg.drag_payload(parent=button, payload_type=PAYLOAD_TYPE, drag_data=cls.type_name):
                    dpg.add_text(f"+ {cls.label}")
                with dpg.tooltip(button):
                    dpg.add_text(cls.description or cls.label)
                    dpg.add_text("Drag onto the canvas", color=theme.DIM)
                self.buttons[cls.type_name] = button
            dpg.add_spacer(height=6)
            dpg.add_separator()
            dpg.add_text("LAYOUT", color=theme.DIM)
            self.snap_box = dpg.add_checkbox(
                label="Snap to grid", default_value=snap, callback=lambda s, a: on_snap(bool(a))
            )
            self.grid_slider = dpg.add_slider_int(
                label="px",
                default_value=grid_size,
                min_value=5,
                max_value=80,
                width=120,
                callback=lambda s, a: on_grid_size(int(a)),
            )
            dpg.add_spacer(height=6)
            with dpg.child_window(height=84, border=True, no_scrollbar=True) as self.trash:
                self.trash_art = dpg.add_drawlist(TOOLBOX_W - 20, 62)
                self._draw_trash()
            error = theme.STATUS_COLORS[next(s for s in theme.STATUS_COLORS if s.value == "error")]
            with dpg.theme() as self.trash_hot, dpg.theme_component(dpg.mvChildWindow):
                dpg.add_theme_color(dpg.mvThemeCol_ChildBg, (110, 40, 40, 255), category=dpg.mvThemeCat_Core)
                dpg.add_theme_color(dpg.mvThemeCol_Border, error, category=dpg.mvThemeCat_Core)
            if registry.problems:
                dpg.add_spacer(height=6)
                dpg.add_text("Plugin problems", color=error)
                for problem in registry.problems:
                    dpg.add_text(problem, wrap=TOOLBOX_W - 16, color=theme.DIM)

    def _draw_trash(self) -> None:
        dl = self.trash_art
        cx = 26
        body = theme.DIM
        dpg.draw_rectangle((cx - 9, 22), (cx + 9, 46), color=body, thickness=2, rounding=2, parent=dl)
        dpg.draw_line((cx - 13, 18), (cx + 13, 18), color=body, thickness=2, parent=dl)
        dpg.draw_line((cx - 4, 14), (cx + 4, 14), color=body, thickness=2, parent=dl)
        for dx in (-4, 0, 4):
            dpg.draw_line((cx + dx, 26), (cx + dx, 42), color=body, parent=dl)
        dpg.draw_text((48, 14), "Delete zone", size=15, color=theme.TEXT, parent=dl)
        dpg.draw_text((48, 34), "drop a widget here", size=13, color=body, parent=dl)

    def trash_rect(self) -> Rect:
        """The delete zone in window pixels."""
        (x, y), (w, h) = dpg.get_item_rect_min(self.trash_art), dpg.get_item_rect_size(self.trash_art)
        return Rect(float(x), float(y), float(w), float(h))

    def hot(self, on: bool) -> None:
        """Show the delete zone armed (a widget dragged over it) or not."""
        dpg.bind_item_theme(self.trash, self.trash_hot if on else 0)

    def show_grid(self, snap: bool, grid_size: int) -> None:
        """Show the grid settings."""
        dpg.set_value(self.snap_box, snap)
        dpg.set_value(self.grid_slider, min(80, grid_size))


class CanvasPaint:
    """The window colour around the canvas and toolbox (the backdrop) and the canvas's grid.

    A dashboard of close widgets is drawn on a canvas cleared to the panels' colour (`on_panel`): the
    canvas colour is painted only where no widget lies (and in their rounded corners), and the widgets'
    frames have no fill of their own. That is the same picture with far fewer pixels shaded, which is
    most of a frame's cost on a software renderer; a sparse dashboard is drawn the usual way.
    """

    def __init__(self, backdrop: int | str, grid_layer: int | str) -> None:
        self.backdrop, self.grid_layer = backdrop, grid_layer
        self.window_size = (0, 0)
        """The viewport's client size in pixels, as last fitted."""
        self.on_panel = False
        """Whether the viewport is cleared to the panel colour (widget frames then go unfilled)."""
        self.bare: tuple[bool, ...] = ()
        """For each still frame last drawn (`draw_grid`'s `covers`), whether it goes without a fill."""
        self.panel_clear = True
        """Whether a dense dashboard may be drawn on a panel-coloured canvas (False: every frame fills
        itself, as before; `benchmarks/bench_timetravel.py` compares the two)."""
        self._backdrop_key: tuple[object, ...] | None = None
        self._grid_key: tuple[object, ...] | None = None
        dpg.set_viewport_clear_color(theme.CANVAS)

    def fit_window(self, window: int | str) -> None:
        """Make `window` as large as the viewport (it has no background of its own to fill)."""
        size = (dpg.get_viewport_client_width(), dpg.get_viewport_client_height())
        if size != self.window_size and size[0] > 0 and size[1] > 0:
            self.window_size = size
            dpg.configure_item(window, width=size[0], height=size[1])

    def draw_backdrop(self, canvas: Rect, toolbox: Rect) -> None:
        """Paint the window colour everywhere but over the canvas and the toolbox (and the canvas colour
        under the toolbox while the viewport is cleared to the panel colour)."""
        key = (*self.window_size, *_corners(canvas), *_corners(toolbox), self.on_panel)
        if key == self._backdrop_key:
            return
        self._backdrop_key = key
        dpg.delete_item(self.backdrop, children_only=True)
        if self.on_panel:
            _fill(toolbox, theme.CANVAS, self.backdrop)
        outer = Rect(0, 0, float(self.window_size[0]), float(self.window_size[1]))
        for r in rects_outside(outer, (canvas, toolbox)):
            dpg.draw_rectangle(
                (r.x, r.y), (r.x + r.w, r.y + r.h), color=theme.BG, fill=theme.BG, parent=self.backdrop
            )

    def draw_grid(
        self,
        view: tuple[int, int],
        rects: Sequence[Rect],
        covers: tuple[Rect, ...],
        grid_size: int,
        snap: bool,
        *,
        toolbox_area: float = 0.0,
        settled: bool = True,
    ) -> None:
        """Draw the grid over the whole scrolled area, except under `covers` (only when something moved).

        Args:
            view: the canvas's visible size.
            rects: every widget's frame.
            covers: the frames that lie still (a dragged one aside).
            grid_size: the grid step in pixels.
            snap: whether widgets snap to it (the grid is brighter then).
            toolbox_area: pixels of canvas colour painted under the toolbox while `on_panel`.
            settled: no widget is being dragged: `on_panel` is decided again (a drag keeps it as it was,
                rather than flip every frame's look while the widget moves).
        """
        view_w, view_h = view
        if view_w <= 0:
            self.bare = (False,) * len(covers)
            return
        extent = canvas_extent(view_w, view_h, rects, theme.SCROLLBAR)
        w, h = int(extent[0]), int(extent[1])
        key = (w, h, *view, grid_size, snap, bool(rects), covers, toolbox_area, self.panel_clear)
        if key == self._grid_key:
            return
        self._grid_key = key
        layer = self.grid_layer
        dpg.delete_item(layer, children_only=True)
        dpg.configure_item(layer, width=max(1, w), height=max(1, h))
        area = Rect(0, 0, w, h)
        keeps = overlapped(covers)  # one over another keeps its fill, or the one below would show through
        on_panel = self.on_panel  # a drag keeps the look
        if settled:
            on_panel = self.panel_clear and panels_on_clear(area, covers, keeps, toolbox_area)
        if on_panel != self.on_panel:
            self.on_panel = on_panel
            dpg.set_viewport_clear_color(theme.PANEL if on_panel else theme.CANVAS)
        self.bare = tuple(on_panel and not k for k in keeps)
        if on_panel:
            for r in rects_outside(area, covers):
                _fill(r, theme.CANVAS, layer)
        for r, bare in zip(covers, self.bare, strict=True):
            if bare:
                for p1, p2, p3 in corner_fans(r, theme.FRAME_ROUNDING):
                    dpg.draw_triangle(p1, p2, p3, color=theme.NO_FILL, fill=theme.CANVAS, parent=layer)
        step = grid_size
        while w / step > 160 or h / step > 160:
            step *= 2
        color = theme.GRID if snap else (31, 34, 41, 255)
        for x in range(0, w, step):
            spans = [(r.y, r.y + r.h) for r in covers if r.x <= x - 1 and x + 1 <= r.x + r.w]
            for a, b in uncovered(0, h, spans):
                dpg.draw_line((x, a), (x, b), color=color, parent=layer)
        for y in range(0, h, step):
            spans = [(r.x, r.x + r.w) for r in covers if r.y <= y - 1 and y + 1 <= r.y + r.h]
            for a, b in uncovered(0, w, spans):
                dpg.draw_line((a, y), (b, y), color=color, parent=layer)
        if not rects:
            msg = "Drag a widget from the toolbox onto the canvas"
            at = (view_w / 2 - len(msg) * 4.6, view_h / 2 - 10)
            dpg.draw_text(at, msg, size=17, color=theme.DIM, parent=layer)
