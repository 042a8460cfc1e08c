"""Dashboards that serve every robot, and the tag tree, in the real window with real input (xdotool under
Xvfb) beside two real robot processes running the same program in /robot1 and /robot2.

The viewer runs in a child process (`ViewerChild`): its frame hook reports what is on screen (the Robot
menu and its entries, the tree's rows, the widgets with the topics they show and their values, the values
the history holds at the cursor) and this process clicks, drags, types and presses keys. Nothing here calls
a handler.
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

import pytest

from tests._ros import first_line
from tests._viewer_child import ROOT, ViewerChild, report_frame

pytestmark = pytest.mark.gui

SIZE = (1300, 820)
ROBOTS = ("/robot1", "/robot2")
SPEED, RPM, BATTERY = "/rosdashboard/speed", "/rosdashboard/motor/rpm", "/rosdashboard/battery"

# One robot: the same program in each namespace (DBGLOG_NAMESPACE), its values told apart by `value`.
_ROBOT = """
import math, sys, time
import dbglog
value = float(sys.argv[1])
i = 0
while True:
    t = time.time()
    dbglog.logfloat("speed", value + math.sin(t))
    dbglog.logfloat("motor/rpm", 100 * value + 10 * math.sin(2 * t))
    dbglog.logfloat("motor/temp", 40 + value)
    dbglog.logfloat("battery", 12 - value / 10 + 0.02 * math.sin(t))
    dbglog.logstring("state", "driving" if i % 40 < 20 else "idle")
    if i == 0:
        print("publishing", flush=True)
    i += 1
    time.sleep(0.05)
"""


@pytest.fixture(scope="module")
def robots() -> Iterator[None]:
    """robot1 (its values around 1) and robot2 (around 2), for every test of the module."""
    procs = []
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    try:
        for n, robot in enumerate(ROBOTS, start=1):
            proc = subprocess.Popen(
                [sys.executable, "-c", _ROBOT, str(n)],
                env={**env, "DBGLOG_NAMESPACE": robot.lstrip("/")},
                stdout=subprocess.PIPE,
                text=True,
            )
            procs.append(proc)
            assert proc.stdout is not None
            assert first_line(proc.stdout) == "publishing", "a robot did not start"
        yield
    finally:
        for proc in procs:
            proc.send_signal(signal.SIGKILL)
            proc.wait(10)
            if proc.stdout is not None:
                proc.stdout.close()


# -- the child: a real viewer over the real engine ------------------------------------------------------


def dashboard(path: Path) -> Path:
    """A dial on the selected robot's battery and a plot of every robot's speed (a version 2 file)."""
    from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    widgets: list[WidgetConfig | RawWidget] = [
        WidgetConfig(
            "dial",
            "battery",
            20,
            20,
            240,
            260,
            (Binding(BATTERY, robot=SELECTED_ROBOT),),
            {"minimum": 11.5, "maximum": 12.0, "decimals": 3.0},
        ),
        WidgetConfig("plot", "speeds", 280, 20, 420, 260, (Binding(SPEED, robot=EVERY_ROBOT),), {}),
    ]
    save_dashboard(Dashboard(widgets), path)
    return path


def rect(item: int | str) -> list[float]:
    """An item's [x, y, w, h] in window pixels."""
    import dearpygui.dearpygui as dpg

    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


class Probe:
    """Frame hook: reports the Robot menu, the tree, the widgets and the history at the cursor."""

    def __init__(self, app: Any, folder: Path) -> None:
        self.app, self.folder, self.frame = app, folder, 0

    def state(self) -> dict[str, Any]:
        """What is on screen now."""
        import dearpygui.dearpygui as dpg

        app = self.app
        at = app.timeline.cursor
        store = app.source.store
        held = {}
        if at is not None:
            for robot in ROBOTS:
                sample = store.at(robot + BATTERY, at)
                held[robot] = sample.value if sample is not None else None
        tree = app.tree
        rows = []
        for row in tree.rows:
            node = tree.model.node(row.key) if row.key is not None else None
            if node is None or not dpg.is_item_shown(row.select) or not dpg.get_item_rect_size(row.select)[1]:
                continue  # not drawn yet
            button = rect(row.button) if dpg.is_item_shown(row.button) else None
            rows.append(
                {
                    "label": node.label,
                    "robot": node.robot,
                    "key": node.key,
                    "rect": rect(row.select),
                    "all": button,
                }
            )
        items = []
        for item in app.items:
            snaps = item.snapshots(app.canvas.snaps)
            items.append(
                {
                    "name": item.name,
                    "type": item.config.type,
                    "bindings": [[b.topic, b.field, b.robot] for b in item.bindings],
                    "series": [b.topic for b in item.series],
                    "values": [s.last for s in snaps],
                    "status": item.status.value,
                    "rect": [*app.canvas.to_window((item.rect.x, item.rect.y)), item.rect.w, item.rect.h],
                }
            )
        robots = app.robots
        # Dear PyGui gives a menu-bar menu no rectangle, only where its label starts in the bar; the robots'
        # entries are selectables, with rectangles while the menu is open.
        entries = {r: rect(e) for r, e in robots.entries.items() if dpg.is_item_visible(e)}
        return {
            "frame": self.frame,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "robots": app.fleet.robots,
            "selected": app.fleet.selected,
            "menu": [
                *dpg.get_item_state(robots.menu).get("pos", [0, 0]),
                *dpg.get_text_size(dpg.get_item_label(robots.menu)),
            ],
            "menu_label": dpg.get_item_label(robots.menu),
            "entries": entries,
            "filter": rect(tree.filter_input),
            "query": tree.model.query,
            "counts": dpg.get_value(tree.counts),
            "rows": rows,
            "items": items,
            "canvas": [*app.canvas.origin(), *app.canvas.size()],
            "cursor": at,
            "held": held,
            "dirty": app.doc.dirty,
            "status": dpg.get_value(app.status.info),
        }

    def hook(self) -> None:
        """Count the frames drawn and report."""
        self.frame = self.app.loop.rendered
        report_frame(self.app, self.folder, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the viewer and its tag tree over the live engine, on `dashboard`, till killed."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    with Engine(stale_after=1.0) as engine:
        app = ViewerApp(engine, registry, width=SIZE[0], height=SIZE[1], tag_tree=True)
        app.start()
        try:
            path = tmp / "robots.json"
            app.load(load_dashboard(path, registry.get), path)
            app.frame_hooks.append(Probe(app, tmp / "probe").hook)
            app.run()
        finally:
            app.close()


# -- this side -----------------------------------------------------------------------------------------


class Viewer(ViewerChild):
    """The viewer in a child process, reporting its drawn frames as ``frame``."""

    def __init__(self, tmp: Path, display: str) -> None:
        super().__init__("robots", tmp, display, "test_ui_robots")

    def widget(self, state: dict[str, Any], name: str) -> dict[str, Any]:
        """The reported widget called `name`."""
        found = [i for i in state["items"] if i["name"] == name]
        assert found, f"no widget {name!r}: {[i['name'] for i in state['items']]}"
        return dict(found[0])

    def row(self, state: dict[str, Any], label: str, robot: str | None) -> dict[str, Any]:
        """The tree row called `label` of `robot`, in view."""
        found = [r for r in state["rows"] if r["label"] == label and r["robot"] == robot]
        assert found, f"no row {label!r} of {robot}: {[(r['label'], r['robot']) for r in state['rows']]}"
        return dict(found[0])


def centre(r: list[float]) -> tuple[float, float]:
    """The middle of an [x, y, w, h] rectangle."""
    return r[0] + r[2] / 2, r[1] + r[3] / 2


@pytest.fixture
def viewer(robots: None, display: str, tmp_path: Path) -> Iterator[Callable[[], Viewer]]:
    """Start the viewer (with its dashboard) on the display; it is killed at the end."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start() -> Viewer:
        dashboard(tmp_path / "robots.json")
        v = Viewer(tmp_path, display)
        started.append(v)
        return v

    yield start
    for v in started:
        v.stop()


def both_robots_live(state: dict[str, Any]) -> bool:
    """The viewer has seen both robots, and the battery dial shows a value."""
    battery = next((i for i in state["items"] if i["name"] == "battery"), None)
    return state["robots"] == list(ROBOTS) and battery is not None and battery["values"][0] is not None


def battery_of(robot: str) -> float:
    """What a robot's battery reads (its program: 12 - n / 10, give or take 0.02)."""
    return 12 - int(robot[-1]) / 10


def test_the_robot_switcher_rebinds_every_widget_its_past_included(viewer: Callable[[], Viewer]) -> None:
    """The Robot menu lists both robots; picking the other one (clicks) shows its battery; paused,
    Ctrl+Up goes back and the dial shows the first robot's value at the cursor, from the history; the
    every-robot plot has one series per robot throughout."""
    v = viewer()
    v.ready()
    state = v.wait_for(both_robots_live)
    first = state["selected"]
    assert first in ROBOTS, "a robot is selected (the first found)"
    other = next(r for r in ROBOTS if r != first)
    assert state["menu_label"] == f"Robot: {first[1:]}"
    speeds = v.widget(state, "speeds")
    overlay = speeds["series"]  # in the order the robots were found, kept: the series keep their colours
    assert sorted(overlay) == ["/robot1" + SPEED, "/robot2" + SPEED]
    mx, my, tw, th = state["menu"]
    v.click(mx + tw / 2, my + th / 2 + 3)
    state = v.wait_for(lambda s: s["entries"].get(other, [0, 0, 0, 0])[3] > 0)
    v.click(*centre(state["entries"][other]))
    state = v.wait_for(lambda s: s["selected"] == other)
    state = v.wait_for(
        lambda s: (
            v.widget(s, "battery")["series"] == [other + BATTERY]
            and abs(v.widget(s, "battery")["values"][0] - battery_of(other)) < 0.05
        )
    )
    assert state["menu_label"] == f"Robot: {other[1:]}"
    assert not state["dirty"], "switching robots is no edit of the dashboard"
    assert v.widget(state, "speeds")["series"] == overlay, "a switch leaves the overlay as it was"

    v.key("space")  # pause: the dial shows the cursor's moment
    state = v.wait_for(
        lambda s: s["cursor"] is not None and v.widget(s, "battery")["values"][0] == s["held"][other]
    )
    cursor = state["cursor"]
    v.key("ctrl+Up")  # the previous robot (two robots: the first again), its past at the same moment
    state = v.wait_for(
        lambda s: s["selected"] == first and v.widget(s, "battery")["values"][0] == s["held"][first]
    )
    assert state["cursor"] == cursor, "switching robots keeps the moment shown"
    assert abs(state["held"][first] - battery_of(first)) < 0.05
    assert v.widget(state, "battery")["series"] == [first + BATTERY]
    assert v.shot("switched").stat().st_size > 0


def test_the_tag_tree_filters_drags_and_double_clicks_and_the_file_reopens_on_another_robot(
    viewer: Callable[[], Viewer], display: str, tmp_path: Path
) -> None:
    """Typed 'rpm' filters the tree; robot1's rpm dragged onto the canvas is a plot that follows the selected
    robot; robot2's motor double-clicked is a plot of robot2's rpm; a click on 'all' overlays speed across
    robots; Ctrl+S saves version 2, which opened with ``--robot robot2`` shows robot2's rpm."""
    v = viewer()
    v.ready()
    state = v.wait_for(both_robots_live)
    if state["selected"] != "/robot1":  # robot2 was found first: the next robot (of two) is robot1
        v.key("ctrl+Down")
    state = v.wait_for(
        lambda s: s["selected"] == "/robot1" and any(r["label"] == "robot2" for r in s["rows"])
    )
    v.click(*centre(state["filter"]))
    v.type("rpm")
    state = v.wait_for(lambda s: s["query"] == "rpm")
    assert [(r["label"], r["robot"]) for r in state["rows"]] == [
        ("robot1", "/robot1"),
        ("motor", "/robot1"),
        ("rpm", "/robot1"),
        ("robot2", "/robot2"),
        ("motor", "/robot2"),
        ("rpm", "/robot2"),
    ]
    matches, _, total, what = state["counts"].split()
    assert (matches, what) == ("2", "match")
    assert int(total) >= 10, "both robots' five tags (and the graph's other topics)"

    x, y, _, _ = state["canvas"]
    v.drag(centre(v.row(state, "rpm", "/robot1")["rect"]), (x + 120, y + 420))
    state = v.wait_for(lambda s: any(i["name"] == "rpm" for i in s["items"]))
    rpm = v.widget(state, "rpm")
    assert rpm["type"] == "plot"
    assert rpm["bindings"] == [[RPM, "", "$selected"]]
    assert rpm["series"] == ["/robot1" + RPM]

    start = centre(v.row(state, "motor", "/robot2")["rect"])
    v.move(*start)
    v.xdo("click", "--repeat", "2", "--delay", "80", "1")
    state = v.wait_for(lambda s: any(i["name"] == "motor" for i in s["items"]))
    assert v.widget(state, "motor")["bindings"] == [["/robot2" + RPM, "", ""]], "robot2's own, as filtered"

    v.click(*centre(state["filter"]))
    v.key("ctrl+a", "BackSpace")
    state = v.wait_for(lambda s: s["query"] == "" and any(r["label"] == "speed" for r in s["rows"]))
    button = v.row(state, "speed", "/robot1")["all"]
    assert button is not None, "a number tag both robots have offers the overlay"
    v.click(*centre(button))
    state = v.wait_for(lambda s: any(i["name"] == "speed (every robot)" for i in s["items"]))
    overlay = v.widget(state, "speed (every robot)")
    assert overlay["bindings"] == [[SPEED, "", "$every"]]
    assert sorted(overlay["series"]) == ["/robot1" + SPEED, "/robot2" + SPEED]

    v.key("ctrl+s")
    state = v.wait_for(lambda s: not s["dirty"])
    saved = json.loads((tmp_path / "robots.json").read_text())
    assert saved["version"] == 2
    by_name = {w["name"]: w for w in saved["widgets"]}
    assert by_name["rpm"]["bindings"] == [
        {"robot": "$selected", "topic": "rosdashboard/motor/rpm", "field": "", "regex": ""}
    ]
    v.stop()

    report = tmp_path / "report.json"
    shot = tmp_path / "robot2.png"
    done = subprocess.run(
        [
            sys.executable,
            "-m",
            "dbglog._cli",
            "view",
            str(tmp_path / "robots.json"),
            "--robot",
            "robot2",
            "--screenshot",
            str(shot),
            "--after",
            "3",
            "--wait-live",
            "20",
            "--report-json",
            str(report),
        ],
        env={**os.environ, "DISPLAY": display},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    shown = json.loads(report.read_text())
    assert shown["robot"] == "robot2"
    widgets = {w["name"]: w for w in shown["widgets"]}
    assert widgets["rpm"]["bindings"][0]["robot"] == "$selected"
    assert widgets["rpm"]["series"] == ["/robot2/rosdashboard/motor/rpm"]
    assert sorted(widgets["speed (every robot)"]["series"]) == [
        "/robot1/rosdashboard/speed",
        "/robot2/rosdashboard/speed",
    ]
    assert widgets["rpm"]["status"] == "live"
    assert 185 <= widgets["rpm"]["values"][0] <= 215, "robot2's rpm (robot1's is about 100)"
    assert 11.75 <= widgets["battery"]["values"][0] <= 11.85
    assert len(widgets["speed (every robot)"]["values"]) == 2


def test_keys_typed_in_the_tag_tree_filter_are_the_filter_s(viewer: Callable[[], Viewer]) -> None:
    """Space, the arrows and Delete typed in the tag tree's filter edit the text: they neither pause the
    dashboard, step its cursor, nor delete the selected widget (they did: only fields on the canvas held
    the keyboard)."""
    v = viewer()
    v.ready()
    state = v.wait_for(both_robots_live)
    battery = v.widget(state, "battery")
    v.click(battery["rect"][0] + 20, battery["rect"][1] + 10)  # select a widget: Delete would remove it
    v.click(*centre(state["filter"]))
    v.type("motor rpmx")
    v.key("Left", "Left", "Right", "BackSpace", "Delete", "End", "BackSpace")
    state = v.wait_for(lambda s: s["query"] == "motor r")  # rpmx: m and x deleted, then p
    time.sleep(0.5)  # a few frames more: a key that reached the canvas would have acted by now
    state = v.state()
    assert state["cursor"] is None, "still live: Space did not pause, the arrows stepped no cursor"
    assert any(i["name"] == "battery" for i in state["items"]), "Delete in the filter deleted a widget"
