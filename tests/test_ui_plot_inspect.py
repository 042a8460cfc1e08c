"""Plots you can inspect, under Xvfb with the real mouse: wheel zoom, drag pan, box zoom, double click, hover.

The real viewer (`ViewerApp.run`) runs in a child process over a `StaticSource` (no ROS needed): known
samples, and in the "live" scenario a new sample on every pass of the loop. Its frame hook reports each
plot's time range (source times), whether it follows or holds, the hover time and values, and the plot's
rectangle in window pixels. This process moves the mouse, turns the wheel, drags and clicks with xdotool
(XTEST: the events a real mouse makes); nothing here calls a handler or a callback of the viewer.
"""

from __future__ import annotations

import math
import os
import shutil
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests._viewer_child import ViewerChild, report_frame

pytestmark = pytest.mark.gui

SIZE = (1240, 800)
STEP = 0.05
"""Seconds between two samples of the known series: sample k holds the value k."""
HISTORY_S = 60.0
"""How far back the known samples reach before the viewer starts."""
WHEELS = ("/robot/left_wheel_velocity", "/robot/right_wheel_velocity", "/robot/odometry_linear_x")


# -- the child: a real viewer whose frame hook reports what the plots show --------------------------------


def inspect_dashboard(tmp: Path) -> Path:
    """Plots A and B (linked, the default), C unlinked, a dial; the canvas has room below them."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    ramp, wave = Binding("/p/ramp", "data"), Binding("/p/wave", "data")
    widgets = [
        WidgetConfig("plot", "A", 20, 20, 480, 260, (ramp, wave), {"window": 10.0}),
        WidgetConfig("plot", "B", 520, 20, 480, 260, (ramp,), {"window": 10.0}),
        WidgetConfig("plot", "C", 20, 300, 480, 260, (ramp,), {"window": 10.0, "link": False}),
        WidgetConfig("dial", "D", 520, 300, 220, 260, (ramp,), {"minimum": 0, "maximum": 5000}),
    ]
    path = tmp / "inspect.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


SMALL_TOPICS = tuple(f"/s/t{i}" for i in range(5)) + WHEELS
"""The "small" scenario's series: five sines (a plot of the bench dashboard) and three long names."""


def small_dashboard(tmp: Path) -> Path:
    """S: a cell of the 20-widget bench dashboard (five series); T: too small for a legend row (three long
    names); L: a big plot with S's series; a dial."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    five = tuple(Binding(f"/s/t{i}", "data") for i in range(5))
    wheels = tuple(Binding(topic, "data") for topic in WHEELS)
    widgets = [
        WidgetConfig("plot", "S", 20, 20, 236, 194, five, {"window": 10.0}),
        WidgetConfig("plot", "T", 280, 20, 200, 150, wheels, {"window": 10.0}),
        WidgetConfig("plot", "L", 500, 20, 480, 260, five, {"window": 10.0}),
        WidgetConfig("dial", "D", 20, 320, 220, 200, (five[0],), {"minimum": -2, "maximum": 2}),
    ]
    path = tmp / "small.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


def _rect(item: int | str) -> list[float]:
    import dearpygui.dearpygui as dpg

    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


class Probe:
    """Frame hook: writes what the plots show to ``state.json``; answers screenshot requests."""

    def __init__(self, app: Any, tmp: Path, base: float) -> None:
        self.app, self.tmp, self.base = app, tmp, base

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        app = self.app
        ox, oy = app.canvas.origin()
        plots = {}
        for item in app.items:
            widget = item.widget
            if item.config.type != "plot" or widget is None:
                continue
            rng = widget.time_range()
            plots[item.name] = {
                "view": list(widget.view) if widget.view is not None else None,
                "following": rng.following,
                "length": rng.length,
                "shared": rng is app.time_range,
                "hover_time": widget.hover_time,
                "pointer_over": widget.pointer_over,
                "hover_values": widget.hover_values,
                "cursor_values": widget.cursor_values,
                "plot": _rect(widget.plot),
                "info": dpg.get_value(widget._info),
                "link": item.config.properties.get("link", True),
                "link_box": _rect(widget._link),
                "updates": item.updates,
                "drawn_from": widget.drawn_from,
                "width": widget.width,
                "legend": widget.legend_plan.mode.value,
                "legend_names": list(widget.legend_plan.labels),
                "series_labels": [dpg.get_item_label(tag) for tag in widget._series],
                "info_rect": _rect(widget._info),
                "info_full": widget.info_full,
                "chip": _rect(widget._chip) if dpg.is_item_shown(widget._chip_box) else None,
                "chip_hovered": bool(dpg.is_item_hovered(widget._chip_box)),
            }
        return {
            "pid": os.getpid(),
            "frame": app.loop.rendered,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "base": self.base,
            "newest": app.time_range.newest,
            "live": app.timeline.live,
            "cursor": app.timeline.cursor,
            "scroll": [dpg.get_x_scroll(app.canvas.window), dpg.get_y_scroll(app.canvas.window)],
            "menu": bool(dpg.is_item_shown(app.pointer_input.menu)),
            "dirty": app.doc.dirty,
            "plots": plots,
            "rects": {i.name: [i.rect.x + ox, i.rect.y + oy, i.rect.w, i.rect.h] for i in app.items},
        }

    def hook(self) -> None:
        """Report; write screenshots asked for with ``shot-NAME.request`` files."""
        report_frame(self.app, self.tmp, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the dashboard over known samples ("live": one more on every pass) until killed."""
    warnings.simplefilter("error")
    from dbglog.viewer._data._model import FieldInfo
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    if scenario == "history":
        history_here(tmp, registry)
        return
    source = StaticSource()
    for topic in ("/p/ramp", "/p/wave", *SMALL_TOPICS):
        source.add_topic(topic, "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    base = math.floor(time.time()) - HISTORY_S
    k = np.arange(int(HISTORY_S / STEP) + 1)
    source.set_series("/p/ramp", "data", base + k * STEP, k.astype(np.float64))
    source.set_series("/p/wave", "data", base + k * STEP, np.sin(k / 20.0) * 100)
    for j, topic in enumerate(SMALL_TOPICS):
        source.set_series(topic, "data", base + k * STEP, np.sin(k / (15.0 + 4 * j) + j) * 10 + j)
    app = ViewerApp(source, registry, width=SIZE[0], height=SIZE[1])
    app.start()
    try:
        path = small_dashboard(tmp) if scenario == "small" else inspect_dashboard(tmp)
        app.load(load_dashboard(path, registry.get), path)
        probe = Probe(app, tmp / "probe", base)
        app.frame_hooks.append(probe.hook)
        if scenario == "live":
            count = [int(k[-1])]

            def more() -> None:  # the ramp goes on in real time: sample k at base + k * STEP
                due = int((time.time() - base) / STEP)
                while count[0] < due:
                    count[0] += 1
                    source.push("/p/ramp", "data", float(count[0]), base + count[0] * STEP)

            app.frame_hooks.insert(0, more)
        app.run()
    finally:
        app.close()


HISTORY_LONG_S = 400.0
"""The recording of the "history" scenario: 400 s at 100 Hz, four times what a snapshot holds."""


def history_here(tmp: Path, registry: Any) -> None:
    """A recording longer than a snapshot holds, replayed (paused at its end) with plot A over 100 s."""
    import struct

    from dbglog.record import McapWriter
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._document._dashboard import (
        Dashboard,
        RawWidget,
        WidgetConfig,
        load_dashboard,
        save_dashboard,
    )
    from dbglog.viewer._ui import ViewerApp

    base = math.floor(time.time()) - 3600
    rec = tmp / "long.mcap"
    writer = McapWriter(rec)
    ch = writer.add_channel("/p/ramp", "std_msgs/msg/Float64")
    for k in range(int(HISTORY_LONG_S * 100)):
        t = (base * 100 + k) * 10_000_000
        writer.write(ch, t, b"\x00\x01\x00\x00" + struct.pack("<d", k), t)  # a Float64 in CDR
    writer.close()
    dash = tmp / "history.json"
    plot = WidgetConfig("plot", "A", 20, 20, 900, 300, (Binding("/p/ramp", "data"),), {"window": 100.0})
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget]([plot]), 20, True), dash)
    app = ViewerApp(load_replay(rec), registry, width=SIZE[0], height=SIZE[1], recording=True)
    app.start()
    try:
        app.load(load_dashboard(dash, registry.get), dash)
        app.frame_hooks.append(Probe(app, tmp / "probe", float(base)).hook)
        app.run()
    finally:
        app.close()


# -- this side: a desktop with a mouse -----------------------------------------------------------------


class Viewer(ViewerChild):
    """The real viewer in a child process with the plot probe."""

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        super().__init__(scenario, tmp, display, "test_ui_plot_inspect")

    def plot(self, name: str, state: dict[str, Any] | None = None) -> dict[str, Any]:
        """The reported plot called `name`."""
        return dict((state or self.state())["plots"][name])

    def at(self, name: str, fx: float, fy: float = 0.5) -> tuple[float, float]:
        """The window pixel a fraction `fx` across and `fy` down the plot called `name` (its ImPlot item;
        another widget: its frame)."""
        state = self.state()
        plot = state["plots"].get(name)
        x, y, w, h = plot["plot"] if plot is not None else state["rects"][name]
        return x + fx * w, y + fy * h

    def wheel(self, notches: int) -> None:
        """Turn the wheel `notches` towards you (zoom out; negative: away, zoom in) where the mouse is."""
        button = "5" if notches > 0 else "4"
        for _ in range(abs(notches)):
            self.xdo("click", button)
            self.frames(2)

    def right_drag(self, start: tuple[float, float], end: tuple[float, float], steps: int = 8) -> None:
        """Press the right button at `start`, move to `end` with it held, let go there."""
        self.move(*start)
        self.xdo("mousedown", "3")
        self.frames(3)
        for i in range(1, steps + 1):
            self.move(start[0] + (end[0] - start[0]) * i / steps, start[1] + (end[1] - start[1]) * i / steps)
        self.xdo("mouseup", "3")
        self.frames(3)

    def double_click(self, x: float, y: float) -> None:
        """Move to (x, y) and click the left button twice, quickly."""
        self.move(x, y)
        self.xdo("click", "--repeat", "2", "--delay", "60", "1")
        self.frames(3)

    def hover_time(self, name: str, x: float, y: float) -> float:
        """Move to (x, y) over plot `name` and return the time the plot reports under the pointer."""
        self.move(x, y)
        state = self.wait_for(lambda s: s["plots"][name]["hover_time"] is not None)
        return float(state["plots"][name]["hover_time"])


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start(scenario: str) -> Viewer:
        v = Viewer(scenario, tmp_path, display)
        started.append(v)
        v.ready()
        v.wait_for(lambda s: all(p["view"] is not None for p in s["plots"].values()))
        return v

    yield start
    for v in started:
        v.stop()


def length(plot: dict[str, Any]) -> float:
    """How many seconds a reported plot shows."""
    start, end = plot["view"]
    return float(end - start)


def ramp_at(base: float, t: float) -> float:
    """The known ramp's value at time `t`: its last sample at or before `t`."""
    return float(math.floor((t - base) / STEP + 1e-4))  # (epoch times hold about 0.2 µs)


def near(a: float, b: float, tol: float) -> bool:
    """Whether two numbers are within `tol` of each other."""
    return abs(a - b) <= tol


# -- the tests ------------------------------------------------------------------------------------------


def test_wheel_zooms_a_live_plot_which_keeps_following(viewer: Callable[[str], Viewer]) -> None:
    """The wheel over a live plot changes its length, its right edge stays on the newest sample as data
    arrive; the linked plot zooms with it, the unlinked one does not, and the canvas does not scroll."""
    v = viewer("live")
    v.move(*v.at("A", 0.3))
    v.wheel(-3)  # three notches away from you: zoom in
    want = 10.0 * (1 - 0.1 / 1.2) ** 3  # ImPlot's zoom rate: each notch keeps 1 - 0.1 / 1.2 of the length
    state = v.wait_for(lambda s: length(v.plot("A", s)) < 9.0)
    a, b, c = (v.plot(n, state) for n in "ABC")
    assert near(length(a), want, 0.05), a
    assert a["following"], "a wheel zoom while live keeps following"
    assert near(a["view"][1], state["newest"], 0.3), "the right edge stays on the newest sample"
    assert b["view"] == a["view"], "the linked plot shows the same range"
    assert near(length(c), 10.0, 1e-6), "the unlinked plot keeps its own"
    assert state["scroll"] == [0, 0], "the wheel over a plot does not scroll the canvas"
    first_end = a["view"][1]
    state = v.wait_for(lambda s: v.plot("A", s)["view"][1] > first_end + 1.5)
    a = v.plot("A", state)
    assert a["following"]
    assert near(a["view"][1], state["newest"], 0.3), "still at the newest sample as the data arrive"
    assert near(length(a), want, 0.05)
    v.wheel(2)  # zoom out: each notch 1.1 times longer
    state = v.wait_for(lambda s: length(v.plot("A", s)) > want + 0.5)
    assert near(length(v.plot("A", state)), want * 1.1**2, 0.05)
    assert near(v.plot("A", state)["view"][1], state["newest"], 0.3)


def test_drag_pans_a_live_plot_it_holds_until_a_double_click(viewer: Callable[[str], Viewer]) -> None:
    """A drag to the right shows earlier data and stops following (the range holds while data arrive, the
    linked plot too); a double click follows the newest data again, with the plot's own window."""
    v = viewer("live")
    x, y = v.at("A", 0.4)
    t0 = v.hover_time("A", x, y)
    t1 = v.hover_time("A", x + 200, y)
    pan = t1 - t0  # 200 px in seconds (both read while following, a moment apart: the axis moved a bit)
    before = time.time()  # the samples' times are this clock's: newest is "now" at the drag's start
    v.drag((x, y), (x + 200, y))
    after = time.time()
    state = v.wait_for(lambda s: not v.plot("A", s)["following"])
    a, b, c = (v.plot(n, state) for n in "ABC")
    assert near(length(a), 10.0, 1e-3), "a pan keeps the length"
    assert before - pan - 0.6 <= a["view"][1] <= after - pan + 0.3, (before, a["view"], after, pan)
    assert b["view"] == a["view"], "the linked plot pans with it"
    assert not b["following"]
    assert c["following"], "the unlinked plot goes on following"
    held = a["view"]
    newest = state["newest"]
    state = v.wait_for(lambda s: s["newest"] > newest + 1.5)
    assert v.plot("A", state)["view"] == held, "held while the data arrive"
    v.move(*v.at("D", 0.5))  # off the plots: their headers say what they show
    state = v.wait_for(lambda s: "held" in v.plot("B", s)["info"])
    assert v.plot("A", state)["view"] == held
    v.double_click(*v.at("A", 0.5))
    state = v.wait_for(lambda s: v.plot("A", s)["following"])
    a = v.plot("A", state)
    assert near(length(a), 10.0, 1e-6)
    assert near(a["view"][1], state["newest"], 0.3)
    assert v.plot("B", state)["following"]


def test_drag_moves_the_data_with_the_pointer(viewer: Callable[[str], Viewer]) -> None:
    """A drag pans: the moment that was under the pointer where the drag started is under it where it ends."""
    v = viewer("static")
    x, y = v.at("A", 0.3)
    t = v.hover_time("A", x, y)
    v.drag((x, y), (x + 180, y + 20))
    state = v.wait_for(lambda s: not v.plot("A", s)["following"])
    px = length(v.plot("A", state)) / v.plot("A", state)["plot"][2]  # about a pixel, in seconds
    assert near(v.hover_time("A", x + 180, y + 20), t, 2 * px)
    assert near(length(v.plot("A", state)), 10.0, 1e-3)


def test_end_makes_every_plot_follow_again(viewer: Callable[[str], Viewer]) -> None:
    """End while live: linked and unlinked plots held by a pan follow the newest data again."""
    v = viewer("live")
    for name in ("A", "C"):
        x, y = v.at(name, 0.5)
        v.drag((x, y), (x + 120, y))
    state = v.wait_for(lambda s: not v.plot("A", s)["following"] and not v.plot("C", s)["following"])
    assert v.plot("A", state)["view"] != v.plot("C", state)["view"], "C was panned on its own"
    v.move(*v.at("D", 0.5))
    v.key("End")
    state = v.wait_for(lambda s: all(v.plot(n, s)["following"] for n in "ABC"))
    for name in "ABC":
        assert near(v.plot(name, state)["view"][1], state["newest"], 0.3), name


def test_box_zoom_holds_the_range_between_its_corners(viewer: Callable[[str], Viewer]) -> None:
    """A right drag across a plot zooms its time axis to the box (no widget menu opens); linked plots too."""
    v = viewer("static")
    (x0, y0), (x1, y1) = v.at("A", 0.3, 0.3), v.at("A", 0.7, 0.7)
    t0, t1 = v.hover_time("A", x0, y0), v.hover_time("A", x1, y1)
    v.right_drag((x0, y0), (x1, y1))
    state = v.wait_for(lambda s: length(v.plot("A", s)) < 9.0)
    a, b, c = (v.plot(n, state) for n in "ABC")
    px = (t1 - t0) / (x1 - x0)  # a pixel, in seconds
    assert near(a["view"][0], t0, 2 * px), (a["view"], t0, t1)
    assert near(a["view"][1], t1, 2 * px), (a["view"], t0, t1)
    assert not a["following"]
    assert b["view"] == a["view"]
    assert near(length(c), 10.0, 1e-6)
    assert not state["menu"], "a right drag over a plot is the plot's, not the widget menu's"


def test_hover_shows_the_value_of_each_series_at_that_time(viewer: Callable[[str], Viewer]) -> None:
    """Over a plot: a line at the pointer, each series' value then (its last sample at or before it) in the
    plot and its header; the linked plot shows the same time, the unlinked one nothing; gone off the plot."""
    from dbglog.viewer._widgets._common import clock_text
    from tests.test_ui import read_png

    v = viewer("static")
    x, y = v.at("A", 0.35)
    t = v.hover_time("A", x, y)
    state = v.frames(3)
    a, b, c = (v.plot(n, state) for n in "ABC")
    base = state["base"]
    k = ramp_at(base, t)
    assert a["pointer_over"]
    assert a["hover_values"][0] == k, (t - base, a["hover_values"])
    assert near(a["hover_values"][1], math.sin(k / 20.0) * 100, 1e-6)
    assert a["view"][0] < t < a["view"][1]
    assert clock_text(t) in a["info"]
    assert b["hover_time"] == t, "the linked plot shows the same moment"
    assert not b["pointer_over"]
    assert b["hover_values"] == [k]
    assert c["hover_time"] is None, "the unlinked plot shows none"
    img = read_png(v.shot("hover"))
    _, py, _, ph = (int(p) for p in a["plot"])
    column = img[py + 10 : py + ph - 30, round(x) - 2 : round(x) + 3, :3].astype(np.int64)
    # The hover line: a light grey over the dark plot area (24, 26, 32), anti-aliased over two pixels.
    hits = (column.min(axis=2) > 60).any(axis=1)
    assert hits.mean() > 0.6, f"hover line pixels in {hits.mean():.0%} of the column"
    beside = img[py + 10 : py + ph - 30, round(x) + 12 : round(x) + 17, :3].astype(np.int64)
    assert (beside.min(axis=2) > 60).any(axis=1).mean() < 0.3, "no such line beside it"
    v.move(*v.at("D", 0.5))  # off every plot
    state = v.wait_for(lambda s: all(v.plot(n, s)["hover_time"] is None for n in "ABC"))
    assert v.plot("A", state)["hover_values"] == []


def test_the_link_box_unlinks_a_plot_and_is_saved(viewer: Callable[[str], Viewer]) -> None:
    """Clicking B's Link box unlinks it (the dashboard is modified): A zooms alone; linked again, B takes
    the shared range."""
    v = viewer("static")
    bx, by, _, bh = v.plot("B")["link_box"]
    v.click(bx + 10, by + bh / 2)
    state = v.wait_for(lambda s: v.plot("B", s)["link"] is False)
    assert state["dirty"], "the Link box is saved with the dashboard"
    v.move(*v.at("A", 0.5))
    v.wheel(-2)
    state = v.wait_for(lambda s: length(v.plot("A", s)) < 9.0)
    assert near(length(v.plot("B", state)), 10.0, 1e-6), "unlinked: B keeps its range"
    v.click(bx + 10, by + bh / 2)
    state = v.wait_for(lambda s: v.plot("B", s)["link"] is True and length(v.plot("B", s)) < 9.0)
    assert v.plot("B", state)["view"] == v.plot("A", state)["view"]


def test_wheel_zoom_while_paused_keeps_the_cursor_at_the_right(viewer: Callable[[str], Viewer]) -> None:
    """Paused, the wheel changes the length and the range still ends (a little past) the cursor."""
    from dbglog.viewer._widgets._plot import CURSOR_MARGIN

    v = viewer("live")
    v.move(*v.at("D", 0.5))
    v.key("space")
    state = v.wait_for(lambda s: s["cursor"] is not None)
    cursor = state["cursor"]
    v.move(*v.at("A", 0.5))
    v.wheel(-2)
    state = v.wait_for(lambda s: length(v.plot("A", s)) < 10.0)
    a = v.plot("A", state)
    span = 10.0 * (1 - 0.1 / 1.2) ** 2
    assert a["following"]
    assert near(a["view"][1], cursor + span * CURSOR_MARGIN, 0.05)
    assert near(a["view"][0], cursor - span, 0.05)
    assert a["cursor_values"][0] == ramp_at(state["base"], cursor)


def test_a_plot_zoomed_out_past_its_snapshot_draws_the_whole_history(viewer: Callable[[str], Viewer]) -> None:
    """Zoomed out with the wheel over a replay longer than a snapshot holds (10,000 samples: 100 s here),
    the plot draws from the start of its range, from the history, not only the snapshot's last 100 s."""
    v = viewer("history")
    a = v.plot("A")
    assert 100.0 <= length(a) <= 110.0  # paused at its end: a margin past the cursor
    v.move(*v.at("A", 0.5))
    v.wheel(12)  # each notch 1.1 times longer: 100 s -> 314 s
    state = v.wait_for(
        lambda s: length(s["plots"]["A"]) > 250.0 and s["plots"]["A"]["drawn_from"] is not None
    )
    a = v.plot("A", state)
    start, end = a["view"]
    assert start > state["base"], "the range is still within the recording"
    column = (end - start) / 800
    assert a["drawn_from"] <= start + 2 * column, (a["drawn_from"] - start, "drawn from the range's start")
    assert end - a["drawn_from"] > 250.0, "more than the snapshot's 100 s is drawn"


# -- small plots: the legend beside the lines, a header label that fits ------------------------------------


def legend_band(img: np.ndarray, rect: list[float]) -> tuple[int, int]:
    """The rows of a plot item in a screenshot above its data area, and the first row of the area: where a
    plot's background fills most of a row (the rows above hold the header, or a legend row)."""
    from dbglog.viewer._widgets._plot import _plot_theme  # noqa: F401  (the colour below is its PlotBg)

    x, y, w, h = (int(v) for v in rect)
    rows = img[y : y + h, x + 45 : x + w - 10, :3].astype(np.int64)
    bg = (np.abs(rows - np.array([24, 26, 32])).max(axis=2) <= 2).mean(axis=1)
    top = int(np.argmax(bg > 0.5))
    return y, y + top


def swatches(img: np.ndarray, x0: int, y0: int, x1: int, y1: int, n: int) -> list[bool]:
    """Whether a region holds a legend's colour square of each of the first `n` series: a solid block of
    6 x 6 pixels in its colour (a line, 2 pixels wide, has none)."""
    from dbglog.viewer._widgets._common import SERIES_COLORS

    part = img[y0:y1, x0:x1, :3].astype(np.int64)
    found = []
    for color in SERIES_COLORS[:n]:
        mask = (np.abs(part - np.array(color[:3])).max(axis=2) <= 6).astype(np.int64)
        sums = np.pad(mask.cumsum(axis=0).cumsum(axis=1), ((1, 0), (1, 0)))
        blocks = sums[6:, 6:] - sums[:-6, 6:] - sums[6:, :-6] + sums[:-6, :-6]
        found.append(bool((blocks == 36).any()))
    return found


def test_a_small_plot_keeps_its_legend_off_the_lines(viewer: Callable[[str], Viewer]) -> None:
    """A bench-sized plot shows its legend as a row of short names above the plot area (none of its colour
    squares over the data) while a big plot keeps it inside with full names; a plot too small for a row
    shows a swatch per series in its header instead, which names them when hovered."""
    from tests.test_ui import read_png

    v = viewer("small")
    state = v.frames(3)
    s, t, big = (v.plot(n, state) for n in "STL")
    assert s["legend"] == "row", s
    assert s["legend_names"] == ["t0", "t1", "t2", "t3", "t4"]
    assert s["series_labels"] == s["legend_names"], "the legend shows the short names"
    assert big["legend"] == "inside"
    assert big["series_labels"] == [f"/s/t{i}" for i in range(5)]
    assert t["legend"] == "collapsed", t
    assert t["chip"] is not None, "the swatches show in T's header"
    img = read_png(v.shot("small"))
    top, area = legend_band(img, s["plot"])
    x, _, w, _ = (int(p) for p in s["plot"])
    assert area - top >= 15, "a legend row above the data area"
    assert all(swatches(img, x, top, x + w, area, 5)), "each series' colour square in the row above the lines"
    assert not any(swatches(img, x, area, x + w, area + 100, 5)), "and none over them"
    bx, _, bw, _ = (int(p) for p in big["plot"])
    btop, barea = legend_band(img, big["plot"])
    assert barea - btop < 15, "the big plot's area starts at its top"
    assert all(swatches(img, bx + 40, barea, bx + bw // 2, barea + 100, 5)), "L's legend: inside, top left"
    tx, _, tw, _ = (int(p) for p in t["plot"])
    _, tarea = legend_band(img, t["plot"])
    assert not any(swatches(img, tx + 40, tarea, tx + tw, tarea + 60, 3)), "T: no legend over its lines"
    cx, cy, cw, ch = (int(p) for p in t["chip"])
    assert not any(swatches(img, cx - 20, cy + ch + 4, cx + 80, cy + ch + 100, 3)), "no tooltip yet"
    v.move(cx + cw / 2, cy + ch / 2)
    # (the tooltip shows in every frame the swatches are hovered; an idle viewer draws few frames, so wait
    # for the state that says so, not for a count of frames)
    v.wait_for(lambda st: v.plot("T", st)["chip_hovered"])
    img = read_png(v.shot("small-names"))
    assert all(swatches(img, cx - 20, cy + ch + 4, cx + 80, cy + ch + 100, 3)), "hovered: the series listed"


def test_a_narrow_plot_header_shortens_its_label_to_fit(viewer: Callable[[str], Viewer]) -> None:
    """Paused, a bench-sized plot's header says a shorter form of what a wide plot says (the full one in its
    tooltip), within the plot's width; the wide plot says it in full."""
    v = viewer("small")
    v.move(*v.at("D", 0.5))
    v.key("space")
    state = v.wait_for(lambda st: st["cursor"] is not None and v.plot("S", st)["info_full"] != "")
    s, big = v.plot("S", state), v.plot("L", state)
    assert big["info_full"] == "", "the wide plot's label is whole"
    assert " to " in big["info"], big["info"]
    assert s["info"], s
    assert s["info"] != s["info_full"], s
    assert s["info_full"] == big["info"], "the same range, in full in the narrow plot's tooltip"
    assert s["info_full"].startswith(s["info"]), "a shorter form, not another text"
    ix, _, iw, _ = s["info_rect"]
    px, _, pw, _ = s["plot"]
    assert ix + iw <= px + pw + 1, (s["info_rect"], s["plot"], "the label ends inside the plot's width")
