"""The auto-dashboard in the real viewer: a node's tags become fitting widgets; swapping a widget's kind."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
import warnings
from pathlib import Path

import pytest

from dbglog.viewer._document._dashboard import WidgetConfig, parse_dashboard
from dbglog.viewer._widgets import WidgetRegistry
from tests.test_demo import display as display  # the shared fixture: a display for the viewer
from tests.test_ui import read_png

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parent.parent


def test_auto_dashboard_picks_a_widget_per_kind_of_tag(display: dict[str, str], tmp_path: Path) -> None:
    """Float64, Bool, String, a Float64MultiArray and a dict logged with dbglog get plot, LED, text, ..."""
    import dbglog

    stop = threading.Event()

    def node() -> None:
        i = 0
        while not stop.is_set():
            i += 1
            dbglog.logfloat("autoui/speed", 0.1 * i)
            dbglog.logbool("autoui/bumper", i % 2 == 0)
            dbglog.logstring("autoui/state", f"step {i}")
            dbglog.log("autoui/ranges", [1.0, 2.0, float(i)])
            dbglog.log("autoui/sound", {"azimuth": 0.5, "confidence": 0.8})
            time.sleep(0.05)

    thread = threading.Thread(target=node, daemon=True)
    thread.start()
    png, report = tmp_path / "auto.png", tmp_path / "auto.json"
    try:
        proc = subprocess.run(
            [
                *(sys.executable, "-m", "dbglog", "view", "--screenshot", str(png), "--after", "5"),
                *("--wait-live", "20", "--report-json", str(report)),
            ],
            env=display,
            capture_output=True,
            text=True,
            timeout=90,
            check=False,
        )
    finally:
        stop.set()
        thread.join(5)
    assert proc.returncode == 0, proc.stderr
    data = json.loads(report.read_text())
    mine = [w for w in data["widgets"] if w["name"].startswith("autoui/")]
    by_name: dict[str, list[str]] = {}
    for w in mine:
        by_name.setdefault(w["name"], []).append(w["type"])
    assert by_name == {
        "autoui/speed": ["plot"],
        "autoui/bumper": ["led"],
        "autoui/state": ["string"],
        "autoui/ranges": ["plot"],
        "autoui/sound/azimuth": ["plot", "compass"],
        "autoui/sound/confidence": ["plot", "thermo"],
    }, by_name
    ranges = next(w for w in mine if w["name"] == "autoui/ranges")
    assert [b["field"] for b in ranges["bindings"]] == ["data[0]", "data[1]", "data[2]"]
    assert all(w["status"] == "live" for w in mine), [(w["name"], w["status"], w["reason"]) for w in mine]
    # The dict's sub-tags sit together: every widget of the group shares the group's rows.
    loaded = parse_dashboard(data["dashboard"], WidgetRegistry.builtin().get)
    assert loaded.messages == []
    configs = [w for w in loaded.dashboard.widgets if isinstance(w, WidgetConfig)]
    sound_rows = {w.y for w in configs if w.name.startswith("autoui/sound/")}
    other_rows = {w.y for w in configs if not w.name.startswith("autoui/sound/")}
    assert sound_rows
    assert not sound_rows & other_rows
    img = read_png(png)
    assert img.shape[0] >= 600
    assert len({tuple(p) for p in img[100:600:7, 300:1200:7, :3].reshape(-1, 3).tolist()}) > 100


def run_here(tmp: str) -> None:
    """Child-process body (one Dear PyGui context each): auto-add around a user's move, then swap kinds."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._ui._auto import AutoDashboard
    from dbglog.viewer._widgets._geometry import Rect

    source = StaticSource()
    app = ViewerApp(source, WidgetRegistry.builtin(), width=1200, height=800)
    app.start()
    try:
        auto = AutoDashboard(app, period=0.0)
        auto.install()
        source.add_topic("/rosdashboard/a/x", "std_msgs/msg/Float64")
        source.push("/rosdashboard/a/x", "", 1.0)
        app.frame()
        (first,) = app.items
        assert first.config.type == "plot"
        # The user drags the plot to where the next widgets of group "b" would go.
        target = Rect(auto.layout.origin[0], first.rect.y + first.rect.h + auto.layout.gap, 500, 190)
        first.place(target, rebuild=True)
        source.add_topic("/rosdashboard/b/near", "std_msgs/msg/Bool")
        source.add_topic("/rosdashboard/b/mode", "std_msgs/msg/String")
        source.add_topic("/other/twist", "geometry_msgs/msg/Twist")
        app.frame()
        assert first.rect == target, "auto mode never moves what the user placed"
        names = [i.name for i in app.items]
        assert names == ["a/x", "b/mode", "b/near"], names
        for a in app.items:
            for b in app.items:
                if a is not b:
                    ra, rb = a.rect, b.rect
                    assert (
                        ra.x + ra.w <= rb.x
                        or rb.x + rb.w <= ra.x
                        or ra.y + ra.h <= rb.y
                        or rb.y + rb.h <= ra.y
                    )

        # Change widget type: same name, place and bindings; a shared property keeps its value.
        led = next(i for i in app.items if i.name == "b/near")
        dial = app.add_widget("dial", 600, 400, name="speed")
        assert dial is not None
        app.apply_bindings(dial, (Binding("/rosdashboard/a/x"),))
        dial.set_properties({"minimum": -5.0, "maximum": 5.0})
        thermo = app.canvas.change_type(dial, "thermo")
        assert thermo is not None
        assert dial not in app.items
        assert (thermo.name, thermo.config.type, thermo.bindings) == ("speed", "thermo", dial.bindings)
        assert (thermo.rect.x, thermo.rect.y) == (dial.rect.x, dial.rect.y)
        assert isinstance(thermo.config, WidgetConfig)
        assert thermo.config.properties["minimum"] == -5.0
        assert source.bound >= {Binding("/rosdashboard/a/x")}
        compass = app.canvas.change_type(led, "compass")
        assert compass is not None
        assert compass.rect.h >= compass.min_size[1]
        app.frame()
        app.screenshot(Path(tmp) / "swap.png")
    finally:
        app.close()


def test_auto_mode_places_around_user_moves_and_swaps_kinds(display: dict[str, str], tmp_path: Path) -> None:
    """New tags go to free cells, never moving the user's widgets; a swapped kind keeps name and bindings."""
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        "from tests import test_auto_ui; test_auto_ui.run_here(sys.argv[1])"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)],
        env=display,
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
        cwd=ROOT,
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "swap.png").stat().st_size > 0
