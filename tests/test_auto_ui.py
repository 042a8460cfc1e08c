"""The automatic dashboard in the real viewer: panels by robot and namespace, every tag bound once, live,
in natural order; tags seen later join their panel; what the user moved stays; swapping a widget's kind."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import threading
import time
import warnings
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from dbglog._ros._tags import natural_key
from dbglog.viewer._document._dashboard import WidgetConfig, parse_dashboard
from dbglog.viewer._widgets import WidgetRegistry
from tests._ros import first_line
from tests._viewer_child import ViewerChild
from tests.test_demo import display as display  # the shared fixture: a display for the viewer
from tests.test_ui import read_png

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parent.parent


def test_auto_dashboard_puts_each_kind_of_tag_in_its_panel(display: dict[str, str], tmp_path: Path) -> None:
    """`dbglog view --report-json`: a Float64, a Bool, a String, a Float64MultiArray and a dict logged with
    dbglog share one panel: numbers in plots (a gauge where the name tells the range), the array's
    elements in a plot of its own, the bool and the text in a States widget; each bound once, all live."""
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
    mine = [w for w in data["widgets"] if w["panel"] == "autoui"]
    kinds = Counter(w["type"] for w in mine)
    assert kinds["states"] == 1
    assert kinds["compass"] == 1
    assert kinds["thermo"] == 1
    series = Counter(
        (b["topic"].removeprefix("/rosdashboard/autoui/"), b["field"])
        for w in mine
        if w["type"] in ("plot", "states")
        for b in w["bindings"]
    )
    assert series == Counter(
        {
            ("speed", ""): 1,
            ("sound/azimuth", ""): 1,
            ("sound/confidence", ""): 1,
            ("ranges", "data[0]"): 1,
            ("ranges", "data[1]"): 1,
            ("ranges", "data[2]"): 1,
            ("bumper", ""): 1,
            ("state", ""): 1,
        }
    ), series
    states = next(w for w in mine if w["type"] == "states")
    assert [b["topic"] for b in states["bindings"]] == [
        "/rosdashboard/autoui/bumper",
        "/rosdashboard/autoui/state",
    ]
    compass = next(w for w in mine if w["type"] == "compass")
    assert compass["bindings"][0]["topic"] == "/rosdashboard/autoui/sound/azimuth"
    assert all(w["status"] == "live" for w in mine), [(w["name"], w["status"], w["reason"]) for w in mine]
    (panel,) = [p for p in data["panels"] if p["title"] == "autoui"]
    assert sorted(panel["widgets"]) == sorted(w["name"] for w in mine)
    px, py, pw, ph = panel["rect"]
    loaded = parse_dashboard(data["dashboard"], WidgetRegistry.builtin().get)
    assert loaded.messages == []
    configs = {w.name: w for w in loaded.dashboard.widgets if isinstance(w, WidgetConfig)}
    for w in mine:  # inside the panel's frame, below its title
        c = configs[w["name"]]
        assert px < c.x
        assert c.x + c.width < px + pw
        assert py + 20 < c.y
        assert c.y + c.height < py + ph
    img = read_png(png)
    assert img.shape[0] >= 600
    assert len({tuple(p) for p in img[100:600:7, 300:1200:7, :3].reshape(-1, 3).tolist()}) > 100


def run_here(scenario: str, tmp: str) -> None:
    """Child-process body (one Dear PyGui context each).

    ``moves``: a static source; tags placed around a widget the user moved, tags seen later joining their
    panel, a widget's kind swapped. ``fleet``: the real engine beside two robots; the frame hook reports
    its state and, when asked, the report `--report-json` writes.
    """
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    if scenario == "fleet":
        _fleet_viewer(Path(tmp))
    else:
        _moves(Path(tmp))


def _frames_until(app: Any, done: Any, timeout: float = 20.0) -> None:
    """Render frames until `done()` holds (the plan waits for a quiet graph and the tags' values)."""
    deadline = time.monotonic() + timeout
    while not done():
        assert time.monotonic() < deadline, "the automatic dashboard did not place the tags in time"
        app.frame()
        time.sleep(0.02)


def _moves(tmp: Path) -> None:
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._ui._auto import AutoDashboard
    from dbglog.viewer._widgets._geometry import Rect, overlaps

    source = StaticSource()
    app = ViewerApp(source, WidgetRegistry.builtin(), width=1200, height=800)
    app.start()
    try:
        auto = AutoDashboard(app, period=0.0)
        auto.install()

        def number(topic: str, value: float) -> None:
            source.add_topic(topic, "std_msgs/msg/Float64")
            for _ in range(12):
                source.push(topic, "", value)

        number("/rosdashboard/a/x", 1.0)
        _frames_until(app, lambda: len(app.items) == 1 and not auto.pending)
        (first,) = app.items
        assert first.config.type == "plot"
        assert auto.frames.drawn == [("a", auto.plan.panels[0].rect)]
        # The user drags the plot to where the next panel would go (to its right on the same row).
        panel = auto.plan.panels[0].rect
        target = Rect(panel.x + panel.w + 20, panel.y, 420, 200)
        first.place(target, rebuild=True)
        source.add_topic("/rosdashboard/b/near", "std_msgs/msg/Bool")
        source.add_topic("/rosdashboard/b/mode", "std_msgs/msg/String")
        source.add_topic("/other/twist", "geometry_msgs/msg/Twist")  # not a tag: left out without --all
        _frames_until(app, lambda: len(app.items) == 2 and not auto.pending)
        assert first.rect == target, "the automatic dashboard never moves what the user placed"
        states = app.items[1]
        assert (states.name, states.config.type) == ("b states", "states")
        assert [b.topic for b in states.bindings] == ["/rosdashboard/b/mode", "/rosdashboard/b/near"]
        assert not overlaps(states.rect, first.rect)
        frames = dict(auto.frames.drawn)
        assert set(frames) == {"a", "b"}
        assert not overlaps(frames["b"], first.rect)
        # Tags seen later join their panel: the plot gains a series (natural order), the lamps a lamp.
        number("/rosdashboard/a/x10", 2.0)
        number("/rosdashboard/a/x2", 3.0)
        source.add_topic("/rosdashboard/b/ahead", "std_msgs/msg/Bool")
        _frames_until(
            app, lambda: len(first.bindings) == 3 and len(states.bindings) == 3 and not auto.pending
        )
        assert len(app.items) == 2, "tags that fit join the widgets there: no new widget"
        assert [b.topic.rsplit("/", 1)[-1] for b in first.bindings] == ["x", "x2", "x10"]
        assert [b.topic.rsplit("/", 1)[-1] for b in states.bindings] == ["ahead", "mode", "near"]
        assert first.rect == target
        assert source.bound >= {*first.bindings, *states.bindings}
        assert not app.doc.dirty, "what the automatic dashboard adds is not an edit of the user's"
        app.frame()
        # A widget the user changed gains nothing: a later tag gets a widget of its own.
        app.apply_bindings(states, (Binding("/rosdashboard/b/near"),))
        source.add_topic("/rosdashboard/b/behind", "std_msgs/msg/Bool")
        _frames_until(app, lambda: len(app.items) == 3 and not auto.pending)
        assert [b.topic for b in states.bindings] == ["/rosdashboard/b/near"]
        assert [b.topic for b in app.items[2].bindings] == ["/rosdashboard/b/behind"]
        for a in app.items:
            for b in app.items:
                assert a is b or not overlaps(a.rect, b.rect)

        # Change widget type: same name, place and bindings; a shared property keeps its value.
        led = states
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
        app.screenshot(tmp / "swap.png")
    finally:
        app.close()


def test_auto_mode_places_around_user_moves_joins_later_tags_and_swaps_kinds(
    display: dict[str, str], tmp_path: Path
) -> None:
    """New panels avoid what the user moved; later tags join their panel's widgets (a plot gains a series, the
    States widget a lamp) unless the user changed them; a swapped kind keeps name and bindings."""
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        "from tests import test_auto_ui; test_auto_ui.run_here('moves', sys.argv[1])"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, str(tmp_path)],
        env=display,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
        cwd=ROOT,
    )
    assert proc.returncode == 0, f"{proc.stdout}\n{proc.stderr}"
    assert (tmp_path / "swap.png").stat().st_size > 0


# -- a fleet: two robots of 300 tags each, real processes, the real engine -----------------------------


def _fleet_viewer(tmp: Path) -> None:
    """Child: the viewer on the live graph, the automatic dashboard, a probe reporting its state."""
    from dbglog.viewer import Engine
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._auto import AutoDashboard, all_live, widget_report

    engine = Engine(stale_after=2.0)
    engine.start()
    app = ViewerApp(engine, WidgetRegistry.builtin(), width=1440, height=900)
    app.start()
    try:
        auto = AutoDashboard(app)
        auto.install()
        started = time.monotonic()
        last = [0.0]

        def probe() -> None:
            now = time.monotonic()
            asked = tmp / "report.request"
            if asked.exists():
                out = tmp / "report.json.tmp"
                out.write_text(json.dumps(widget_report(app, auto=auto)))
                out.replace(tmp / "report.json")
                asked.unlink()
            if now - last[0] < 0.25:
                return
            last[0] = now
            state = {
                "since": now - started,
                "widgets": len(app.items),
                "tags": sum(1 for t in app.source.topics() if t.robot in ("/robot1", "/robot2")),
                "bound": len(
                    {b.topic for i in app.items for b in i.bindings if b.topic.startswith("/robot")}
                ),
                "pending": auto.pending,
                "live": all_live(app),
                "rendered": app.loop.rendered,
            }
            out = tmp / "state.json.tmp"
            out.write_text(json.dumps(state))
            out.replace(tmp / "state.json")

        app.frame_hooks.append(probe)
        app.run()
    finally:
        app.close()
        engine.stop()


def _robot(namespace: str, *args: str) -> subprocess.Popen[str]:
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT", "DBGLOG_NAMESPACE")}
    env["PYTHONPATH"] = str(ROOT)
    env["DBGLOG_NAMESPACE"] = namespace
    proc = subprocess.Popen(
        [sys.executable, "-m", "benchmarks._fleet", *args],
        env=env,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    assert proc.stdout is not None
    assert first_line(proc.stdout) == "publishing", "the robot process did not start"
    return proc


@pytest.fixture
def fleet() -> Iterator[list[subprocess.Popen[str]]]:
    """Two robots running the same program, 300 tags each at 10 Hz, in /robot1 and /robot2."""
    procs = [_robot("robot1"), _robot("robot2")]
    yield procs
    for proc in procs:
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
        proc.wait(10)
        if proc.stdout is not None:
            proc.stdout.close()


class FleetViewer(ViewerChild):
    """The fleet viewer in a child process, reporting its rendered frames as ``rendered``."""

    frame_key = "rendered"

    def __init__(self, tmp: Path, display: str) -> None:
        super().__init__("fleet", tmp, display, "test_auto_ui", probe=tmp)

    def report(self) -> dict[str, Any]:
        """The widget report as `--report-json` writes it, taken now."""
        (self.tmp / "report.json").unlink(missing_ok=True)
        (self.tmp / "report.request").touch()
        self.wait_for(lambda _s: (self.tmp / "report.json").exists())
        return dict(json.loads((self.tmp / "report.json").read_text()))


def _panels_in_natural_order(report: dict[str, Any]) -> None:
    """Panels titled robot1:s0 ... robot2:s14 in natural order, read left to right and top to bottom."""
    panels = [p for p in report["panels"] if p["robot"] in ("/robot1", "/robot2")]
    titles = [p["title"] for p in panels]
    assert titles == [f"robot{r}:s{k}" for r in (1, 2) for k in range(15)], titles
    places = [(p["rect"][1], p["rect"][0]) for p in panels]
    assert places == sorted(places), "panels are placed in natural order"


def test_two_robots_of_300_tags_get_a_panel_each_subsystem(
    fleet: list[subprocess.Popen[str]], display: dict[str, str], tmp_path: Path
) -> None:
    """Two robots (real processes, 300 tags each through the SDK): at most 100 widgets, every tag bound
    exactly once and live within seconds, a panel per robot and subsystem in natural order, each widget's
    series in natural order; tags a robot logs later join their panel's plot and States widget, and no
    widget moves."""
    v = FleetViewer(tmp_path, display["DISPLAY"])
    try:
        state = v.wait_for(lambda s: s["widgets"] >= 90 and not s["pending"] and s["live"], timeout=60)
        print(f"\nfleet: every tag placed and live {state['since']:.1f} s after the dashboard started")
        assert state["since"] <= 15.0, "every tag bound and live within 15 s"
        report = v.report()
        widgets = [w for w in report["widgets"] if (w["panel"] or "").startswith(("robot1:", "robot2:"))]
        assert len(widgets) <= 100
        assert all(w["status"] == "live" for w in widgets), [w for w in widgets if w["status"] != "live"][:3]
        series = Counter(
            b["topic"] for w in widgets if w["type"] in ("plot", "states") for b in w["bindings"]
        )
        expected = {f"/robot{r}/rosdashboard/s{k}/{t}" for r in (1, 2) for k in range(15) for t in _TAGS}
        assert set(series) == expected
        assert set(series.values()) == {1}, "every tag is bound exactly once"
        _panels_in_natural_order(report)
        for w in widgets:
            topics = [b["topic"] for b in w["bindings"]]
            assert topics == sorted(topics, key=natural_key)
            assert {t.rsplit("/", 1)[0] for t in topics} == {f"/{w['panel'].replace(':', '/rosdashboard/')}"}
        before = {w["name"]: w for w in report["dashboard"]["widgets"]}

        late = _robot("robot1", "--subsystems", "1", "--tags", "0", "--late", "0.01")
        try:
            v.wait_for(lambda s: s["bound"] == 602 and not s["pending"], timeout=30)
            report = v.report()
        finally:
            late.kill()
            late.wait(10)
            if late.stdout is not None:
                late.stdout.close()
        after = {w["name"]: w for w in report["dashboard"]["widgets"]}
        # The state joins the panel's States widget. The number joins a plot of its panel whose magnitudes
        # lie within a decade of its own and that has room; whether one has depends on the magnitudes the
        # first samples of the panel's sines showed (a loaded machine sees fewer before placing), so it may
        # instead get a plot of its own in its panel: no other widget is new.
        new = set(after) - set(before)
        assert new <= {"robot1:s0/v_late"}, f"the later tags joined widgets there: new {sorted(new)}"
        assert set(before) <= set(after)
        for name, w in before.items():
            assert (after[name]["x"], after[name]["y"]) == (w["x"], w["y"]), f"{name} moved"
        joined = {
            b["topic"].rsplit("/", 1)[-1]: w
            for w in report["widgets"]
            for b in w["bindings"]
            if b["topic"].rsplit("/", 1)[-1] in ("v_late", "late_flag")
        }
        assert joined["v_late"]["type"] == "plot"
        assert joined["v_late"]["panel"] == "robot1:s0"
        assert joined["late_flag"]["type"] == "states"
        assert joined["late_flag"]["panel"] == "robot1:s0"
        topics = [b["topic"] for b in joined["late_flag"]["bindings"]]
        assert topics == sorted(topics, key=natural_key)
    finally:
        v.stop()


_TAGS = [f"v{j}" for j in range(14)] + ["ok", "fault", "ready", "state", "mode", "error"]
