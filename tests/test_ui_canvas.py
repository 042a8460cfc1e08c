"""The canvas under Xvfb, driven with the real mouse (xdotool): wheel scrolling, the resize grip, drops.

Each test starts the real `ViewerApp.run` loop in a process of its own. A frame hook there reports what is
on screen (widgets and toolbox buttons in window pixels, the scroll offsets, the status bar) to a JSON
file and answers screenshot requests; this process moves, clicks, drags and turns the wheel with xdotool
(XTEST: the same events a real mouse makes). Nothing here calls a handler or callback directly.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import pytest

from tests._ros import wait_until
from tests._viewer_child import ViewerChild, in_view
from tests.test_ui_menus import _menubar

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parent.parent
WAIT_S = 30.0
"""How long the viewer may take to show what the mouse asked for (generous for a loaded CI machine)."""
SIZE = (1000, 700)  # the canvas: 700 less the menu, timeline and status bars


# -- the child: a real viewer whose frame hook reports what is on screen ---------------------------------


def canvas_dashboard(tmp: Path) -> Path:
    """A dial and a plot at the top, and an LED far below the view (so the canvas scrolls)."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    widgets = [
        WidgetConfig("dial", "Gauge", 40, 40, 220, 240, (), {}),
        WidgetConfig("plot", "Trend", 400, 40, 360, 240, (Binding("/t/x", "data"),), {}),
        WidgetConfig("led", "Far", 40, 1000, 140, 180, (), {}),
    ]
    path = tmp / "dash.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


def dense_dashboard(tmp: Path) -> Path:
    """Six widgets that fill the view, and an LED on top of the last one (a file may hold that)."""
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    widgets = [
        WidgetConfig(kind, name, x, y, 240, 260, (), {})
        for (kind, name), (x, y) in zip(
            (
                ("dial", "Gauge"),
                ("thermo", "Thermo"),
                ("compass", "Heading"),
                ("string", "Text"),
                ("knob", "Knob"),
                ("dial", "Under"),
            ),
            ((20, 20), (280, 20), (540, 20), (20, 300), (280, 300), (540, 300)),
            strict=True,
        )
    ]
    widgets.append(WidgetConfig("led", "Over", 620, 400, 140, 140, (), {}))
    path = tmp / "dense.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


def span_of(widget: Any) -> float | None:
    """The seconds a plot shows (None for another widget, or before it drew)."""
    shown = widget.visible_range() if hasattr(widget, "visible_range") else None
    return None if shown is None else float(shown[1] - shown[0])


def rect_of(item: int | str) -> list[float]:
    """An item's [x, y, w, h] in window pixels, as last drawn."""
    import dearpygui.dearpygui as dpg

    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


class Probe:
    """Frame hook: writes the viewer's visible state to `state.json` whenever it changes."""

    def __init__(self, app: Any, tmp: Path, first_status: str) -> None:
        self.app, self.tmp = app, tmp
        self.calls = 0
        self.last = ""
        self.first_status = first_status
        self.selected_at: dict[str, float] = {}

    def state(self) -> dict[str, Any]:
        """What is on screen now, in window pixels."""
        import dearpygui.dearpygui as dpg

        app = self.app
        ox, oy = app.canvas.origin()
        sx, sy = dpg.get_x_scroll(app.canvas.window), dpg.get_y_scroll(app.canvas.window)
        bar_w = (
            14 if dpg.get_y_scroll_max(app.canvas.window) > 0 else 0
        )  # the scrollbars' width (theme.SCROLLBAR)
        bar_h = 14 if dpg.get_x_scroll_max(app.canvas.window) > 0 else 0
        view_w, view_h = app.canvas.size()
        selected = app.doc.selected.name if app.doc.selected is not None else None
        if selected is not None and selected not in self.selected_at:
            self.selected_at[selected] = time.time()
        buttons = {}
        for name, button in app.canvas.tools.buttons.items():
            (bx, by), (bw, bh) = dpg.get_item_rect_min(button), dpg.get_item_rect_size(button)
            buttons[name] = [bx, by, bw, bh]
        return {
            "pid": os.getpid(),
            "items": [
                {
                    "name": i.name,
                    "type": i.config.type,
                    "rect": [i.rect.x + ox, i.rect.y + oy, i.rect.w, i.rect.h],
                    "filled": i.frame_look[1],
                    "span": span_of(i.widget),
                }
                for i in app.items
            ],
            "on_panel": app.canvas.paint.on_panel,
            "canvas": [ox + sx, oy + sy, view_w - bar_w, view_h - bar_h],
            "scroll": [sx, sy],
            "scroll_max": [dpg.get_x_scroll_max(app.canvas.window), dpg.get_y_scroll_max(app.canvas.window)],
            "buttons": buttons,
            "selected": selected,
            "selected_at": self.selected_at,
            "dialog": type(app.dialog).__name__ if app.dialog is not None else None,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "menubar": _menubar(app.main),
            "status": dpg.get_value(app.status.info),
            "status_all": dpg.get_value(app.status.info_tip),  # every part, shown or given way (its tooltip)
            "message": [dpg.get_value(app.status.message), *rect_of(app.status.message)],
            "info": rect_of(app.status.info),
            "window": [dpg.get_viewport_client_width(), dpg.get_viewport_client_height()],
            "first_status": self.first_status,
            "rendered": app.loop.rendered,
        }

    def hook(self) -> None:
        """Report; answer screenshot requests (`shot-NAME.request` files the test drops into the folder)."""
        import dearpygui.dearpygui as dpg

        self.calls += 1
        for request in sorted(self.tmp.glob("shot-*.request")):
            name = request.stem.removeprefix("shot-")
            request.unlink()
            dpg.output_frame_buffer(file=str(self.tmp / f"{name}.png"))
            if hasattr(self.app, "pacer"):
                self.app.pacer.request()  # the capture happens on the next rendered frame
        state = self.state()
        text = json.dumps(state)
        if text != self.last or self.calls % 20 == 0:
            self.last = text
            state["calls"] = self.calls
            state["time"] = time.time()
            out = self.tmp / "state.json.tmp"
            out.write_text(json.dumps(state, indent=1))
            out.replace(self.tmp / "state.json")


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: open the scenario's dashboard and run the viewer until it closes."""
    warnings.simplefilter("error")
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._data._model import FieldInfo
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    if "-bg" in scenario:  # as `dbglog view` runs by default: every thread under SCHED_IDLE
        from dbglog._sched import CpuPolicy, set_cpu_policy

        assert set_cpu_policy(CpuPolicy.BACKGROUND) is None
    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    source = StaticSource()
    source.add_topic("/t/x", "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    now = time.time()
    for k in range(200):
        source.push("/t/x", "data", float(np.sin(k / 10)), now - 2 + k * 0.01)
    options: dict[str, Any] = {"fps": float(scenario.split(":")[1])} if ":" in scenario else {}
    width = 700 if scenario.endswith("-narrow") else SIZE[0]  # (the smallest the viewer opens is 640)
    app = ViewerApp(source, registry, width=width, height=SIZE[1], **options)
    app.start()
    try:
        path = dense_dashboard(tmp) if scenario.startswith("dense") else canvas_dashboard(tmp)
        app.load(load_dashboard(path, registry.get), path)
        app.frame()  # the first frame with the dashboard: what its status bar says
        probe = Probe(app, tmp, dpg.get_value(app.status.info))
        app.frame_hooks.append(probe.hook)
        if scenario.startswith("live"):  # a new sample for the plot on every pass of the loop
            app.frame_hooks.append(lambda: source.push("/t/x", "data", time.time() % 1.0))
        app.run()
    finally:
        app.close()


# -- this side: a desktop with a mouse -----------------------------------------------------------------


class Viewer(ViewerChild):
    """The real viewer in a child process (see `ViewerChild`), reporting its drawn frames as ``rendered``."""

    frame_key = "rendered"

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        super().__init__(scenario, tmp, display, "test_ui_canvas", probe=tmp)

    def settle(self) -> dict[str, Any]:
        """Wait until the viewer rendered a few more frames (so it has acted on the last input)."""
        return self.frames(3)

    def png(self, name: str) -> npt.NDArray[np.uint8]:
        """A screenshot of the window, as an (h, w, channels) array."""
        from tests.test_ui import read_png

        return read_png(self.shot(name))

    def wheel(self, notches: int) -> None:
        """Turn the wheel `notches` down (negative: up) where the mouse is."""
        button = "5" if notches > 0 else "4"
        for _ in range(abs(notches)):
            self.xdo("click", button)
        self.settle()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start(scenario: str) -> Viewer:
        v = Viewer(scenario, tmp_path, display)
        started.append(v)
        return v

    yield start
    for v in started:
        v.stop()


def item(state: dict[str, Any], name: str) -> dict[str, Any]:
    """The reported widget called `name`."""
    return next(i for i in state["items"] if i["name"] == name)


def count_near(img: npt.NDArray[np.uint8], rgb: tuple[int, ...], tol: int) -> int:
    """Pixels within `tol` of an RGB colour."""
    diff = np.abs(img[:, :, :3].astype(np.int64) - np.array(rgb[:3]))
    return int(np.all(diff <= tol, axis=2).sum())


def overlap(a: list[float], b: list[float]) -> bool:
    """Whether two [x, y, w, h] rectangles share any area."""
    return a[0] < b[0] + b[2] and b[0] < a[0] + a[2] and a[1] < b[1] + b[3] and b[1] < a[1] + a[3]


# -- the tests ------------------------------------------------------------------------------------------


def test_wheel_scrolls_canvas_background_not_over_a_plot(viewer: Callable[[str], Viewer]) -> None:
    """The wheel over the canvas background scrolls it (down and back up); over a plot it is the plot's."""
    v = viewer("canvas")
    v.ready()
    state = v.wait_for(lambda s: s["scroll_max"][1] > 300)  # the LED far below makes the canvas scroll
    cx, cy, cw, ch = state["canvas"]
    v.move(cx + cw - 60, cy + ch - 40)  # background, below the plot
    v.wheel(3)
    state = v.wait_for(lambda s: s["scroll"][1] > 0)
    assert state["scroll"][1] == pytest.approx(180, abs=1)
    v.wheel(-2)
    state = v.wait_for(lambda s: s["scroll"][1] < 180)
    assert state["scroll"][1] == pytest.approx(60, abs=1)
    v.wheel(-5)
    assert v.wait_for(lambda s: s["scroll"][1] == 0)["scroll"][1] == 0, "never above the top"
    trend = item(v.state(), "Trend")["rect"]
    v.move(trend[0] + trend[2] / 2, trend[1] + trend[3] / 2)
    v.wheel(3)
    v.settle()
    assert v.state()["scroll"][1] == 0, "the wheel over a plot does not scroll the canvas"


def test_new_widgets_land_in_view_scrolled_to_and_selected(viewer: Callable[[str], Viewer]) -> None:
    """A widget dropped on a canvas whose view is full, and View > Log console, land below what is there: the
    canvas scrolls to each (not only its scrollbar says so), and it is the one selected."""
    v = viewer("dense")
    state = v.ready()
    cx, cy, cw, ch = state["canvas"]
    button = state["buttons"]["dial"]
    v.drag((button[0] + button[2] / 2, button[1] + button[3] / 2), (cx + cw / 2, cy + ch / 2), steps=12)
    state = v.wait_for(lambda s: len(s["items"]) == 8 and s["dialog"] == "TopicDialog")
    dropped = state["items"][-1]["name"]
    state = v.wait_for(lambda s: in_view(item(s, dropped)["rect"], s["canvas"]))
    assert state["scroll"][1] > 0, "scrolled down to the new dial"
    assert state["selected"] == dropped
    v.key("Escape")  # the new dial's topic setup
    v.wait_for(lambda s: s["dialog"] is None)
    v.shot("dropped-in-view")
    new = item(v.state(), dropped)["rect"]
    v.move(new[0] + new[2] / 2, new[1] + new[3] / 2)  # (a dial leaves the wheel to the canvas)
    v.wheel(-20)
    v.wait_for(lambda s: s["scroll"][1] == 0)
    v.menu_entry("View", "Log console")
    state = v.wait_for(lambda s: any(i["type"] == "log" for i in s["items"]))
    (log,) = [i["name"] for i in state["items"] if i["type"] == "log"]
    state = v.wait_for(lambda s: in_view(item(s, log)["rect"], s["canvas"]))
    assert state["scroll"][1] > 0, "scrolled down to the console"
    assert state["selected"] == log
    v.shot("console-in-view")


def test_status_message_stays_readable_in_a_narrow_window(viewer: Callable[[str], Viewer]) -> None:
    """In a narrow window the status bar's message (the dashboard just opened) shows whole, inside the
    window, on the left; what the window shows (its file, widgets, history) gives way on the right."""
    v = viewer("canvas-narrow")
    state = v.ready()
    state = v.wait_for(lambda s: s["message"][0] and s["status"].strip())
    text, mx, _my, mw, _mh = state["message"]
    width = state["window"][0]
    assert text == "opened dashboard dash.json"
    assert mx >= 0
    assert mx + mw <= width, f"the message runs past the window's edge ({mx + mw} > {width})"
    ix, _iy, iw, _ih = state["info"]
    assert mx + mw < ix, "what the window shows: to the right of the message"
    assert ix + iw <= width, "and inside the window"
    assert "widgets" in state["status"], "the path too long to fit leaves room for the rest"
    v.shot("status-narrow")


def test_a_scroll_of_the_canvas_goes_on_over_a_plot_that_slides_under_the_pointer(
    viewer: Callable[[str], Viewer],
) -> None:
    """Notch by notch the wheel scrolls the canvas up until the plot slides under the pointer; the notches
    that follow still scroll the canvas and the plot keeps its range. Once the wheel rests (or with Ctrl),
    the wheel over the plot zooms it and the canvas stays put."""
    from dbglog.viewer._ui._pointer import WHEEL_STEP

    v = viewer("canvas")
    state = v.ready()
    state = v.wait_for(lambda s: s["scroll_max"][1] > 400 and item(s, "Trend")["span"])
    span = item(state, "Trend")["span"]
    _cx, cy, _cw, ch = state["canvas"]
    trend = item(state, "Trend")["rect"]
    px, py = trend[0] + trend[2] / 2, trend[1] + trend[3] * 0.6  # over the plot's area while not scrolled
    v.move(px, cy + ch - 40)  # the background below the plot
    v.wheel(6)
    v.wait_for(lambda s: s["scroll"][1] == 6 * WHEEL_STEP)
    v.move(px, py)  # the plot is above the view now: background under the pointer
    for notch in range(5, -1, -1):  # one notch at a time, each shown before the next

        def scrolled(s: dict[str, Any], n: int = notch) -> bool:
            return bool(s["scroll"][1] == n * WHEEL_STEP)

        v.xdo("click", "4")
        state = v.wait_for(scrolled, timeout=5)
    assert item(state, "Trend")["span"] == pytest.approx(span), "the plot slid under the pointer: no zoom"
    v.shot("scrolled-past-the-plot")
    v.xdo("keydown", "ctrl", "click", "5", "keyup", "ctrl")  # the scroll still under way: Ctrl zooms
    state = v.wait_for(lambda s: item(s, "Trend")["span"] != pytest.approx(span))
    zoomed = item(state, "Trend")["span"]
    assert zoomed > span, "Ctrl+wheel towards you zooms the plot out"
    assert state["scroll"][1] == 0, "and the canvas stays put"
    time.sleep(1.2)  # the wheel rests (LATCH_S, 1 s): the plot under the still pointer takes it
    v.wheel(-2)
    state = v.wait_for(lambda s: item(s, "Trend")["span"] != pytest.approx(zoomed))
    assert item(state, "Trend")["span"] < zoomed, "the wheel away from you zooms in"
    assert state["scroll"][1] == 0


def test_grid_covers_the_scrolled_area(viewer: Callable[[str], Viewer]) -> None:
    """Scrolled to the bottom, the canvas still shows its grid where the view was not at the start."""
    from dbglog.viewer._ui._theme import GRID

    v = viewer("canvas")
    state = v.ready()
    cx, cy, cw, ch = state["canvas"]
    v.move(cx + cw - 60, cy + ch - 40)  # background, below the plot
    v.wheel(20)
    state = v.wait_for(lambda s: s["scroll"][1] >= s["scroll_max"][1] > 300)
    img = v.png("scrolled")
    x0, y0, w, h = (int(p) for p in state["canvas"])
    far = item(state, "Far")["rect"]
    # The band right of the LED, at the bottom of the view: canvas beyond the first screenful.
    band = img[y0 + h - 200 : y0 + h - 10, int(far[0] + far[2]) + 20 : x0 + w - 20]
    lines = count_near(band, GRID, 3)
    assert lines > 0.03 * band.shape[0] * band.shape[1], f"grid pixels {lines} in a {band.shape} band"


def test_resize_grip_is_bottom_right_and_dragging_it_resizes(viewer: Callable[[str], Viewer]) -> None:
    """The grip's lines are in the frame's bottom-right corner (none bottom-left); dragging it resizes."""
    from dbglog.viewer._ui._theme import DIM

    v = viewer("canvas")
    state = v.ready()
    x, y, w, h = (int(p) for p in item(state, "Gauge")["rect"])
    img = v.png("grip")
    right = img[y + h - 18 : y + h - 2, x + w - 18 : x + w - 2]
    left = img[y + h - 18 : y + h - 2, x + 2 : x + 18]
    assert count_near(right, DIM, 40) >= 8, "grip lines in the bottom-right corner"
    assert count_near(left, DIM, 40) == 0, "nothing grip-like in the bottom-left corner"
    v.drag((x + w - 6, y + h - 6), (x + w - 6 + 100, y + h - 6 + 60))
    state = v.wait_for(lambda s: item(s, "Gauge")["rect"][2] != w)
    nx, ny, nw, nh = item(state, "Gauge")["rect"]
    assert (nx, ny) == (x, y), "the top-left corner stays"
    assert (nw, nh) == (w + 100, h + 60), "snapped to the 20 px grid"
    img = v.png("grip-after")
    nx, ny, nw, nh = (int(p) for p in (nx, ny, nw, nh))
    assert count_near(img[ny + nh - 18 : ny + nh - 2, nx + nw - 18 : nx + nw - 2], DIM, 40) >= 8
    assert count_near(img[ny + nh - 18 : ny + nh - 2, nx + 2 : nx + 18], DIM, 40) == 0


@pytest.mark.parametrize("where", ["beside a widget", "at the corner"])
def test_drop_lands_on_free_grid_spot_inside_the_canvas(viewer: Callable[[str], Viewer], where: str) -> None:
    """A toolbox widget dragged next to another, or to the view's corner, lands on free canvas in view."""
    v = viewer("canvas")
    state = v.ready()
    gauge = item(state, "Gauge")["rect"]
    cx, cy, cw, ch = state["canvas"]
    button = state["buttons"]["dial"]
    start = (button[0] + button[2] / 2, button[1] + button[3] / 2)
    if where == "beside a widget":  # the old rule (20 px left of the pointer, snapped) put the dial on it
        v.drag(start, (gauge[0] + gauge[2] + 10, gauge[1] + 120), steps=12)
    else:  # the old rule let the dial run off the bottom-right of the view
        v.drag(start, (cx + cw - 8, cy + ch - 8), steps=12)
    # The drop adds the widget, then opens its topic setup: wait for both.
    state = v.wait_for(lambda s: len(s["items"]) == 4 and s["dialog"] is not None)
    new = state["items"][-1]["rect"]
    for other in state["items"][:-1]:
        assert not overlap(new, other["rect"]), f"{new} overlaps {other}"
    assert (new[0] - cx) % 20 == 0
    assert (new[1] - cy) % 20 == 0
    assert cx <= new[0]
    assert new[0] + new[2] <= cx + cw
    assert cy <= new[1]
    assert new[1] + new[3] <= cy + ch
    assert state["dialog"] == "TopicDialog", "the drop opens the new widget's topic setup"


def test_a_full_canvas_is_cleared_to_the_panel_colour_and_looks_the_same(
    viewer: Callable[[str], Viewer],
) -> None:
    """Widgets that fill the view are drawn without fills of their own over a canvas cleared to their colour:
    the gaps and the rounded corners show the canvas colour, a widget over another still hides it, and one
    dragged by its title keeps its fill while it moves (the grid is painted under it)."""
    from dbglog.viewer._ui._frame import TITLE_H
    from dbglog.viewer._ui._theme import CANVAS, GRID, PANEL

    v = viewer("dense")
    state = v.ready()
    assert state["on_panel"] is True
    filled = {i["name"]: i["filled"] for i in state["items"]}
    assert filled == {
        "Gauge": False,
        "Thermo": False,
        "Heading": False,
        "Text": False,
        "Knob": False,
        "Under": True,
        "Over": True,
    }, "only the two that overlap keep their fills"
    img = v.png("dense")
    gx, gy, gw, gh = (int(p) for p in item(state, "Gauge")["rect"])
    tx = int(item(state, "Thermo")["rect"][0])
    gap = img[gy + 40 : gy + gh - 40, gx + gw + 4 : tx - 4]  # between two widgets: canvas (and grid lines)
    assert count_near(gap, PANEL, 2) == 0, "no panel colour between the widgets"
    assert count_near(gap, CANVAS, 2) > 0.5 * gap.shape[0] * gap.shape[1]
    for x, y in ((gx, gy), (gx + gw - 1, gy), (gx, gy + gh - 1), (gx + gw - 1, gy + gh - 1)):
        corner = img[y : y + 1, x : x + 1]  # outside the rounding: the canvas, or a grid line on the edge
        assert count_near(corner, CANVAS, 3) + count_near(corner, GRID, 3) == 1, f"rounded corner {(x, y)}"
    inside = img[gy + TITLE_H + 4 : gy + TITLE_H + 14, gx + 4 : gx + 40]  # the dial's face lies lower
    assert count_near(inside, PANEL, 2) == inside.shape[0] * inside.shape[1], "the panel colour inside"
    ox, oy, _, oh = (int(p) for p in item(state, "Over")["rect"])
    strip = img[oy + TITLE_H + 6 : oy + oh - 8, ox + 4 : ox + 12]  # over the dial below, left of the bulb
    assert count_near(strip, PANEL, 2) == strip.shape[0] * strip.shape[1], "the widget below does not show"
    # Drag the text widget by its title over the knob: while it moves it keeps its fill; back, it has none.
    x, y, w, h = item(state, "Text")["rect"]
    v.move(x + 40, y + 12)
    v.xdo("mousedown", "1")
    v.frames(3)
    for step in range(1, 5):
        v.move(x + 40 + step * 30, y + 12 + step * 10)
    state = v.wait_for(lambda s: item(s, "Text")["filled"] is True)
    assert item(state, "Knob")["filled"] is False, "the one it passes over is still: no fill of its own"
    dragging = v.png("dragging")
    kx, ky, kw, kh = (int(p) for p in item(state, "Knob")["rect"])
    mx, my, mw, mh = (int(p) for p in item(state, "Text")["rect"])
    x0, x1 = max(kx, mx) + 10, min(kx + kw, mx + mw) - 10  # where the moved text lies over the knob,
    y0, y1 = max(ky, my) + 80, min(ky + kh, my + mh) - 10  # below its text line
    assert x1 - x0 > 40
    assert y1 - y0 > 40
    spread = np.ptp(img[y0:y1, x0:x1, :3].reshape(-1, 3).astype(int), axis=0)
    assert spread.max() > 40, "the knob's dial lies there when nothing covers it"
    spread = np.ptp(dragging[y0:y1, x0:x1, :3].reshape(-1, 3).astype(int), axis=0)
    assert spread.max() <= 3, f"the dragged widget's own plain box hides the knob: {spread}"
    v.move(x + 40, y + 12)
    v.frames(3)
    v.xdo("mouseup", "1")
    state = v.wait_for(lambda s: item(s, "Text")["filled"] is False)
    assert item(state, "Text")["rect"] == [x, y, w, h]


def test_a_sparse_canvas_keeps_filled_widget_frames(viewer: Callable[[str], Viewer]) -> None:
    """A few widgets on a large canvas: the canvas is cleared to its own colour and every frame is filled."""
    from dbglog.viewer._ui._theme import CANVAS, PANEL

    v = viewer("canvas")
    state = v.ready()
    assert state["on_panel"] is False
    assert all(i["filled"] for i in state["items"])
    img = v.png("sparse")
    gx, gy, gw, _ = (int(p) for p in item(state, "Gauge")["rect"])
    assert count_near(img[gy + 1 : gy + 2, gx + gw + 30 : gx + gw + 90], CANVAS, 2) > 40
    assert count_near(img[gy + 50 : gy + 51, gx + 4 : gx + 20], PANEL, 2) == 16


def test_status_bar_counts_widgets_from_the_first_frame(viewer: Callable[[str], Viewer]) -> None:
    """The first frame's status bar counts the loaded widgets and shows no fps; once measured, it does (when
    there is room: on a loaded machine a CPU note comes first, and what does not fit is in its tooltip)."""
    v = viewer("canvas")
    state = v.ready()
    first = state["first_status"]
    assert "3 widgets" in first
    assert "fps" not in first, first
    state = v.wait_for(lambda s: "fps" in s["status_all"] or "idle" in s["status_all"])
    assert "3 widgets" in state["status"]


def test_view_new_file_starts_empty_dashboard_that_ctrl_s_writes(display: str, tmp_path: Path) -> None:
    """`dbglog view new.json` (no such file yet) opens an empty dashboard named new.json; Ctrl+S writes it."""
    path = tmp_path / "new.json"
    report = tmp_path / "report.json"
    env = {**os.environ, "DISPLAY": display}

    def xdo(*args: str) -> str:
        return subprocess.run(
            ["xdotool", *args], env=env, capture_output=True, text=True, timeout=WAIT_S, check=True
        ).stdout

    with (tmp_path / "view.log").open("w") as log:
        proc = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "dbglog",
                "view",
                str(path),
                "--report-json",
                str(report),
                "--size",
                "900x600",
            ],
            env=env,
            stdout=log,
            stderr=subprocess.STDOUT,
            cwd=ROOT,
        )
        try:
            window = xdo("search", "--sync", "--pid", str(proc.pid)).split()[0]
            assert wait_until(lambda: "new.json" in xdo("getwindowname", window), timeout=WAIT_S)
            assert xdo("getwindowname", window).strip().endswith("new.json"), "named, and nothing unsaved"
            assert not path.exists(), "nothing is written before Save"
            xdo("windowfocus", "--sync", window)
            xdo("key", "--clearmodifiers", "ctrl+s")  # once, quick: Ctrl goes up before S (xdotool's order)
            assert wait_until(path.exists, timeout=WAIT_S), (tmp_path / "view.log").read_text()
            saved = json.loads(path.read_text())
            assert saved["widgets"] == []
            xdo("key", "--clearmodifiers", "ctrl+q")  # nothing unsaved: closes at once
            try:
                code = proc.wait(WAIT_S)
            except subprocess.TimeoutExpired:
                title = xdo("getwindowname", window).strip()
                proc.send_signal(signal.SIGUSR1)  # `dbglog view` prints every thread's stack
                time.sleep(2.0)
                pytest.fail(
                    f"still running {WAIT_S} s after Ctrl+Q; title {title!r}; its log and stacks:\n"
                    + (tmp_path / "view.log").read_text()
                )
            assert code == 0, (tmp_path / "view.log").read_text()
        finally:
            if proc.poll() is None:
                proc.kill()
                proc.wait(10)
    done = json.loads(report.read_text())
    assert done["file"] == str(path)
    assert done["modified"] is False
    assert done["widgets"] == []
