"""Pictures that do not lie, in the real window under Xvfb: a gap drawn as a gap, a box zoom's y range
holding the line where it leaves the box, NaN and infinities in plots and gauges said as such.

The real viewer (`ViewerApp.run`) runs in a child process over a `StaticSource` of known samples, with
warnings as errors (a RuntimeWarning ends it). Its frame hook reports what the plots and gauges show; this
process moves the mouse and drags with xdotool (XTEST: a real mouse's events) and reads screenshots.
"""

from __future__ import annotations

import math
import shutil
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests._viewer_child import ViewerChild, report_frame
from tests.test_ui_plot_inspect import Viewer, length, near

pytestmark = pytest.mark.gui

SIZE = (1240, 900)
GAP = (20.0, 40.0)
"""Seconds after `base` between which /t/gap and /t/count are silent (a robot killed and restarted)."""
SPIKE_STEP = 0.5
"""Seconds between /t/spike's samples: 0, and 1000 at every eighth."""


def spike_at(base: float, t: float) -> float:
    """The /t/spike line's value at time `t` (between two samples: on the segment joining them)."""
    k = (t - base) / SPIKE_STEP
    k0 = math.floor(k + 1e-9)

    def value(i: int) -> float:
        return 1000.0 if i % 8 == 0 else 0.0

    return value(k0) + (value(k0 + 1) - value(k0)) * (k - k0)


def truth_dashboard(tmp: Path) -> Path:
    """Plots G (a gap; a float and an Int series), Z (spikes), N (NaN, ±inf), each unlinked; gauges, an LED
    and a String on NaN and infinities."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    def b(topic: str) -> Binding:
        return Binding(topic, "data")

    own = {"link": False}
    widgets = [
        WidgetConfig("plot", "G", 0, 0, 480, 260, (b("/t/gap"), b("/t/count")), {"window": 60.0, **own}),
        WidgetConfig("plot", "Z", 500, 0, 480, 260, (b("/t/spike"),), {"window": 10.0, **own}),
        WidgetConfig("plot", "N", 0, 280, 480, 260, (b("/t/odd"),), {"window": 60.0, **own}),
        WidgetConfig("dial", "dial", 500, 280, 160, 160, (b("/t/nan"),), {}),
        WidgetConfig("knob", "knob", 670, 280, 160, 160, (b("/t/pinf"),), {}),
        WidgetConfig("compass", "compass", 840, 280, 150, 170, (b("/t/nan"),), {}),
        WidgetConfig("thermo", "thermo", 500, 460, 120, 200, (b("/t/ninf"),), {}),
        WidgetConfig("led", "led", 630, 460, 120, 130, (b("/t/nan"),), {}),
        WidgetConfig("string", "string", 760, 460, 220, 130, (b("/t/pinf"),), {}),
        WidgetConfig("compass", "nothing", 630, 600, 150, 150, (b("/t/none"),), {}),
    ]
    path = tmp / "truth.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


class Probe:
    """Frame hook: what each plot and gauge shows, to ``state.json``; screenshots on request."""

    def __init__(self, app: Any, tmp: Path, base: float) -> None:
        self.app, self.tmp, self.base = app, tmp, base

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        from tests.test_ui_plot_inspect import _rect

        app = self.app
        ox, oy = app.canvas.origin()
        plots, readouts = {}, {}
        for item in app.items:
            widget = item.widget
            if widget is None:
                continue
            if item.config.type == "plot":
                plots[item.name] = {
                    "view": list(widget.view) if widget.view is not None else None,
                    "limits": list(widget._limits) if widget._limits is not None else None,
                    "hover_time": widget.hover_time,
                    "hover_values": widget.hover_values,
                    "tags": [dpg.get_item_label(n) for n in widget._notes if dpg.is_item_shown(n)],
                    "marks": [[dpg.is_item_shown(m) for m in ms] for ms in getattr(widget, "_marks", [])],
                    "plot": _rect(widget.plot),
                }
            elif item.config.type == "string":
                readouts[item.name] = widget.latest_text
            elif item.config.type == "compass" and not dpg.is_item_shown(widget._north):
                readouts[item.name] = dpg.get_item_configuration(widget._readout)["text"] + " (no needle)"
            else:
                readout = widget._caption if item.config.type == "led" else widget._readout
                readouts[item.name] = dpg.get_item_configuration(readout)["text"]
        return {
            "frame": app.loop.rendered,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "base": self.base,
            "menu": bool(dpg.is_item_shown(app.pointer_input.menu)),
            "plots": plots,
            "readouts": readouts,
            "rects": {i.name: [i.rect.x + ox, i.rect.y + oy, i.rect.w, i.rect.h] for i in app.items},
        }

    def hook(self) -> None:
        """Report; write screenshots asked for."""
        report_frame(self.app, self.tmp, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the dashboard over known samples until killed."""
    warnings.simplefilter("error")
    from dbglog.viewer._data._model import FieldInfo
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    source = StaticSource()
    topics = ("/t/gap", "/t/count", "/t/spike", "/t/odd", "/t/nan", "/t/pinf", "/t/ninf")
    for topic in topics:
        source.add_topic(topic, "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    base = math.floor(time.time()) - 60.0
    t = base + np.arange(600) * 0.1
    alive = (t < base + GAP[0]) | (t >= base + GAP[1])
    source.set_series("/t/gap", "data", t[alive], np.sin(t[alive] / 3) * 3 + 5)
    for k in range(0, 600, 7):  # an Int32 counter, its value an int: drawn as steps
        if alive[k]:
            source.push("/t/count", "data", k // 7, float(t[k]))
    ts = base + np.arange(121) * SPIKE_STEP
    source.set_series("/t/spike", "data", ts, np.where(np.arange(121) % 8 == 0, 1000.0, 0.0))
    odd = np.sin(t / 2)
    odd[300:310] = np.nan
    odd[350], odd[420] = np.inf, -np.inf
    source.set_series("/t/odd", "data", t, odd)
    for topic, value in (("/t/nan", math.nan), ("/t/pinf", math.inf), ("/t/ninf", -math.inf)):
        source.set_series(topic, "data", np.array([base + 59.0]), np.array([value]))
    app = ViewerApp(source, registry, width=SIZE[0], height=SIZE[1])
    app.start()
    try:
        path = truth_dashboard(tmp)
        app.load(load_dashboard(path, registry.get), path)
        app.frame_hooks.append(Probe(app, tmp / "probe", base).hook)
        app.run()
    finally:
        app.close()


class TruthViewer(Viewer):
    """The real viewer in a child process with this module's probe."""

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        ViewerChild.__init__(self, scenario, tmp, display, "test_ui_plot_truth")

    def pixel_of(self, name: str, t: float) -> float:
        """The window x of source time `t` over plot `name` (measured by hovering two points)."""
        x0, y = self.at(name, 0.3)
        x1, _ = self.at(name, 0.7)
        t0, t1 = self.hover_time(name, x0, y), self.hover_time(name, x1, y)
        return x0 + (t - t0) * (x1 - x0) / (t1 - t0)


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[], TruthViewer]]:
    """Start the viewer on the display; killed at the end if it still runs."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[TruthViewer] = []

    def start() -> TruthViewer:
        v = TruthViewer("truth", tmp_path, display)
        started.append(v)
        v.ready()
        v.wait_for(lambda s: all(p["view"] is not None and p["limits"] for p in s["plots"].values()))
        return v

    yield start
    for v in started:
        v.stop()


def series_pixels(img: np.ndarray, x0: float, x1: float, y0: float, y1: float) -> int:
    """How many pixels of the first two series' colours a region of a screenshot holds."""
    from dbglog.viewer._widgets._common import SERIES_COLORS

    part = img[int(y0) : int(y1), int(x0) : int(x1), :3].astype(np.int64)
    return sum(
        int((np.abs(part - np.array(color[:3])).max(axis=2) <= 40).sum()) for color in SERIES_COLORS[:2]
    )


def test_a_box_zoom_fits_the_y_axis_to_the_line_leaving_the_box(viewer: Callable[[], TruthViewer]) -> None:
    """A right drag boxes zeros just before a spike: the y axis holds the segment rising to the spike
    where it leaves the box (it was fitted to the zeros inside and the line ran off the top)."""
    from tests.test_ui import read_png

    v = viewer()
    base = v.state()["base"]
    t0, t1 = base + 53.0, base + 55.75  # zeros from 52.5 to 55.5, the spike at 56
    y = v.at("Z", 0.5)[1]
    x0, x1 = v.pixel_of("Z", t0), v.pixel_of("Z", t1)
    v.right_drag((x0, y - 40), (x1, y + 40))
    state = v.wait_for(lambda s: length(s["plots"]["Z"]) < 5.0)
    z = state["plots"]["Z"]
    start, end = z["view"]
    px = (t1 - t0) / (x1 - x0)
    assert near(start, t0, 3 * px), (start - base, end - base)
    assert near(end, t1, 3 * px), (start - base, end - base)
    assert not state["menu"]
    rising = spike_at(base, end)
    assert 300.0 < rising < 700.0, "the box ends on the segment rising to the spike"
    lo, hi = z["limits"]
    assert lo < 0.0, z["limits"]
    assert hi >= rising, f"y axis {z['limits']}: the line leaves the box at {rising:.0f}, above it"
    img = read_png(v.shot("box"))
    px0, py, pw, _ph = z["plot"]
    top = series_pixels(img, px0 + 45, px0 + pw - 5, py + 4, py + 8)
    assert top == 0, f"{top} pixels of the line at the plot's top edge: it runs off"


def test_gaps_nan_and_infinities_are_drawn_and_said_as_they_are(viewer: Callable[[], TruthViewer]) -> None:
    """Nothing is drawn across a 20 s silence; NaN breaks a line, ±inf stand at the edges marked; the
    pointer over NaN reads NaN; gauges, the LED and the String say NaN, +inf, -inf (a compass without a
    value shows no needle); no warning."""
    from tests.test_ui import read_png

    v = viewer()
    state = v.state()
    base = state["base"]
    assert state["readouts"] == {
        "dial": "NaN",
        "knob": "+inf",
        "compass": "NaN (no needle)",
        "thermo": "-inf",
        "led": "NaN",
        "string": "+inf",
        "nothing": "\u2014 (no needle)",
    }
    g = state["plots"]["G"]
    inside = (v.pixel_of("G", base + GAP[0] + 3.0), v.pixel_of("G", base + GAP[1] - 3.0))
    n = v.state()["plots"]["N"]
    assert n["marks"] == [[False, True, True]], "a +inf and a -inf mark, no sample alone"
    x, y = v.pixel_of("N", base + 30.45), v.at("N", 0.5)[1]
    v.move(x, y)
    state = v.wait_for(lambda s: s["plots"]["N"]["hover_time"] is not None)
    n = state["plots"]["N"]
    assert math.isnan(n["hover_values"][0]), n["hover_values"]
    assert n["tags"] == ["NaN"]
    v.move(*v.at("dial", 0.5))
    v.wait_for(lambda s: s["plots"]["N"]["hover_time"] is None)
    img = read_png(v.shot("truth"))
    _gx, gy, _gw, gh = g["plot"]
    across = series_pixels(img, inside[0], inside[1], gy + 30, gy + gh - 30)
    assert across == 0, f"{across} pixels of a line across the silence"
    nan_x = (v.pixel_of("N", base + 30.1), v.pixel_of("N", base + 30.8))
    _nx, ny, _nw, nh = n["plot"]
    assert series_pixels(img, nan_x[0], nan_x[1], ny + 30, ny + nh - 30) == 0, "nothing drawn over NaN"
    assert v.proc.poll() is None, v.output()
